"""apply_skf on real MNE objects: every route equals the arrays, and a dipole is localized."""

import mne
import numpy as np
import pytest

from skf_ref import InputError, InputTypeError, apply_skf, make_skf_operator, reconstruct
from skf_ref.io import make_stc

# Two computations of the same whitened model (MNE's whitener and an eigendecomposition
# here, or a projection and a whitening) differ by rounding amplified by cond(S) < 1e4.
ROUTE_RTOL = 1e-9
SETTINGS = dict(pm_snr_db=0.0, ep_snr_db=20.0, exponent=1.25, smoother="rts-standardized")


@pytest.fixture(scope="module")
def problem(mne_setup):
    epochs = mne_setup["make_epochs"](target=300, seed=0)
    return mne_setup, epochs.average(), mne.compute_covariance(epochs, tmax=0, verbose=False)


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def test_whitening_reduces_to_the_covariance_rank(problem):
    setup, evoked, cov = problem
    stc, rec = apply_skf(evoked, setup["forward"], cov, return_reconstruction=True, **SETTINGS)
    # independent: project the average reference out of C / nave (the covariance of an
    # average of nave trials), keep its 63 nonzero eigenvalues; the priors, from the SNRs
    # on this whitened lead field, are nave times smaller than the operator's
    nave = evoked.nave
    names = evoked.ch_names
    index = [cov["names"].index(name) for name in names]
    C = cov.data[np.ix_(index, index)] / nave
    P = np.eye(64) - 1 / 64
    eigenvalues, eigenvectors = np.linalg.eigh(P @ C @ P)
    W = (eigenvectors[:, 1:] / np.sqrt(eigenvalues[1:])).T  # rank 63: the smallest is 0
    L = setup["forward"]["sol"]["data"]
    theta0, q = rec.theta0 / nave, rec.q / nave
    ours = reconstruct(W @ L, W @ evoked.data, noise_std=1.0, theta0=theta0, q=q, **_skf(SETTINGS))
    operator = make_skf_operator(evoked.info, setup["forward"], cov, verbose=False)
    assert rec.n_times == evoked.data.shape[1] and operator.rank == 63 and nave == 30
    assert relative(rec.z, ours.z) < ROUTE_RTOL
    assert relative(rec.x / np.sqrt(nave), ours.x) < ROUTE_RTOL  # the state, sqrt(nave) x
    np.testing.assert_allclose(stc.data, ours.amplitude(3), rtol=1e-8)
    assert isinstance(stc, mne.VolSourceEstimate)
    np.testing.assert_allclose(stc.times, evoked.times)
    np.testing.assert_array_equal(stc.vertices[0], setup["forward"]["src"][0]["vertno"])


def _skf(settings):
    """The arrays' settings of an apply_skf run: its standardization is "position" by
    default, with the forward's three columns per position."""
    chosen = {k: v for k, v in settings.items() if k in ("exponent", "smoother")}
    return {**chosen, "standardize": "position", "n_orient": 3}


def test_a_noise_level_equals_the_average_referenced_arrays(problem):
    # noise_std=sigma of one trial: whitening by sigma / sqrt(nave) on the 63-dim range of
    # the projector is the same model as R = sigma^2 / nave I on projected data (the
    # constant direction carries nothing), with priors nave times smaller (docs/model.md §4)
    setup, evoked, _ = problem
    sigma, nave = 1e-6, evoked.nave
    stc, rec = apply_skf(
        evoked, setup["forward"], noise_std=sigma, return_reconstruction=True, **SETTINGS
    )
    L, Y = setup["forward"]["sol"]["data"], evoked.data
    arrays = reconstruct(
        L - L.mean(axis=0),
        Y - Y.mean(axis=0),
        noise_std=sigma / np.sqrt(nave),
        theta0=rec.theta0 / nave,
        q=rec.q / nave,
        **_skf(SETTINGS),
    )
    assert relative(rec.z, arrays.z) < ROUTE_RTOL
    assert relative(rec.x / np.sqrt(nave), arrays.x) < ROUTE_RTOL


def test_channel_order_bad_channels_and_extra_forward_channels(problem):
    setup, evoked, cov = problem
    base = apply_skf(evoked, setup["forward"], cov, **SETTINGS).data
    shuffled = evoked.copy().reorder_channels([evoked.ch_names[i] for i in range(63, -1, -1)])
    assert relative(apply_skf(shuffled, setup["forward"], cov, **SETTINGS).data, base) < 1e-9
    # a bad channel is dropped; a forward computed on the remaining channels alone agrees
    with_bad = evoked.copy()
    with_bad.info["bads"] = ["Fp1", "Oz"]
    kept = [name for name in evoked.ch_names if name not in ("Fp1", "Oz")]
    info = mne.pick_info(setup["info"], mne.pick_channels(setup["info"].ch_names, kept))
    small_forward = mne.make_forward_solution(
        info, None, setup["forward"]["src"], setup["sphere"], eeg=True, meg=False, verbose=False
    )
    dropped = apply_skf(with_bad, setup["forward"], cov, **SETTINGS).data
    picked = apply_skf(evoked.copy().pick(kept), small_forward, cov, **SETTINGS).data
    assert relative(dropped, picked) < 1e-9 and relative(dropped, base) > 1e-6


def test_vector_output_has_the_components_of_the_amplitude(problem):
    setup, evoked, cov = problem
    amplitude = apply_skf(evoked, setup["forward"], cov)
    vector = apply_skf(evoked, setup["forward"], cov, pick_ori="vector")
    assert isinstance(vector, mne.VolVectorSourceEstimate) and vector.data.shape[1] == 3
    np.testing.assert_allclose(np.linalg.norm(vector.data, axis=1), amplitude.data, rtol=1e-12)


def test_data_referenced_without_a_projector_are_given_one(problem):
    setup, evoked, cov = problem
    direct = evoked.copy().del_proj().set_eeg_reference("average", verbose=False)
    assert direct.info["custom_ref_applied"]
    with_projector = apply_skf(evoked, setup["forward"], noise_std=1e-6).data
    assert (
        relative(apply_skf(direct, setup["forward"], noise_std=1e-6).data, with_projector) < 1e-9
    )


@pytest.mark.slow  # over 10 s: CI runs it with the slow tests
def test_fixed_orientation_localizes_a_noise_free_source_exactly(mne_setup):
    # sLORETA's property (docs/model.md §2), one column per position: with T = 1 and
    # P_{1|0} = theta0 + q times I, |z_i| <= sqrt(Res_jj) for the true column j
    rng = np.random.default_rng(2)
    rr = mne_setup["positions"]
    normals = rng.standard_normal(rr.shape)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    src = mne.setup_volume_source_space(
        pos=dict(rr=rr, nn=normals), sphere=mne_setup["sphere"], verbose=False
    )
    forward = mne.make_forward_solution(
        mne_setup["info"], None, src, mne_setup["sphere"], eeg=True, meg=False, verbose=False
    )
    forward = mne.convert_forward_solution(forward, surf_ori=True, force_fixed=True, verbose=False)
    for target in range(0, len(rr), 101):
        evoked = mne.EvokedArray(
            forward["sol"]["data"][:, [target]] * 1e-8, mne_setup["info"], verbose=False
        )
        evoked.set_eeg_reference("average", projection=True, verbose=False)
        stc = apply_skf(evoked, forward, noise_std=1e-9)
        assert np.argmax(np.abs(stc.data[:, 0])) == target
        assert stc.data[target, 0] > 0  # signed: a positive source gives a positive z


@pytest.mark.slow
def test_a_dipole_is_localized(mne_setup):
    # One dipole, 30 epochs, peak SNR 20 dB in the average, 8 positions: the peak's distance
    # from the dipole at the pulse's maximum. Free orientation standardizes each column on
    # its own (docs/model.md §1), which biases deep positions even without noise, so single
    # runs miss by a grid step or more; medians over the dipoles are robust. The numbers
    # are in apply_skf's docstring.
    errors = {name: [] for name in SMOOTHERS_AND_EXPONENTS}
    for target in range(50, len(mne_setup["positions"]), 150):
        epochs = mne_setup["make_epochs"](target, seed=target)
        evoked, cov = epochs.average(), mne.compute_covariance(epochs, tmax=0, verbose=False)
        for name, settings in SMOOTHERS_AND_EXPONENTS.items():
            stc = apply_skf(evoked, mne_setup["forward"], cov, **COLUMN_EP20, **settings)
            best = np.argmax(stc.data[:, mne_setup["peak"]])
            distance = np.linalg.norm(
                mne_setup["positions"][best] - mne_setup["positions"][target]
            )
            errors[name].append(distance * 1e3)
    median = {name: np.median(e) for name, e in errors.items()}
    two_steps = 24.0 + 1e-6  # two steps of the 12 mm grid
    assert median["0.5"] <= two_steps and median["0.5, rts-state"] <= two_steps
    assert median["0.5, rts-standardized"] >= median["0.5"]
    assert median["1.25"] > 2 * median["0.5"]


# The numbers of apply_skf's docstring were measured with the defaults before 0.4.0.
COLUMN_EP20 = dict(standardize="column", ep_snr_db=20.0)
SMOOTHERS_AND_EXPONENTS = {
    "0.5": {},
    "0.5, rts-state": dict(smoother="rts-state"),
    "0.5, rts-standardized": dict(smoother="rts-standardized"),
    "1.25": dict(exponent=1.25),
}


def test_baseline_noise(mne_setup):
    epochs = mne_setup["make_epochs"](target=300, seed=3)
    evoked = epochs.average()
    with pytest.raises(
        InputError, match="needs at least as many pre-stimulus samples .* 64, got 21"
    ):
        apply_skf(evoked, mne_setup["forward"], "baseline")
    long = mne.EpochsArray(
        np.concatenate([epochs.get_data()] * 4, axis=2),
        mne_setup["info"],
        tmin=-0.2,
        verbose=False,
    )
    long.set_eeg_reference("average", projection=True, verbose=False)
    stc = apply_skf(long.average(), mne_setup["forward"], "baseline")
    assert np.isfinite(stc.data).all() and stc.data.shape == (len(mne_setup["positions"]), 240)


@pytest.mark.parametrize(
    "change, error, match",
    [
        (dict(evoked=np.zeros((64, 10))), InputTypeError, "evoked must be an mne.Evoked"),
        (dict(forward="fwd.fif"), InputTypeError, "forward must be an SKFOperator or an mne"),
        (dict(noise_cov="diag"), InputError, r"noise_cov must be one of \['baseline'\]"),
        (dict(noise_cov=None, noise_std=-1.0), InputError, "noise_std must be > 0"),
        (dict(noise_std=1e-6), InputError, "give exactly one of noise_cov .* and noise_std"),
        (dict(noise_cov=None), InputError, "give exactly one of noise_cov .* and noise_std"),
        (dict(noise_cov=[1.0]), InputTypeError, "noise_cov must be an mne.Covariance"),
        (dict(pick_ori="normal"), InputError, r"pick_ori must be one of \[None, 'vector'\]"),
        (dict(exponent=-1), InputError, "exponent must be >= 0"),
    ],
)
def test_bad_input(problem, change, error, match):
    setup, evoked, cov = problem
    kwargs = dict(evoked=evoked, forward=setup["forward"], noise_cov=cov) | change
    with pytest.raises(error, match=match):
        apply_skf(kwargs.pop("evoked"), kwargs.pop("forward"), kwargs.pop("noise_cov"), **kwargs)


def test_references_the_forward_cannot_be_given(problem):
    setup, evoked, cov = problem
    mastoid = evoked.copy().del_proj().set_eeg_reference(["P9", "P10"], verbose=False)
    with pytest.raises(InputError, match="custom EEG reference other than the average"):
        apply_skf(mastoid, setup["forward"], noise_std=1e-6)
    raw_reference = evoked.copy().del_proj()
    with pytest.raises(InputError, match="neither an average-reference projector"):
        apply_skf(raw_reference, setup["forward"], noise_std=1e-6)


def test_no_common_channel_and_nan(problem):
    setup, evoked, cov = problem
    # made anew: MNE's rename_channels on a copy renames the original's projector too
    info = mne.create_info([f"X{name}" for name in evoked.ch_names], 1000.0, "eeg")
    renamed = mne.EvokedArray(evoked.data, info, verbose=False)
    with pytest.raises(InputError, match=r"no EEG channel is common .* e.g. \['XFp1'"):
        apply_skf(renamed, setup["forward"], noise_std=1e-6)
    broken = evoked.copy()
    broken.data[3, 7] = np.nan
    with pytest.raises(InputError, match="evoked.data contains NaN"):
        apply_skf(broken, setup["forward"], noise_std=1e-6)


def test_to_stc_from_arrays(mne_setup, problem):
    setup, evoked, cov = problem
    stc, rec = apply_skf(evoked, setup["forward"], cov, return_reconstruction=True)
    again = make_stc(rec, setup["forward"]["src"], evoked.times[0], 1e-3)
    np.testing.assert_array_equal(again.data, stc.data)
    vector = make_stc(rec, setup["forward"]["src"], evoked.times[0], 1e-3, pick_ori="vector")
    np.testing.assert_allclose(np.linalg.norm(vector.data, axis=1), stc.data, rtol=1e-12)
    fixed = reconstruct(np.eye(4, 1254) + 1, np.ones((4, 2)), noise_std=1, theta0=1, q=1)
    with pytest.raises(InputError, match="pick_ori='vector' needs free orientation"):
        make_stc(fixed, setup["forward"]["src"], 0.0, 1e-3, pick_ori="vector")
    with pytest.raises(InputError, match="pick_ori must be one of"):
        make_stc(rec, setup["forward"]["src"], 0.0, 1e-3, pick_ori="normal")
    with pytest.raises(InputError, match="has 1254 positions, so it needs 1254"):
        make_stc(
            reconstruct(np.eye(4, 10) + 1, np.ones((4, 2)), noise_std=1, theta0=1, q=1),
            setup["forward"]["src"],
            0.0,
            1e-3,
        )
