"""Prepared operators: made once, applied to evokeds, epochs and raw recordings alike.

Every route gives the numbers of the one-call ``apply_skf(evoked, forward, noise_cov)``;
the whitening, the SVD and the covariance recursion are computed once; what the operator
leaves out is said; what it cannot use is refused in one clear error.
"""

import copy
import types

import mne
import numpy as np
import pytest
from rounding import assert_same_to_rounding

from skf_ref import (
    InputError,
    InputTypeError,
    SKFOperator,
    apply_skf,
    apply_skf_epochs,
    apply_skf_raw,
    make_skf_operator,
)
from skf_ref.method._paths import singular_basis, spectral

SETTINGS = dict(exponent=1.25, smoother="rts-standardized")
# Blocks of rows and whole arrays compute the same products in another order (the
# paper's smoother sums a projection over blocks): rounding only.
BLOCK_RTOL = 1e-12


@pytest.fixture(scope="module")
def problem(mne_setup):
    epochs = mne_setup["make_epochs"](target=300, seed=21)
    cov = mne.compute_covariance(epochs, tmax=0, verbose=False)
    return mne_setup, epochs, cov


@pytest.fixture(scope="module")
def operator(problem):
    setup, epochs, cov = problem
    return make_skf_operator(epochs.info, setup["forward"], cov, verbose=False)


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def _evoked(epochs, k):
    return mne.EvokedArray(epochs.get_data()[k], epochs.info, tmin=epochs.times[0], nave=1)


def test_an_operator_gives_the_one_call_numbers(problem, operator):
    setup, epochs, cov = problem
    evoked = epochs.average()
    for settings in ({}, SETTINGS):
        once = apply_skf(evoked, setup["forward"], cov, **settings).data
        prepared = apply_skf(evoked, operator, **settings).data
        assert_same_to_rounding(prepared, once)  # one SVD, other products' shapes
    assert isinstance(operator, SKFOperator) and operator.rank == 63
    assert "63" in repr(operator) and operator.dropped == {}


def test_the_svd_and_the_recursion_are_computed_once(problem, monkeypatch):
    setup, epochs, cov = problem
    # the walk's priors are fixed: one recursion for every epoch (a time constant chosen by
    # the data, the default, is chosen for each)
    operator = make_skf_operator(epochs.info, setup["forward"], cov, ep_snr_db=0.0, verbose=False)
    calls = {"svd": 0, "recursion": 0}

    def counted(name, function):
        def call(*args, **kwargs):
            calls[name] += 1
            return function(*args, **kwargs)

        return call

    monkeypatch.setattr(singular_basis, "thin_svd", counted("svd", singular_basis.thin_svd))
    monkeypatch.setattr(spectral, "Recursions", counted("recursion", spectral.Recursions))
    estimates = apply_skf_epochs(epochs[:4], operator, **SETTINGS)
    assert len(estimates) == 4 and calls == {"svd": 0, "recursion": 1}


def test_epochs_equal_their_evokeds_as_a_list_or_a_generator(problem, operator):
    setup, epochs, cov = problem
    listed = apply_skf_epochs(epochs[:3], operator, pick_ori="vector")
    generated = apply_skf_epochs(epochs[:3], operator, pick_ori="vector", return_generator=True)
    assert isinstance(generated, types.GeneratorType)
    for k, (a, b) in enumerate(zip(listed, generated, strict=True)):
        expected = apply_skf(_evoked(epochs, k), operator, pick_ori="vector")
        assert isinstance(a, mne.VolVectorSourceEstimate)
        assert_same_to_rounding(a.data, expected.data)  # the epochs stacked: other shapes
        assert_same_to_rounding(b.data, expected.data)
        np.testing.assert_allclose(a.times, epochs.times)


@pytest.fixture(scope="module")
def raw(problem):
    setup, epochs, cov = problem
    data = np.concatenate(list(epochs.get_data()[:6]), axis=1)  # 360 samples in a row
    raw = mne.io.RawArray(data, setup["info"], verbose=False)
    return raw.set_eeg_reference("average", verbose=False)  # MNE's default: no projector


def test_raw_runs_the_filter_along_the_recording(raw, operator):
    stc = apply_skf_raw(raw, operator, 40, 300, **SETTINGS)
    segment = mne.EvokedArray(raw.get_data(start=40, stop=300), raw.info, tmin=raw.times[40])
    # streamed in blocks along the recording: the same algebra, other products' shapes
    assert_same_to_rounding(stc.data, apply_skf(segment, operator, **SETTINGS).data)
    assert stc.data.shape[1] == 260 and stc.tmin == pytest.approx(raw.times[40])
    with pytest.raises(InputError, match="stop must be > start=40, got 40"):
        apply_skf_raw(raw, operator, 40, 40)
    with pytest.raises(MemoryError, match=r"give out='NAME.zarr' to stream it"):
        apply_skf_raw(raw, operator, memory_limit=2**20)


@pytest.mark.parametrize("pick_ori", [None, "vector"])
def test_raw_streamed_to_zarr_equals_the_estimate(raw, operator, tmp_path, pick_ori):
    pytest.importorskip("zarr")
    in_memory = apply_skf_raw(raw, operator, pick_ori=pick_ori, **SETTINGS)
    store = apply_skf_raw(raw, operator, pick_ori=pick_ori, out=tmp_path / "r.zarr", **SETTINGS)
    assert relative(np.asarray(store["data"][:]), in_memory.data) <= BLOCK_RTOL
    assert store.attrs["stc_class"] == type(in_memory).__name__
    assert store.attrs["vertices"] == [v.tolist() for v in in_memory.vertices]
    assert store.attrs["tstep"] == pytest.approx(in_memory.tstep)
    with pytest.raises(InputError, match="exists: give overwrite=True"):
        apply_skf_raw(raw, operator, out=tmp_path / "r.zarr", memory_limit=1)  # before work


@pytest.mark.filterwarnings("ignore:tune. pm_snr_db")  # on its bound: the choice is the same
def test_auto_priors_are_chosen_for_each_data_set(problem):
    setup, epochs, cov = problem
    evoked = epochs.average()
    once, rec = apply_skf(
        evoked, setup["forward"], cov, pm_snr_db="auto", return_reconstruction=True
    )
    operator = make_skf_operator(evoked.info, setup["forward"], cov, pm_snr_db="auto")
    prepared, again = apply_skf(evoked, operator, return_reconstruction=True)
    assert_same_to_rounding(prepared.data, once.data)
    assert again.tuning is not None
    assert again.tuning.pm_snr_db == pytest.approx(rec.tuning.pm_snr_db, rel=1e-9)


def test_channels_left_out_are_listed_and_logged(problem, capsys):
    setup, epochs, cov = problem
    kept = [name for name in setup["info"].ch_names if name != "Oz"]
    forward = mne.pick_channels_forward(setup["forward"], kept, verbose=False)
    info = epochs.info.copy()
    info["bads"] = ["Fp1"]
    operator = make_skf_operator(info, forward, cov, verbose=True)
    err = capsys.readouterr().err
    assert operator.dropped == {"bad": ["Fp1"], "not in the forward": ["Oz"]}
    assert "62 of the 64 EEG channels used" in err
    assert "not in the forward: 1 ['Oz']" in err and "bad: 1 ['Fp1']" in err
    make_skf_operator(info, forward, cov, verbose=False)
    assert capsys.readouterr().err == ""


def test_what_the_operator_cannot_use_is_refused(problem, operator):
    setup, epochs, cov = problem
    evoked = epochs.average()
    with pytest.raises(InputError, match=r"evoked lacks 1 channels the operator uses: \['Oz'\]"):
        apply_skf(evoked.copy().drop_channels(["Oz"]), operator)
    bad = evoked.copy()
    bad.info["bads"] = ["Cz"]
    with pytest.raises(InputError, match=r"evoked marks \['Cz'\] bad, which the operator uses"):
        apply_skf(bad, operator)
    other = evoked.copy()
    vector = np.random.default_rng(0).standard_normal((1, 64))
    other.add_proj(mne.Projection(data=dict(nrow=1, ncol=64, row_names=None,
                                            col_names=evoked.ch_names, data=vector),
                                  desc="an SSP", kind=1, active=False))  # fmt: skip
    with pytest.raises(InputError, match="has projectors the operator does not apply"):
        apply_skf(other, operator)
    mastoid = evoked.copy().del_proj().set_eeg_reference(["P9", "P10"], verbose=False)
    with pytest.raises(InputError, match="custom EEG reference other than the average"):
        apply_skf(mastoid, operator)
    with pytest.raises(InputError, match="the operator fixes noise_cov, pm_snr_db"):
        apply_skf(evoked, operator, cov, pm_snr_db=3.0)
    with pytest.raises(InputTypeError, match="operator must be an SKFOperator"):
        apply_skf_epochs(epochs, setup["forward"])
    with pytest.raises(InputTypeError, match="epochs must be an mne.Epochs"):
        apply_skf_epochs(evoked, operator)
    with pytest.raises(InputTypeError, match="raw must be an mne.io.Raw"):
        apply_skf_raw(evoked, operator)
    with pytest.raises(InputError, match="noise_cov='baseline' needs the data"):
        make_skf_operator(evoked.info, setup["forward"], "baseline")
    with pytest.raises(InputError, match="meg=False and eeg=False pick no channel"):
        make_skf_operator(evoked.info, setup["forward"], cov, meg=False, eeg=False)
    with pytest.raises(InputError, match=r"no MEG channel is common .* types: eeg\)"):
        make_skf_operator(evoked.info, setup["forward"], cov, eeg=False)
    with pytest.raises(InputError, match="meg=True asks for grad/mag channels, but none"):
        make_skf_operator(evoked.info, setup["forward"], cov, meg=True)


# --- the noise covariance ---------------------------------------------------------------


def _with_data(cov, data):
    return mne.Covariance(data, cov["names"], bads=[], projs=[], nfree=cov["nfree"])


def _indefinite(C):
    eigenvalues, vectors = np.linalg.eigh(C)
    return C - 2 * eigenvalues[-1] * np.outer(vectors[:, -1], vectors[:, -1])


def _asymmetric(C):
    return C + np.triu(np.full(C.shape, 0.5 * np.abs(C).max()), 1)


def _entry(value):
    def change(C):
        C = C.copy()
        C[3, 3] = value
        return C

    return change


COVARIANCE_FAULTS = {
    "indefinite": (_indefinite, "noise_cov must be positive semi-definite"),
    "negative definite": (lambda C: -C, "noise_cov must be positive semi-definite"),
    "asymmetric": (_asymmetric, "noise_cov must be symmetric"),
    "NaN": (_entry(np.nan), r"noise_cov contains NaN or Inf \(channels \['F1'\]\)"),
    "Inf": (_entry(np.inf), r"noise_cov contains NaN or Inf"),
    "1e300": (_entry(1e300), "noise_cov is out of range: its largest entry is 1e"),
    "zero": (np.zeros_like, "noise_cov is zero on the 64 EEG channels used"),
}


@pytest.mark.parametrize("fault", COVARIANCE_FAULTS)
def test_a_covariance_that_is_none_is_refused_naming_it(problem, fault):
    setup, epochs, cov = problem
    change, match = COVARIANCE_FAULTS[fault]
    with pytest.raises(InputError, match=match):
        apply_skf(epochs.average(), setup["forward"], _with_data(cov, change(cov.data)))


def test_one_good_channel_is_a_clear_error(problem):
    setup, epochs, cov = problem
    evoked = epochs.average()
    evoked.info["bads"] = evoked.ch_names[1:]
    with pytest.raises(InputError, match="one EEG channel, 'Fp1', is common .* at least 2"):
        apply_skf(evoked, setup["forward"], cov)


# --- MEG and EEG together ----------------------------------------------------------------


@pytest.fixture(scope="module")
def meg_eeg():
    """MNE's own Neuromag 306 sensors (device = head coordinates) and the mgh60 cap."""
    if not hasattr(mne.channels, "read_meg_canonical_info"):
        pytest.skip("MNE >= 1.12 ships the canonical MEG sensors")
    meg = mne.channels.read_meg_canonical_info("neuromag", verbose=False)
    montage = mne.channels.make_standard_montage("mgh60")
    eeg = mne.create_info(montage.ch_names, 1000.0, "eeg").set_montage(montage)
    raw = mne.io.RawArray(np.zeros((306, 1)), meg, verbose=False)
    raw.add_channels([mne.io.RawArray(np.zeros((60, 1)), eeg, verbose=False)], True)
    info = raw.info
    sphere = mne.make_sphere_model((0.0, 0.0, 0.0), 0.09, info, verbose=False)
    src = mne.setup_volume_source_space(
        sphere=sphere, pos=30.0, mindist=5.0, exclude=20.0, verbose=False
    )
    forward = mne.make_forward_solution(info, None, src, sphere, verbose=False)
    rng = np.random.default_rng(3)
    scale = np.where([mne.channel_type(info, i) == "eeg" for i in range(366)], 1e-6, 1e-12)
    scale[mne.pick_types(info, meg="grad")] *= 10  # T/m: a gradiometer's baseline is ~4 cm
    noise = scale[None, :, None] * rng.standard_normal((70, 366, 30))
    epochs = mne.EpochsArray(noise, info, tmin=-0.03, verbose=False)
    cov = mne.compute_covariance(epochs, verbose=False)
    signal = forward["sol"]["data"][:, 100:101] * 1e-8 * np.hanning(30)
    evoked = mne.EvokedArray(signal + noise[0] / 4, info, tmin=-0.01, verbose=False)
    return evoked.set_eeg_reference("average", verbose=False), forward, cov


@pytest.mark.slow  # over 10 s: CI runs it with the slow tests
def test_meg_and_eeg_are_whitened_by_type_and_only_eeg_is_referenced(meg_eeg):
    evoked, forward, cov = meg_eeg
    operator = make_skf_operator(evoked.info, forward, cov, meg=True, ep_snr_db=0.0, verbose=False)
    stc, rec = apply_skf(evoked, operator, smoother=None, return_reconstruction=True)
    names = operator.ch_names
    meg = [i for i, name in enumerate(names) if name not in operator.eeg_names]
    eeg = [i for i, name in enumerate(names) if name in operator.eeg_names]
    assert len(meg) == 306 and len(eeg) == 60 and operator.rank == 306 + 59
    W = operator.whitener
    assert np.abs(W[:, eeg].sum(axis=1)).max() < 1e-9 * np.abs(W[:, eeg]).max()
    # independent: each type whitened on its own (MNE ignores covariances across types),
    # the EEG with the average reference projected out; any rotation of the whitened rows
    # is the same model
    index = [cov["names"].index(name) for name in names]
    C = cov.data[np.ix_(index, index)]
    values, vectors = np.linalg.eigh(C[np.ix_(meg, meg)])
    W_meg = (vectors / np.sqrt(values)).T
    P = np.eye(60) - 1 / 60
    values, vectors = np.linalg.eigh(P @ C[np.ix_(eeg, eeg)] @ P)
    W_eeg = (vectors[:, 1:] / np.sqrt(values[1:])).T
    L = forward["sol"]["data"][[forward["sol"]["row_names"].index(n) for n in names]]
    Y = evoked.data[[evoked.ch_names.index(n) for n in names]]
    from skf_ref import reconstruct

    WL = np.vstack([W_meg @ L[meg], W_eeg @ L[eeg]])
    WY = np.vstack([W_meg @ Y[meg], W_eeg @ Y[eeg]])
    expected = reconstruct(WL, WY, noise_std=1.0, theta0=rec.theta0, q=rec.q,
                           standardize="position", n_orient=3)  # fmt: skip
    assert relative(rec.z, expected.z) < 1e-8  # two whitenings of a covariance of cond ~1e3


@pytest.mark.slow
def test_channel_types_are_picked_by_argument(meg_eeg):
    evoked, forward, cov = meg_eeg
    grad = make_skf_operator(evoked.info, forward, cov, meg="grad", verbose=False)
    assert len(grad.ch_names) == 204 + 60 and len(grad.eeg_names) == 60
    shared = make_skf_operator(evoked.info, forward, cov, verbose=False)
    assert len(shared.ch_names) == 366 and shared.rank == 365  # as apply_inverse takes them
    eeg_only = make_skf_operator(evoked.info, forward, cov, meg=False, verbose=False)
    assert len(eeg_only.ch_names) == 60 and eeg_only.rank == 59
    stds = {"eeg": 1e-6, "grad": 1e-11, "mag": 1e-12}
    both = make_skf_operator(evoked.info, forward, noise_std=stds, meg=True, verbose=False)
    assert both.rank == 365 and np.isfinite(apply_skf(evoked, both).data).all()
    with pytest.raises(InputError, match=r"noise_std must be a dict naming each channel type"):
        make_skf_operator(evoked.info, forward, noise_std=1e-6, meg=True)
    with pytest.raises(InputError, match=r"meg must be None, True, False, 'mag' or 'grad'"):
        make_skf_operator(evoked.info, forward, cov, meg="planar")


def test_an_indefinite_covariance_is_not_told_to_be_whitened():
    from skf_ref import reconstruct

    rng = np.random.default_rng(1)
    L, Y = rng.standard_normal((6, 9)), rng.standard_normal((6, 4))
    indefinite = np.diag([1.0, 1.0, 1.0, 1.0, 1.0, -0.5])
    with pytest.raises(InputError, match="a negative variance, so no covariance$"):
        reconstruct(L, Y, noise_cov=indefinite, theta0=1.0, q=0.1)
    singular = np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 0.0])
    with pytest.raises(InputError, match="whitened to its rank .* skf-ref reconstruct --forward"):
        reconstruct(L, Y, noise_cov=singular, theta0=1.0, q=0.1)


@pytest.mark.slow
def test_the_types_come_from_the_data(meg_eeg):
    # an MEG-only evoked just works (as apply_inverse): the types the data, the forward and
    # the covariance share; meg=/eeg= restrict them
    evoked, forward, cov = meg_eeg
    meg_only = evoked.copy().pick("meg")
    # MEG is blind to a radial dipole: leave out the grid's positions on the sphere's axes,
    # whose x, y or z column is radial
    grid = forward["src"][0]
    rr = grid["rr"][grid["vertno"]]
    off_axis = rr[np.sum(np.abs(rr) > 1e-9, axis=1) > 1]
    normals = np.tile([0.0, 0.0, 1.0], (len(off_axis), 1))
    sphere = mne.make_sphere_model((0.0, 0.0, 0.0), 0.09, meg_only.info, verbose=False)
    src = mne.setup_volume_source_space(
        pos=dict(rr=off_axis, nn=normals), sphere=sphere, verbose=False
    )
    meg_forward = mne.make_forward_solution(meg_only.info, None, src, sphere, verbose=False)
    stc, rec = apply_skf(meg_only, meg_forward, cov, return_reconstruction=True)
    operator = make_skf_operator(meg_only.info, meg_forward, cov, verbose=False)
    assert len(operator.ch_names) == 306 and operator.eeg_names == []
    assert rec.settings["standardize"] == "column"  # MEG alone: the column form by default
    assert_same_to_rounding(apply_skf(meg_only, operator).data, stc.data)
    with pytest.raises(InputError, match="eeg=True asks for eeg channels, but none is common"):
        make_skf_operator(meg_only.info, meg_forward, cov, eeg=True)
    mag = make_skf_operator(evoked.info, forward, cov, meg="mag", verbose=False)
    assert set(mag.ch_types) == {"mag", "eeg"} and len(mag.ch_names) == 102 + 60
    with pytest.raises(InputError, match=r"lacks \['mag', 'grad'\] \(no type is given a def"):
        make_skf_operator(evoked.info, forward, noise_std={"eeg": 1e-6})
    with pytest.raises(InputError, match=r"noise_std must be a dict naming each channel type"):
        make_skf_operator(meg_only.info, meg_forward, noise_std=1e-12)
    grad = make_skf_operator(meg_only.info, meg_forward, noise_std=1e-11, meg="grad")
    assert set(grad.ch_types) == {"grad"}  # one type: one number will do


@pytest.mark.filterwarnings("ignore:tune. (pm|ep)_snr_db")
def test_priors_searched_over_a_range(problem):
    setup, epochs, cov = problem
    evoked = epochs.average()
    operator = make_skf_operator(evoked.info, setup["forward"], cov, pm_snr_db=[-40, 20],
                                 ep_snr_db=0.0, verbose=False)  # fmt: skip
    assert operator.pm_snr_db == (-40.0, 20.0) and "searched in (-40, 20) dB" in repr(operator)
    stc, rec = apply_skf(evoked, operator, return_reconstruction=True)
    assert -40 <= rec.tuning.pm_snr_db <= 20 and rec.tuning.ep_snr_db == 0.0
    once = apply_skf(evoked, setup["forward"], cov, pm_snr_db=(-40, 20), ep_snr_db=0.0)
    assert_same_to_rounding(once.data, stc.data)
    for value, match in [
        ((20, -40), r"pm_snr_db must be a range \(low, high\) with low < high, got \(20, -40\)"),
        ((1, 2, 3), r"pm_snr_db must be a number \(dB\), 'auto' or a search range"),
        ("best", r"pm_snr_db must be a number \(dB\), 'auto' or a search range"),
        ((-400, 0), r"pm_snr_db\[0\] must be >= -300 dB"),
    ]:
        with pytest.raises(InputError, match=match):
            make_skf_operator(evoked.info, setup["forward"], cov, pm_snr_db=value)


def test_a_bound_warning_names_the_remedy_on_every_route(problem):
    setup, epochs, cov = problem
    evoked = epochs.average()
    remedy = r"widen pm_snr_db (above|below) -?\d+ dB to let the data choose: pm_snr_db=\("
    remedy += r".*\) in Python \(tune, apply_skf, make_skf_operator\) or --pm-snr-db=-?\d+,-?\d+ "
    with pytest.warns(UserWarning, match=remedy + "on the command line"):
        apply_skf(evoked, setup["forward"], cov, pm_snr_db=(-40, -39))


def test_an_operator_shows_itself_in_a_notebook(operator):
    html = operator._repr_html_()
    assert html.startswith("<table>") and html.endswith("</table>")
    for cell in ("<th", "64 (64 eeg)", ">63<", "free orientation"):
        assert cell in html
    # the defaults: PM-SNR 0 dB, the AR(1) prior's time constant chosen by the data
    assert "PM-SNR</th><td style='text-align:left'>0 dB<" in html
    assert ">auto<" in html


def test_the_default_standardization_is_per_position_with_eeg_and_per_column_for_meg_alone(
    meg_eeg,
):
    # MEG does not see a position's radial orientation in a spherical head: its 3 x 3
    # blocks are singular, and the study that chose "position" measured EEG only
    evoked, forward, cov = meg_eeg
    # (test_the_types_come_from_the_data runs an MEG-only evoked through it, off the axes)
    # fixed priors: the standardization is the subject, not the time constant's search
    with_eeg = make_skf_operator(evoked.info, forward, cov, ep_snr_db=0.0, verbose=False)
    assert with_eeg.default_standardize == "position"
    meg_alone = copy.copy(with_eeg)
    meg_alone.eeg_names = []
    assert meg_alone.default_standardize == "column"
    data = with_eeg.select(evoked.info, evoked.data)[:, :5]
    assert with_eeg.reconstruct(data).settings["standardize"] == "position"
