"""Every input answered, v5 (issue 44): options never dropped, messages that name the cause.

Items 13-19 of the issue, and the estimate inside bad segments, NaN on every smoother.
"""

import json
import os
import warnings

import mne
import numpy as np
import pytest

import skf_ref
from skf_ref import InputError, apply_skf, apply_skf_raw, make_skf_operator, reconstruct
from skf_ref.io import read_data, read_leadfield, read_skf_operator
from skf_ref.method._standardization import check_positions_seen


@pytest.fixture(scope="module")
def arrays(tmp_path_factory):
    """A 16-channel lead field of 10 positions x 3 and data of a source at position 4."""
    folder = tmp_path_factory.mktemp("arrays")
    rng = np.random.default_rng(0)
    L = rng.standard_normal((16, 30))
    L -= L.mean(axis=0)
    x = np.zeros((30, 60))
    x[13] = 5 * np.hanning(60)  # position 4, its y component
    np.save(folder / "L.npy", L)
    np.save(folder / "Y.npy", L @ x + 0.1 * rng.standard_normal((16, 60)))
    np.savez(folder / "Y.npz", Y=np.load(folder / "Y.npy"))
    return folder


def _arrays(folder, *more):
    return ["reconstruct", "--leadfield", str(folder / "L.npy"), "--data", str(folder / "Y.npy"),
            "--noise-std", "0.1", *more]  # fmt: skip


# --- item 13: an option the route or the file does not use is refused ---------------------


@pytest.mark.parametrize(
    "more, message",
    [
        (["--condition", "1"],
         "argument --condition: {Y} is not an MNE -ave.fif: it holds one recording, no "
         "conditions to choose"),
        (["--pick-ori", "vector"], "argument --pick-ori: the MNE route's (--forward/--evoked)"),
        (["--key", "Y"], "argument --key: names a variable of .npz and .mat files, and neither"),
    ],
)  # fmt: skip
def test_the_array_route_refuses_what_it_would_drop(cli, arrays, tmp_path, more, message):
    result = cli(*_arrays(arrays, *more, "--out", str(tmp_path / "o.npz")))
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert message.format(Y=arrays / "Y.npy") in result.stderr
    assert not any(tmp_path.iterdir())  # before any work


def test_key_goes_to_the_file_that_has_variables(cli, arrays, tmp_path):
    arguments = _arrays(arrays, "--key", "Y", "--out", str(tmp_path / "o.npz"), "--quiet")
    arguments[4] = str(arrays / "Y.npz")  # the lead field .npy, the data .npz
    assert cli(*arguments).returncode == 0


@pytest.fixture(scope="module")
def mne_files(tmp_path_factory, mne_setup):
    folder = tmp_path_factory.mktemp("mne")
    epochs = mne_setup["make_epochs"](target=300, seed=6, n_epochs=5)
    epochs.save(folder / "e-epo.fif", verbose=False)
    mne.write_forward_solution(folder / "f-fwd.fif", mne_setup["forward"], verbose=False)
    return folder


@pytest.mark.parametrize(
    "more, message",
    [
        (["--key", "Y"], "argument --key: the array route's (--leadfield/--data)"),
        (["--average-reference"], "argument --average-reference: the array route's"),
        (["--condition", "0"], "argument --condition: {evoked} is not an MNE -ave.fif"),
    ],
)
def test_the_mne_route_refuses_what_it_would_drop(cli, mne_files, tmp_path, more, message):
    evoked = mne_files / "e-epo.fif"
    arguments = ["reconstruct", "--forward", str(mne_files / "f-fwd.fif"), "--evoked"]
    arguments += [str(evoked), "--noise-std", "1e-6", "--out", str(tmp_path / "o.npz"), *more]
    result = cli(*arguments)
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert message.format(evoked=evoked) in result.stderr
    assert not any(tmp_path.iterdir())


def test_the_readers_refuse_an_option_the_file_does_not_take(arrays):
    with pytest.raises(InputError, match=r"key='Y' names a variable of .npz and .mat files, and "
                       r".*L.npy is not one: give no key"):  # fmt: skip
        read_leadfield(arrays / "L.npy", key="Y")
    with pytest.raises(InputError, match=r"condition=1 chooses among the conditions of an MNE"):
        read_data(arrays / "Y.npy", condition=1)
    with pytest.raises(InputError, match=r"sfreq=1000.0 gives the sampling frequency of a .csv"):
        read_data(arrays / "Y.npz", sfreq=1000.0)
    assert read_data(arrays / "Y.npz", key="Y").data.shape == (16, 60)


# --- item 14: a folder named in SKF_REF_DATA that lacks files ------------------------------


def test_an_incomplete_named_folder_says_how_to_get_the_files(tmp_path, monkeypatch):
    from skf_ref.datasets import _paths as paths

    monkeypatch.setenv(paths.DATA_ENV, str(tmp_path))
    # the advice was data_path(download=True), which read the same variable and failed alike
    with pytest.raises(InputError, match=r"lacks fecnn/LICENSE: put the files there .* or "
                       r"unset \$SKF_REF_DATA and call skf_ref.datasets.data_path\(download=True\)"
                       ):  # fmt: skip
        skf_ref.datasets.data_path(download=True)
    with pytest.raises(InputError, match=r"or give no path and call .*data_path\(download=True"):
        skf_ref.datasets.data_path(tmp_path)


# --- item 15: a channel bad in the noise covariance ----------------------------------------


@pytest.mark.filterwarnings("ignore:Too few samples")
def test_a_channel_bad_in_the_noise_covariance_is_named_so(mne_setup):
    epochs = mne_setup["make_epochs"](target=300, seed=6, n_epochs=5)
    cov = mne.compute_covariance(epochs, verbose=False)
    cov["bads"] = ["Oz"]  # held by the covariance, marked bad there
    held = mne.pick_channels_cov(cov, exclude=["Iz"], verbose=False)  # not held at all
    operator = make_skf_operator(epochs.info, mne_setup["forward"], held, verbose=False)
    assert operator.dropped == {
        "not in the noise covariance": ["Iz"],
        "bad in the noise covariance": ["Oz"],
    }


# --- item 16: position blocks that no data can fill -----------------------------------------


def test_too_few_channels_for_three_orientations_is_named(mne_setup):
    info = mne.pick_info(mne_setup["info"], [0, 1, 2])
    operator = make_skf_operator(info, mne_setup["forward"], noise_std=1e-6, verbose=False)
    data = np.random.default_rng(0).standard_normal((3, 20)) * 1e-6
    evoked = mne.EvokedArray(data - data.mean(axis=0), info, verbose=False)
    evoked.set_eeg_reference("average", projection=True, verbose=False)
    with pytest.raises(InputError, match=r"has a singular block, rank 2 < 3 orientations .*: "
                       r"L, whitened, has rank 2 \(2 rows; a reference .*"
                       r"no position's 3 orientations can be told apart; give more channels"
                       ) as error:  # fmt: skip
        apply_skf(evoked, operator, standardize="position")
    assert "MEG" not in str(error.value)  # there is none


def test_an_unseen_orientation_is_named_as_such():
    L = np.random.default_rng(1).standard_normal((8, 6))
    L[:, 2] = L[:, 0] + L[:, 1]  # position 0 sees two orientations of its three
    with pytest.raises(InputError, match=r"position 0 \(columns 0-2 of L\) has a singular "
                       r"block, rank 2 < 3 .*: the sensors do not see one orientation of it"
                       ):  # fmt: skip
        check_positions_seen(L, np.eye(8), 3)


# --- item 17: NaN in the recording is no BAD_ annotation ------------------------------------


def test_a_gap_of_nan_is_logged_as_what_it_is(mne_setup, capsys):
    epochs = mne_setup["make_epochs"](target=300, seed=21, n_epochs=4)
    operator = make_skf_operator(epochs.info, mne_setup["forward"], noise_std=5e-6,
                                 verbose=False)  # fmt: skip
    data = np.concatenate(list(epochs.get_data()), axis=1)
    data[:, 100:120] = np.nan
    raw = mne.io.RawArray(data, epochs.info, verbose=False)
    raw.set_annotations(mne.Annotations([0.2], [0.01], ["BAD_blink"]))
    capsys.readouterr()
    stc = apply_skf_raw(raw, operator)
    log = capsys.readouterr().err
    assert "1 bad segment(s) (BAD_ annotations) skipped as missing observations, 10 of 240" in log
    gap = "1 gap(s) of NaN in every channel of the recording (no annotation) skipped as "
    assert gap + "missing observations, 20 of 240 samples, no estimate there: 0.100-0.119" in log
    assert np.isnan(stc.data[:, 100:120]).all() and np.isnan(stc.data[:, 200:210]).all()
    raw._data[:] = np.nan
    with pytest.raises(InputError, match=r"every sample from start to stop is NaN in every "
                       r"channel or lies in a bad segment"):  # fmt: skip
        apply_skf_raw(raw, operator)


# --- item 18: a named pipe, a device --------------------------------------------------------


@pytest.fixture
def odd_files(tmp_path):
    os.mkfifo(tmp_path / "pipe.csv")
    os.mkfifo(tmp_path / "pipe-skf.h5")
    os.mkfifo(tmp_path / "pipe-cov.fif")
    (tmp_path / "zero.npz").symlink_to("/dev/zero")
    return tmp_path


def test_what_is_no_regular_file_is_named(cli, odd_files, arrays):
    from skf_ref.conformance import export

    export(odd_files / "cases", ["npz"])
    case = odd_files / "cases" / "original_skf.npz"
    result = cli("compare", str(case), str(odd_files / "pipe.csv"))
    assert result.returncode == 2
    assert "pipe.csv: not a regular file but a named pipe (FIFO): give a file" in result.stderr
    result = cli("compare", str(case), str(odd_files / "zero.npz"))
    assert (
        result.returncode == 2
        and ("zero.npz: not a regular file but a character device (a link to /dev/zero)")
        in result.stderr
    )
    with pytest.raises(InputError, match=r"pipe-skf.h5: not a regular file but a named pipe"):
        read_skf_operator(odd_files / "pipe-skf.h5")
    for flag in ("--noise-cov", "--data", "--leadfield"):
        arguments = _arrays(arrays, "--out", str(odd_files / "o.npz"))
        if flag == "--noise-cov":  # MNE's reader would wait for a writer
            arguments[arguments.index("--noise-std") : arguments.index("--out")] = [
                flag, str(odd_files / "pipe-cov.fif")]  # fmt: skip
        else:
            arguments[arguments.index(flag) + 1] = str(odd_files / "pipe.csv")
        result = cli(*arguments)
        assert result.returncode == 2 and result.stderr.count("\n") == 1
        assert f"argument {flag}: {odd_files}/pipe" in result.stderr
        assert "not a regular file but a named pipe (FIFO): give a file" in result.stderr
    with pytest.raises(InputError, match=r"zero.npz: not a regular file but a character device"):
        read_data(odd_files / "zero.npz")


# --- item 19: the figure of an array estimate -----------------------------------------------


def test_the_plot_shows_positions_and_samples(cli, arrays, tmp_path, monkeypatch):
    import skf_ref.study._plots as plots

    drawn = {}
    original = plots.plot_estimate

    def recorded(amplitude, times, *args, **kwargs):
        drawn.update(amplitude=amplitude, times=times)
        fig = original(amplitude, times, *args, **kwargs)
        drawn["xlabel"] = fig.axes[0].get_xlabel()
        return fig

    monkeypatch.setattr(plots, "plot_estimate", recorded)
    plot = tmp_path / "p.png"
    arguments = _arrays(arrays, "--n-orient", "3", "--standardize", "position", "--out")
    assert cli(*arguments, str(tmp_path / "o.npz"), "--plot", str(plot), "--quiet").returncode == 0
    # the positions' amplitudes (10), not single columns of z (30); samples, not ms
    assert drawn["amplitude"].shape == (10, 60) and drawn["times"] is None
    assert drawn["xlabel"] == "sample" and plot.read_bytes()[:4] == b"\x89PNG"
    assert int(np.argmax(drawn["amplitude"].max(axis=1))) == 4  # the true source's position


# --- bad segments: no estimate on any smoother ----------------------------------------------


@pytest.mark.parametrize("method", ["spectral", "dense", "filterpy"])
@pytest.mark.parametrize("standardize", ["column", "position"])
def test_smoothed_weights_leave_no_estimate_at_a_missing_step(method, standardize):
    # the docs promise NaN inside bad segments; "rts-smoothed-weights" gave finite values
    rng = np.random.default_rng(3)
    L, Y = rng.standard_normal((6, 9)), rng.standard_normal((6, 30))
    Y[:, 10:14] = np.nan
    rec = reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1, path=method,
                      smoother="rts-smoothed-weights", standardize=standardize,
                      n_orient=3 if standardize == "position" else None)  # fmt: skip
    assert (
        np.isnan(rec.z[:, 10:14]).all() and np.isfinite(np.delete(rec.z, range(10, 14), 1)).all()
    )
    assert np.isfinite(rec.x).all()  # the smoothed state interpolates the gap
    blocks = np.concatenate([block for _, block in rec.blocks("z", rows=3)])
    np.testing.assert_array_equal(np.isnan(blocks), np.isnan(rec.z))


def test_a_bad_segment_has_no_estimate_on_any_smoother(mne_setup):
    epochs = mne_setup["make_epochs"](target=300, seed=21, n_epochs=4)
    operator = make_skf_operator(epochs.info, mne_setup["forward"], noise_std=5e-6,
                                 verbose=False)  # fmt: skip
    raw = mne.io.RawArray(np.concatenate(list(epochs.get_data()), axis=1), epochs.info,
                          verbose=False)  # fmt: skip
    raw.set_annotations(mne.Annotations([0.1], [0.02], ["BAD_blink"]))
    for smoother in (None, "rts-state", "rts-smoothed-weights"):
        stc = apply_skf_raw(raw, operator, smoother=smoother, verbose=False)
        inside = np.zeros(240, bool)
        inside[100:120] = True
        assert np.isnan(stc.data[:, inside]).all(), smoother
        assert np.isfinite(stc.data[:, ~inside]).all(), smoother


# --- item 4: a recording on the command line goes the way apply_skf_raw takes it -----------


@pytest.fixture(scope="module")
def recording(tmp_path_factory, mne_setup):
    """A recording of 4 epochs end to end, a BAD_ annotation over samples 100-119."""
    folder = tmp_path_factory.mktemp("recording")
    epochs = mne_setup["make_epochs"](target=300, seed=21, n_epochs=4)
    raw = mne.io.RawArray(np.concatenate(list(epochs.get_data()), axis=1), epochs.info,
                          verbose=False)  # fmt: skip
    raw.set_annotations(mne.Annotations([0.1], [0.02], ["BAD_blink"]))
    raw.save(folder / "r-raw.fif", verbose=False)
    raw.set_annotations(mne.Annotations([0.0], [raw.times[-1] + 0.001], ["BAD_all"]))
    raw.save(folder / "all_bad-raw.fif", verbose=False)
    mne.write_forward_solution(folder / "f-fwd.fif", mne_setup["forward"], verbose=False)
    return folder


def _recording(folder, name, *more):
    return ["reconstruct", "--forward", str(folder / "f-fwd.fif"), "--evoked",
            str(folder / name), *more]  # fmt: skip


def test_a_recordings_bad_segments_are_skipped_on_the_command_line(cli, recording, tmp_path):
    # the raw was made an evoked of raw.get_data(): the artefact filtered in, exit 0
    out = tmp_path / "r-vl.stc"
    result = cli(*_recording(recording, "r-raw.fif", "--noise-std", "5e-6", "--out", str(out)))
    assert result.returncode == 0, result.stderr
    assert "a continuous recording: 20 of 240 samples inside bad segments (BAD_ annotations)" \
        ", skipped as missing observations: no estimate there (NaN)" in result.stderr  # fmt: skip
    stc = mne.read_source_estimate(out)
    assert np.isnan(stc.data[:, 100:120]).all()
    assert np.isfinite(np.delete(stc.data, range(100, 120), axis=1)).all()
    raw = mne.io.read_raw_fif(recording / "r-raw.fif", verbose=False)
    operator = make_skf_operator(raw.info, mne.read_forward_solution(recording / "f-fwd.fif",
                                 verbose=False), noise_std=5e-6, verbose=False)  # fmt: skip
    expected = apply_skf_raw(raw.load_data(verbose=False), operator, verbose=False)
    np.testing.assert_allclose(stc.data, expected.data, rtol=1e-5, equal_nan=True)  # .stc: float32
    settings = json.loads(out.with_name(out.name + ".json").read_text())
    assert settings["bad_samples"] == 20 and settings["nave"] == 1


@pytest.mark.parametrize(
    "name, more, message",
    [
        ("all_bad-raw.fif", ["--noise-std", "5e-6"],
         "argument --evoked: {folder}/all_bad-raw.fif: every sample of the recording lies in a "
         "bad segment (BAD_ annotations): nothing to reconstruct\n"),
        ("r-raw.fif", ["--noise-std", "5e-6", "--smoother", "rts-standardized"],
         "argument --evoked: {folder}/r-raw.fif: smoother='rts-standardized' is undefined over "
         "missing steps (the data have 20)"),
        ("r-raw.fif", ["--baseline"],
         "argument --baseline: {folder}/r-raw.fif is a continuous recording, with no "
         "pre-stimulus samples (t <= 0)"),
    ],
)  # fmt: skip
def test_a_recording_that_cannot_be_used_is_refused(cli, recording, tmp_path, name, more, message):
    result = cli(*_recording(recording, name, *more, "--out", str(tmp_path / "o.stc")))
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert message.format(folder=recording) in result.stderr
    assert not any(tmp_path.iterdir())


def test_a_recording_as_array_data_has_its_bad_segments_missing(cli, recording, tmp_path):
    # the same class on the array route: --data RECORDING read raw.get_data(), the artefact
    # inside the BAD_ annotation filtered in; its samples are missing observations there too
    raw = mne.io.read_raw_fif(recording / "r-raw.fif", verbose=False)
    forward = mne.read_forward_solution(recording / "f-fwd.fif", verbose=False)
    np.save(tmp_path / "L.npy", forward["sol"]["data"])
    out = tmp_path / "r.npz"
    args = ["reconstruct", "--leadfield", str(tmp_path / "L.npy"), "--data"]
    result = cli(*args, str(recording / "r-raw.fif"), "--noise-std", "5e-6", "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert "20 of 240 samples inside bad segments (BAD_ annotations)" in result.stderr
    z = np.load(out)["z"]
    assert z.shape[1] == raw.n_times and np.isnan(z[:, 100:120]).all()
    assert np.isfinite(np.delete(z, range(100, 120), axis=1)).all()
    assert json.loads(out.with_name(out.name + ".json").read_text())["bad_samples"] == 20
    result = cli(*args, str(recording / "all_bad-raw.fif"), "--noise-std", "5e-6", "--out",
                 str(tmp_path / "o.npz"))  # fmt: skip
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert "all_bad-raw.fif is bad throughout (BAD_ annotations cover every sample)" in (
        result.stderr
    )
    assert not (tmp_path / "o.npz").exists()


# --- item 6: the whitener's rank, said and settable -----------------------------------------


def _few_samples_covariance(info, n_samples, seed=0):
    """A covariance of ``n_samples`` samples of noise, average referenced (nfree n - 1)."""
    noise = np.random.default_rng(seed).standard_normal((len(info.ch_names), n_samples)) * 5e-6
    noise -= noise.mean(axis=0)
    return mne.Covariance(noise @ noise.T / n_samples, info.ch_names, [], [], n_samples - 1)


def test_a_whitener_of_low_rank_is_told_and_rank_is_taken(mne_setup, caplog):
    epochs = mne_setup["make_epochs"](target=300, seed=6, n_epochs=5)
    evoked, forward = epochs.average(), mne_setup["forward"]
    cov = _few_samples_covariance(evoked.info, 6)
    with pytest.warns(UserWarning, match=r"the whitener has rank 6 for 64 channels \(63 "
                      r"dimensions after the projectors\): 57 dimensions of every data set are "
                      r"dropped; the noise covariance was estimated from too few samples \(its "
                      r"nfree is 5, for 63 dimensions\): regularize it \(mne.cov.regularize, "
                      r"or .*method='shrunk'\)\), or give rank=") as record:  # fmt: skip
        apply_skf(evoked, forward, cov, verbose="INFO")
    assert {w.filename for w in record} == {__file__}  # the user's line, through apply_skf
    assert "Computing rank from the noise covariance with rank=None: whitener of rank 6, of " \
        "the 63 dimensions the 64 channels carry" in caplog.text  # fmt: skip
    # rank= reaches MNE's whitener through apply_skf, as make_skf_operator takes it
    full = _few_samples_covariance(evoked.info, 500)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a covariance of 500 samples: nothing to warn of
        apply_skf(evoked, forward, full, verbose=False)
    ranked = apply_skf(evoked, forward, full, rank={"eeg": 40}, verbose=False)
    assert not np.allclose(ranked.data, apply_skf(evoked, forward, full, verbose=False).data)
    operator = make_skf_operator(evoked.info, forward, full, rank={"eeg": 40}, verbose=False)
    assert operator.rank == 40
    with pytest.raises(InputError, match=r"the operator fixes rank: give them to "
                       r"make_skf_operator"):  # fmt: skip
        apply_skf(evoked, operator, rank={"eeg": 40})
    with pytest.raises(InputError, match=r"rank must be None \(estimated from the noise "
                       r"covariance\), 'info', 'full' or a dict of positive ints by channel "
                       r"type \(e.g. \{'eeg': 20\}\), got 'auto'"):  # fmt: skip
        make_skf_operator(evoked.info, forward, full, rank="auto")


# --- item 20: how the array route standardized the columns, and what to pass --------------


@pytest.mark.parametrize(
    "more, said",
    [
        ([], "standardized column by column (--standardize column, the default on arrays); "
         "its 30 columns could be 10 positions x 3 orientations: for a free-orientation lead "
         "field (x, y, z per position) pass --standardize position --n-orient 3"),
        (["--n-orient", "1"], "standardized column by column (--standardize column, the "
         "default on arrays)\n"),
        (["--standardize", "column"], "standardized column by column (--standardize column, "
         "given)\n"),
        (["--standardize", "position", "--n-orient", "3"], "standardized per source position: "
         "3 columns of the lead field's 30 as a whole (--standardize position --n-orient 3)"),
    ],
)  # fmt: skip
def test_the_array_route_says_how_it_standardized(cli, arrays, tmp_path, more, said):
    out = tmp_path / "o.npz"
    result = cli(*_arrays(arrays, *more, "--out", str(out)))
    assert result.returncode == 0, result.stderr
    assert said in result.stderr
    settings = json.loads(out.with_name("o.npz.json").read_text())
    assert settings["standardized"].startswith(said.rstrip("\n"))
    assert settings["standardized"] + "\n" in result.stderr  # the line printed, recorded
    quiet = cli(*_arrays(arrays, *more, "--out", str(tmp_path / "q.npz"), "--quiet"))
    assert quiet.returncode == 0 and quiet.stderr == ""


# --- item 5: data and noise in different units, told by the whitened data's level ---------


def _units_warnings(record):
    return [str(w.message) for w in record if "whitened data's RMS" in str(w.message)]


def test_data_and_noise_in_different_units_are_told(mne_setup):
    evoked = mne_setup["make_epochs"](target=300, seed=6).average()  # in V, 5 uV per trial
    forward = mne_setup["forward"]
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        apply_skf(evoked, forward, noise_std=5e-6, verbose=False)  # the same units
    assert _units_warnings(record) == []
    with pytest.warns(UserWarning, match=r"the whitened data's RMS \(median over "
                      r"samples\) before the response \(t <= 0\) is [0-9.e+]+ \(\+120 dB\), "
                      r"where noise whitened in the data's units is near 1: the data are larger "
                      r"than the noise said by [0-9.e+]+, "
                      r"likely different units \(data in uV with a noise covariance in V\^2, or "
                      r"a noise_std in V for data in uV; MNE keeps EEG in V\)"
                      ) as record:  # fmt: skip
        apply_skf(evoked, forward, noise_std=5e-12, verbose=False)  # noise in "MV"
    assert {w.filename for w in record} == {__file__}
    with pytest.warns(UserWarning, match=r"\(-120 dB\), .* the data are smaller than the noise "
                      r"said by .*data in V with a noise covariance in uV\^2"):  # fmt: skip
        apply_skf(evoked, forward, noise_std=5.0, verbose=False)  # noise in uV
    # "auto" priors on a bound: the units, not the range, and no advice to widen it
    with pytest.warns(UserWarning) as record:
        apply_skf(evoked, forward, noise_std=5e-12, pm_snr_db="auto", ep_snr_db="auto",
                  verbose=False)  # fmt: skip
    bounds = [str(w.message) for w in record if "lies on the" in str(w.message)]
    assert bounds and all(
        "the likely cause is the units, not the range (widening it will not help): the "
        "whitened data's RMS (median over samples) before the response"
        in text
        and "widen pm" not in text
        for text in bounds
    )


def test_array_data_and_noise_std_in_different_units_are_told(cli, arrays, tmp_path):
    # the arrays' noise is 0.1: --noise-std 1e-7 is a million times off
    result = cli(*_arrays(arrays, "--out", str(tmp_path / "o.npz"), "--quiet"))
    assert result.returncode == 0 and _units_warnings(result.warnings) == []
    arguments = _arrays(arrays, "--out", str(tmp_path / "u.npz"), "--quiet")
    arguments[arguments.index("--noise-std") + 1] = "1e-7"
    result = cli(*arguments)
    (said,) = _units_warnings(result.warnings)
    assert said.startswith("the whitened data's RMS (median over samples) over all samples")
    assert "the data are larger than the noise said by" in said and result.returncode == 0
