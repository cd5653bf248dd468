"""An average of nave trials is whitened with the noise covariance over nave, as MNE does.

The operator is made once, from the covariance of one trial; nave enters when it is
applied, as sqrt(nave) times the whitened data, which is exactly the model whitened with
C / nave (its priors follow the whitened lead field). Where the SKF reduces to sLORETA
(exponent 0.5, one step), it is MNE's sLORETA on the same evoked.
"""

import mne
import numpy as np
import pytest
from rounding import assert_same_to_rounding

from skf_ref import InputError, apply_skf, apply_skf_epochs, make_skf_operator
from skf_ref.io import baseline_covariance

# Two whitenings of the same model (of C and of C / nave: their eigendecompositions differ
# in rounding) amplified by the filter's conditioning.
ROUTE_RTOL = 1e-9
# The marginal likelihood of both models is one function of the SNRs up to rounding: the
# optimizer's choices agree far inside the grid's cell.
TUNE_ATOL_DB = 1e-4
NAVE = 30


@pytest.fixture(scope="module")
def sphere():
    """biosemi32 on a sphere, a 25 mm grid, 60 epochs of one dipole under white noise."""
    montage = mne.channels.make_standard_montage("biosemi32")
    info = mne.create_info(montage.ch_names, 500.0, "eeg").set_montage(montage)
    sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    src = mne.setup_volume_source_space(sphere=sphere, pos=25.0, verbose=False)
    forward = mne.make_forward_solution(info, None, src, sphere, verbose=False)
    rng = np.random.default_rng(7)
    times = np.arange(40) / 500.0 - 0.02
    pulse = np.where(times > 0, np.sin(np.pi * np.clip(times, 0, 0.04) / 0.04), 0.0)
    gain = forward["sol"]["data"][:, 30:33] @ [0.0, 0.6, 0.8]
    noise = 5e-6 * rng.standard_normal((60, 32, 40))
    epochs = mne.EpochsArray(
        np.outer(gain, 20e-9 * pulse) + noise, info, tmin=-0.02, verbose=False
    )
    epochs.set_eeg_reference("average", projection=True, verbose=False)
    cov = mne.compute_covariance(epochs, verbose=False)
    return dict(info=info, sphere=sphere, forward=forward, epochs=epochs, cov=cov)


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def _scaled(cov, factor):
    return mne.Covariance(
        cov.data * factor, cov["names"], [], cov["projs"], cov["nfree"], verbose=False
    )


def _evoked(sphere, nave):
    epochs = sphere["epochs"]
    data = epochs.get_data()[:NAVE].mean(axis=0)
    evoked = mne.EvokedArray(data, epochs.info, tmin=epochs.times[0], nave=nave, verbose=False)
    return evoked


@pytest.mark.filterwarnings("ignore:tune. pm_snr_db")  # on a bound: the same bound for both
@pytest.mark.parametrize(
    "settings",
    [
        dict(ep_snr_db=0.0, smoother=None),
        dict(exponent=1.25, smoother="rts-standardized", ep_snr_db=0.0),
        dict(pm_snr_db="auto", ep_snr_db=0.0),
    ],
    ids=["walk", "paper", "auto"],
)
def test_nave_k_equals_nave_1_with_the_covariance_over_k(sphere, settings):
    averaged, single = _evoked(sphere, NAVE), _evoked(sphere, 1)
    stc, rec = apply_skf(
        averaged, sphere["forward"], sphere["cov"], return_reconstruction=True, **settings
    )
    over_k = _scaled(sphere["cov"], 1 / NAVE)
    expected, again = apply_skf(
        single, sphere["forward"], over_k, return_reconstruction=True, **settings
    )
    assert relative(rec.z, again.z) < ROUTE_RTOL
    assert relative(stc.data, expected.data) < ROUTE_RTOL
    assert rec.log_likelihood == pytest.approx(again.log_likelihood, rel=1e-10)
    if rec.tuning is not None:
        assert rec.tuning.pm_snr_db == pytest.approx(again.tuning.pm_snr_db, abs=TUNE_ATOL_DB)
    # and nave is not a no-op: the single-trial covariance on the average differs
    ignored = apply_skf(single, sphere["forward"], sphere["cov"], **settings)
    assert relative(ignored.data, expected.data) > 1e-2


def test_an_operator_made_once_applies_to_every_nave(sphere):
    # the operator's whitener is that of C; for an average it is sqrt(nave) times it, and
    # scaling the whitened data alone is the model whitened with C / nave
    info, forward, cov = sphere["info"], sphere["forward"], sphere["cov"]
    operator = make_skf_operator(info, forward, cov, ep_snr_db=0.0, verbose=False)
    evoked = _evoked(sphere, 1)
    data = operator.select(evoked.info, evoked.data)
    for nave in (1, 4, 30):
        made_for_k = make_skf_operator(
            info, forward, _scaled(cov, 1 / nave), ep_snr_db=0.0, verbose=False
        )
        np.testing.assert_allclose(
            np.abs(made_for_k.whitener), np.sqrt(nave) * np.abs(operator.whitener), rtol=1e-9
        )  # the same rows up to sign (an eigendecomposition each)
        for settings in ({}, dict(exponent=1.25, smoother="rts-state")):
            a = operator.reconstruct(data, nave=nave, **settings)
            b = made_for_k.reconstruct(data, **settings)
            assert relative(a.z, b.z) < ROUTE_RTOL and relative(a.weights, b.weights) < 1e-12
            assert a.log_likelihood == pytest.approx(b.log_likelihood, rel=1e-10)
            assert a.theta0 == pytest.approx(nave * b.theta0, rel=1e-12)  # priors of W L
            # the state of the whitened model is sqrt(nave) x, x in the forward's units
            assert relative(a.x / np.sqrt(nave), b.x) < ROUTE_RTOL
    with pytest.raises(InputError, match="nave must be > 0, got 0.0"):
        operator.reconstruct(data, nave=0)


def test_epochs_take_nave_as_apply_inverse_epochs(sphere):
    epochs = sphere["epochs"][:3]
    operator = make_skf_operator(epochs.info, sphere["forward"], sphere["cov"], verbose=False)
    for nave in (1, 5):
        estimates = apply_skf_epochs(epochs, operator, nave=nave)
        for k, stc in enumerate(estimates):
            evoked = mne.EvokedArray(
                epochs.get_data()[k], epochs.info, tmin=epochs.times[0], nave=nave, verbose=False
            )
            assert_same_to_rounding(stc.data, apply_skf(evoked, operator).data)


def test_a_baseline_covariance_is_that_of_one_trial(sphere):
    # the average's own baseline covariance, times nave: the evoked is whitened with the
    # covariance of its baseline whatever its nave
    long = mne.EpochsArray(
        np.concatenate([sphere["epochs"].get_data()] * 2, axis=2),
        sphere["info"],
        tmin=-0.1,
        verbose=False,
    )
    long.set_eeg_reference("average", projection=True, verbose=False)
    evoked = long.average()
    baseline = evoked.data[:, evoked.times <= 0]
    of_average = baseline @ baseline.T / baseline.shape[1]
    cov = baseline_covariance(evoked)
    np.testing.assert_allclose(cov.data, evoked.nave * of_average, rtol=1e-12)
    as_one_trial = evoked.copy()
    as_one_trial.nave = 1
    given = mne.Covariance(
        of_average, evoked.ch_names, [], evoked.info["projs"], 50, verbose=False
    )
    expected = apply_skf(as_one_trial, sphere["forward"], given)
    assert relative(apply_skf(evoked, sphere["forward"], "baseline").data, expected.data) < 1e-9


@pytest.fixture(scope="module")
def fixed(sphere):
    """A fixed-orientation forward (random normals on the 25 mm grid) and one sample."""
    rng = np.random.default_rng(2)
    grid = sphere["forward"]["src"][0]
    rr = grid["rr"][grid["vertno"]]
    nn = rng.standard_normal(rr.shape)
    nn /= np.linalg.norm(nn, axis=1, keepdims=True)
    src = mne.setup_volume_source_space(
        pos=dict(rr=rr, nn=nn), sphere=sphere["sphere"], verbose=False
    )
    forward = mne.make_forward_solution(sphere["info"], None, src, sphere["sphere"], verbose=False)
    forward = mne.convert_forward_solution(forward, surf_ori=True, force_fixed=True, verbose=False)
    y = forward["sol"]["data"][:, [7]] * 1e-8 + 1e-6 * rng.standard_normal((32, 1))
    evoked = mne.EvokedArray(y, sphere["info"], nave=25, verbose=False)
    return forward, evoked.set_eeg_reference("average", projection=True, verbose=False)


@pytest.mark.parametrize("lambda2", [1 / 9, 1.0, 1e-2])
@pytest.mark.parametrize("ep_snr_db", [20.0, -300.0])
def test_one_step_is_mne_sloreta(sphere, fixed, lambda2, ep_snr_db):
    # at T = 1, P_{1|0} = (theta0 + q) I and exponent 0.5: z = diag(L^T S^-1 L)^(-1/2)
    # L^T S^-1 y, sLORETA with lambda2 = 1 / (10^(PM/10) (1 + 10^(EP/10))) (the "gain"
    # convention's theta0 and MNE's source covariance both scale the whitened lead field
    # to the rank): PM-SNR = -10 log10(lambda2) when q is negligible (EP-SNR << 0 dB).
    # Same evoked and nave (25), same covariance; fixed orientation (MNE normalizes a free
    # position's three components together, the SKF each on its own: docs/model.md §1)
    forward, evoked = fixed
    inverse = mne.minimum_norm.make_inverse_operator(
        evoked.info, forward, sphere["cov"], loose=0.0, fixed=True, depth=None, verbose=False
    )
    sloreta = mne.minimum_norm.apply_inverse(evoked, inverse, lambda2, "sLORETA", verbose=False)
    pm_snr_db = -10 * np.log10(lambda2) - 10 * np.log10(1 + 10 ** (ep_snr_db / 10))
    if ep_snr_db == -300.0:
        assert pm_snr_db == -10 * np.log10(lambda2)
    skf = apply_skf(evoked, forward, sphere["cov"], pm_snr_db=pm_snr_db, ep_snr_db=ep_snr_db)
    assert relative(skf.data, sloreta.data) < 1e-12
