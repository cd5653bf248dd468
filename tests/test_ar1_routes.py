"""The stationary AR(1) prior on every route: operators, evoked, epochs, raw, files, the CLI.

Each route gives :func:`skf_ref.ar1_priors` on the whitened lead field, with the sampling rate
of its MNE object; an EP-SNR and a time constant together are refused naming both; the
default (neither) is the paper's random walk at EP-SNR 0 dB, as before.
"""

import json

import mne
import numpy as np
import pytest

from skf_ref import (
    InputError,
    apply_skf,
    apply_skf_epochs,
    apply_skf_raw,
    ar1_priors,
    make_skf_operator,
    priors_from_snr,
    reconstruct,
)

SFREQ = 500.0
# The routes and reconstruct on the whitened arrays run the same spectral path on the same
# numbers, but for blocks of rows and the order of products: rounding only.
ROUTE_RTOL = 1e-10


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@pytest.fixture(scope="module")
def sample():
    """biosemi32 at 500 Hz on a sphere, a 30 mm grid, 8 epochs of 60 samples, a raw run."""
    montage = mne.channels.make_standard_montage("biosemi32")
    info = mne.create_info(montage.ch_names, SFREQ, "eeg").set_montage(montage)
    sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    src = mne.setup_volume_source_space(sphere=sphere, pos=30.0, verbose=False)
    forward = mne.make_forward_solution(info, None, src, sphere, verbose=False)
    rng = np.random.default_rng(42)
    wave = np.convolve(rng.standard_normal(60), np.exp(-np.arange(15) / 5.0))[:60]
    data = 1e-6 * rng.standard_normal((8, 32, 60))
    data += forward["sol"]["data"][:, [30]][None] * 3e-9 * wave
    epochs = mne.EpochsArray(data, info, tmin=-0.02, verbose=False)
    epochs.set_eeg_reference("average", projection=True, verbose=False)
    cov = mne.compute_covariance(epochs, verbose=False)
    raw = mne.io.RawArray(np.concatenate(list(epochs.get_data()), axis=1), info, verbose=False)
    raw.set_eeg_reference("average", verbose=False)
    return forward, epochs, cov, raw


def arrays_reconstruction(operator, data, nave, time_constant_ms, sfreq=SFREQ, **options):
    """What a route should give: reconstruct on the whitened arrays with ar1_priors."""
    whitened = np.sqrt(nave) * operator.whitener @ data
    theta0, q, rho = ar1_priors(operator.leadfield, 1.0, 0.0, time_constant_ms, sfreq)
    return reconstruct(
        operator.leadfield,
        whitened,
        noise_std=1.0,
        theta0=theta0,
        q=q,
        transition=rho,
        standardize="position",
        n_orient=3,
        **options,
    )


def test_an_operator_with_a_time_constant_is_ar1_priors_on_the_whitened_forward(sample):
    forward, epochs, cov, _ = sample
    evoked = epochs.average()
    operator = make_skf_operator(evoked.info, forward, cov, time_constant_ms=15.0)
    assert (operator.ep_snr_db, operator.time_constant_ms) == (None, 15.0)
    assert "PM-SNR 0 dB, time constant 15 ms>" in repr(operator)
    assert "time constant" in operator._repr_html_()
    stc, rec = apply_skf(evoked, operator, smoother=None, return_reconstruction=True)
    data = operator.select(evoked.info, evoked.data)
    expected = arrays_reconstruction(operator, data, evoked.nave, 15.0)
    assert rec.transition == pytest.approx(np.exp(-2.0 / 15.0), rel=1e-15)
    assert (rec.theta0, rec.q) == (expected.theta0, expected.q)
    assert relative(rec.z, expected.z) <= ROUTE_RTOL
    # the one-call route makes the same operator
    once = apply_skf(evoked, forward, cov, time_constant_ms=15.0, smoother=None)
    assert relative(once.data, stc.data) <= ROUTE_RTOL  # one SVD each: rounding only
    # an operator of the random walk, the time constant given where it is applied
    walk = make_skf_operator(evoked.info, forward, cov, ep_snr_db=0.0)
    given_here = apply_skf(evoked, walk, time_constant_ms=15.0, smoother=None).data
    assert relative(given_here, stc.data) <= ROUTE_RTOL


@pytest.mark.filterwarnings("ignore:tune. time_constant_ms")
def test_the_default_is_the_ar1_prior_chosen_by_the_data_and_ep_snr_gives_the_walk(sample):
    # the evidence study v3's rule (validation/report/default.json)
    forward, epochs, cov, _ = sample
    evoked = epochs.average()
    operator = make_skf_operator(evoked.info, forward, cov)
    assert operator.ep_snr_db is None and "time constant" in repr(operator)
    _, rec = apply_skf(evoked, forward, cov, return_reconstruction=True)
    tau = rec.tuning.time_constant_ms
    assert 1.0 <= tau <= 1000.0
    dt_ms = 1e3 / evoked.info["sfreq"]
    assert rec.transition == pytest.approx(np.exp(-dt_ms / tau), rel=1e-12)
    assert rec.settings["smoother"] == "rts-smoothed-weights"
    # the 0.4 default, one argument away: the random walk at EP-SNR 0 dB
    walk = make_skf_operator(evoked.info, forward, cov, ep_snr_db=0.0)
    assert (walk.ep_snr_db, walk.time_constant_ms) == (0.0, None)
    assert repr(walk).endswith("PM-SNR and EP-SNR 0 dB, 0 dB>")
    _, rec = apply_skf(evoked, walk, smoother=None, return_reconstruction=True)
    theta0, q = priors_from_snr(walk.leadfield, 1.0, 0.0, 0.0, n_steps=evoked.data.shape[1])
    assert (rec.theta0, rec.q, rec.transition) == (theta0, q, 1.0)


@pytest.mark.filterwarnings("ignore:The measurement information indicates a low-pass")
def test_epochs_take_the_time_constant_at_their_sampling_rate(sample):
    forward, epochs, cov, _ = sample
    ar1 = make_skf_operator(epochs.info, forward, cov, time_constant_ms=8.0)
    walk = make_skf_operator(epochs.info, forward, cov, ep_snr_db=0.0)
    by_operator = apply_skf_epochs(epochs[:3], ar1, smoother="rts-state")
    by_call = apply_skf_epochs(epochs[:3], walk, smoother="rts-state", time_constant_ms=8.0)
    for k, (a, b) in enumerate(zip(by_operator, by_call, strict=True)):
        assert relative(a.data, b.data) <= ROUTE_RTOL
        evoked = mne.EvokedArray(epochs.get_data()[k], epochs.info, tmin=epochs.times[0])
        alone = apply_skf(evoked, ar1, smoother="rts-state").data  # stacked vs alone
        assert relative(a.data, alone) <= ROUTE_RTOL
    # twice the sampling rate: the same time constant is twice as many samples
    decimated = epochs.copy().decimate(2)
    _, rec = apply_skf(decimated.average(), ar1, return_reconstruction=True)
    assert rec.transition == pytest.approx(np.exp(-4.0 / 8.0), rel=1e-15)


@pytest.mark.parametrize("smoother", [None, "rts-standardized", "rts-state"])
def test_raw_runs_the_ar1_prior_held_and_streamed(sample, tmp_path, smoother):
    pytest.importorskip("zarr")
    forward, epochs, cov, raw = sample
    operator = make_skf_operator(raw.info, forward, cov, time_constant_ms=10.0)
    stc, rec = apply_skf_raw(raw, operator, smoother=smoother, return_reconstruction=True)
    assert 0 < rec.lazy_outputs.steady < raw.n_times  # the steady state is held
    data = operator.select(raw.info, raw.get_data())
    expected = arrays_reconstruction(operator, data, 1, 10.0, smoother=smoother)
    assert relative(rec.z, expected.z) <= ROUTE_RTOL
    store = apply_skf_raw(raw, operator, smoother=smoother, out=tmp_path / "r.zarr")
    assert relative(np.asarray(store["data"][:]), stc.data) <= ROUTE_RTOL
    # the same with the operator's random walk and the time constant given here
    walk = make_skf_operator(raw.info, forward, cov, ep_snr_db=0.0)
    again = apply_skf_raw(raw, walk, smoother=smoother, time_constant_ms=10.0)
    assert relative(again.data, stc.data) <= ROUTE_RTOL


def test_a_raw_segment_filtered_does_not_depend_on_what_follows(sample):
    forward, _, cov, raw = sample
    ar1 = make_skf_operator(raw.info, forward, cov, time_constant_ms=10.0)
    walk = make_skf_operator(raw.info, forward, cov, ep_snr_db=0.0)
    for operator, same in ((ar1, True), (walk, False)):  # the filter: no smoother
        whole = apply_skf_raw(raw, operator, 0, 400, smoother=None).data[:, :200]
        first = apply_skf_raw(raw, operator, 0, 200, smoother=None).data
        assert (relative(first, whole) <= ROUTE_RTOL) == same


@pytest.mark.filterwarnings("ignore:tune. (pm_snr_db|time_constant_ms)")
def test_auto_chooses_the_time_constant_and_says_so(sample, capsys):
    forward, epochs, cov, raw = sample
    evoked = epochs.average()
    stc, rec = apply_skf(
        evoked, forward, cov, time_constant_ms="auto", return_reconstruction=True, verbose=True
    )
    chosen = rec.tuning.time_constant_ms
    assert 1.0 <= chosen <= 1000.0 and rec.tuning.ep_snr_db is None
    assert rec.transition == rec.tuning.transition == pytest.approx(np.exp(-2.0 / chosen))
    # logged to two significant digits, the precision the search settles to
    assert f"time constant {float(f'{chosen:.2g}'):g} ms" in capsys.readouterr().err
    operator = make_skf_operator(raw.info, forward, cov, pm_snr_db=0.0)
    _, rec = apply_skf_raw(
        raw, operator, time_constant_ms=(2.0, 200.0), return_reconstruction=True
    )
    assert 2.0 <= rec.tuning.time_constant_ms <= 200.0 and rec.tuning.pm_snr_db == 0.0


def test_an_ep_snr_and_a_time_constant_together_are_refused(sample):
    forward, epochs, cov, raw = sample
    evoked = epochs.average()
    both = r"give ep_snr_db \(the paper's random walk\) or time_constant_ms .* not both"
    with pytest.raises(InputError, match=both + ": got ep_snr_db=20 and time_constant_ms=15"):
        make_skf_operator(evoked.info, forward, cov, ep_snr_db=20, time_constant_ms=15)
    with pytest.raises(InputError, match=both):
        apply_skf(evoked, forward, cov, ep_snr_db=0.0, time_constant_ms="auto")
    operator = make_skf_operator(evoked.info, forward, cov)
    with pytest.raises(InputError, match="time_constant_ms must be > 0, got -5.0"):
        apply_skf_raw(raw, operator, time_constant_ms=-5.0)
    with pytest.raises(InputError, match="time_constant_ms must be a number of milliseconds"):
        apply_skf_epochs(epochs, operator, time_constant_ms="slow", return_generator=True)
    with pytest.raises(InputError, match=r"time_constant_ms must be a range \(low, high\)"):
        make_skf_operator(evoked.info, forward, cov, time_constant_ms=(50.0, 5.0))
    with pytest.raises(InputError, match="sfreq must be > 0, got 0.0"):
        operator.reconstruct(operator.select(evoked.info, evoked.data), time_constant_ms=5.0,
                             sfreq=0.0)  # fmt: skip


# --- the command line ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def files(tmp_path_factory, sample):
    forward, epochs, cov, _ = sample
    folder = tmp_path_factory.mktemp("ar1")
    evoked = epochs.average()
    mne.write_evokeds(folder / "e-ave.fif", evoked, verbose=False)
    mne.write_forward_solution(folder / "f-fwd.fif", forward, verbose=False)
    mne.write_cov(folder / "n-cov.fif", cov, verbose=False)
    L = forward["sol"]["data"]
    np.save(folder / "L.npy", L - L.mean(axis=0))
    np.save(folder / "Y.npy", evoked.data - evoked.data.mean(axis=0))
    return folder


def test_the_array_route_takes_the_time_constant_at_sfreq(cli, files, tmp_path):
    L, Y = np.load(files / "L.npy"), np.load(files / "Y.npy")
    arrays = ["reconstruct", "--leadfield", str(files / "L.npy"), "--data", str(files / "Y.npy")]
    arrays += ["--noise-std", "1e-6"]
    result = cli(*arrays, "--time-constant-ms", "12", "--sfreq", "500", "--out",
                 str(tmp_path / "a.npz"), "--quiet")  # fmt: skip
    assert result.returncode == 0, result.stderr
    theta0, q, rho = ar1_priors(L, 1e-6, 0.0, 12.0, 500.0)
    expected = reconstruct(  # the command line's smoother is the package's default
        L, Y, noise_std=1e-6, theta0=theta0, q=q, transition=rho, smoother="rts-smoothed-weights"
    )
    assert relative(np.load(tmp_path / "a.npz")["z"], expected.z) <= ROUTE_RTOL
    settings = json.loads((tmp_path / "a.npz.json").read_text())
    assert (settings["time_constant_ms"], settings["sfreq"], settings["ep_snr_db"]) == (
        12.0,
        500.0,
        None,
    )
    result = cli(*arrays, "--time-constant-ms", "12", "--out", str(tmp_path / "b.npz"))
    assert result.returncode == 2
    assert "argument --time-constant-ms: needs the data's sampling rate" in result.stderr
    assert "give --sfreq (Hz)" in result.stderr


@pytest.mark.parametrize(
    "extra, message",
    [
        (
            ("--ep-snr-db", "20", "--time-constant-ms", "10"),
            "argument --time-constant-ms: give --ep-snr-db (the paper's random walk) or "
            "--time-constant-ms (the stationary AR(1) prior), not both",
        ),
        (("--time-constant-ms", "0"), "argument --time-constant-ms: must be > 0, got 0.0"),
        (("--time-constant-ms", "9,3"), "must be a range (low, high) with low < high"),
        (("--sfreq", "500"), "argument --sfreq: the MNE route takes the sampling rate from"),
    ],
)
def test_bad_time_constants_on_the_command_line(cli, files, tmp_path, extra, message):
    mne_route = ["reconstruct", "--forward", str(files / "f-fwd.fif"), "--evoked"]
    mne_route += [str(files / "e-ave.fif"), "--noise-cov", str(files / "n-cov.fif")]
    result = cli(*mne_route, *extra, "--out", str(tmp_path / "x.stc"))
    assert result.returncode == 2 and message in result.stderr


@pytest.mark.filterwarnings("ignore:tune. (pm_snr_db|time_constant_ms)")
def test_the_mne_route_reports_the_time_constant_it_chose(cli, files, tmp_path):
    mne_route = ["reconstruct", "--forward", str(files / "f-fwd.fif"), "--evoked"]
    mne_route += [str(files / "e-ave.fif"), "--noise-cov", str(files / "n-cov.fif")]
    result = cli(*mne_route, "--time-constant-ms", "auto", "--out", str(tmp_path / "t.stc"))
    assert result.returncode == 0, result.stderr
    assert "priors chosen by the data: PM-SNR 0.00 dB, time constant" in result.stderr
    settings = json.loads((tmp_path / "t.stc.json").read_text())
    assert settings["priors_searched"]["time_constant_ms"] == "auto"
    assert 1.0 <= settings["time_constant_ms"] <= 1000.0 and settings["sfreq"] == SFREQ
