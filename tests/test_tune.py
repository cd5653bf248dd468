"""Priors chosen by the data: the likelihood without outputs, its maximum, and its inputs."""

import warnings

import numpy as np
import pytest
from scipy import linalg

import skf_ref
from skf_ref import InputError, reconstruct, tune
from skf_ref.method import SpectralBasis

# The likelihood-only recursion and the full paths compute the same sum of the same terms
# in other orders (the dense path through Cholesky factors of S): rounding, ~1e-15 relative.
LIKELIHOOD_RTOL = 1e-11
# The residual in the basis against the dense path's x_{t|t}: the same numbers by other
# roundings (the dense path's Cholesky solves, the SVD), ~1e-13 relative.
RESIDUAL_RTOL = 1e-10
# The discrepancy's EP-SNR is solved to 1e-10 dB, where the residual's slope is below 1 per
# dB: it meets n_channels * n_times to ~1e-11 relative, on the dense path as in the basis.
DISCREPANCY_RTOL = 1e-9


def whitened_residual(L, Y, R, x_filtered):
    """sum_t ||C^{-1} (y_t - L x_{t|t})||^2 with R = C C^T, the direct way."""
    C = linalg.cholesky(R, lower=True)
    return float(np.sum(linalg.solve_triangular(C, Y - L @ x_filtered, lower=True) ** 2))


def state_space_data(seed, m=16, n=40, T=200, sigma=0.5, theta0=0.8, q=0.05):
    """Data drawn from the model itself: x_0 ~ N(0, theta0 I), increments N(0, q I)."""
    rng = np.random.default_rng(seed)
    L = rng.standard_normal((m, n))
    x = np.sqrt(theta0) * rng.standard_normal(n)
    X = np.cumsum(np.sqrt(q) * rng.standard_normal((n, T)), axis=1) + x[:, None]
    return L, L @ X + sigma * rng.standard_normal((m, T))


@pytest.mark.parametrize("transition", [1.0, 0.9])
def test_likelihood_without_outputs_equals_every_path(transition):
    L, Y = state_space_data(0, T=30)
    basis = SpectralBasis(L, 0.25 * np.eye(16))
    priors = [(0.8, 0.05), (2.0, 0.001), (1e-3, 1.0)]
    values = basis.log_likelihood(Y, [p[0] for p in priors], [p[1] for p in priors], transition)
    for (theta0, q), value in zip(priors, values, strict=True):
        for method in ("spectral", "dense"):
            rec = reconstruct(
                L, Y, noise_std=0.5, theta0=theta0, q=q, transition=transition, path=method
            )
            assert value == pytest.approx(rec.log_likelihood, rel=LIKELIHOOD_RTOL), method


@pytest.mark.parametrize("transition", [1.0, 0.9])
def test_residual_energy_equals_the_dense_paths_residual(transition):
    L, Y = state_space_data(6, T=30)
    rng = np.random.default_rng(6)
    B = rng.standard_normal((16, 16))
    R = 0.25 * np.eye(16) + 0.01 * B @ B.T  # a full covariance: the whitening is not a scale
    basis = SpectralBasis(L, R)
    priors = [(0.8, 0.05), (2.0, 0.001), (1e-3, 1.0)]
    values = basis.residual_energy(Y, [p[0] for p in priors], [p[1] for p in priors], transition)
    assert values.shape == (3,)
    for (theta0, q), value in zip(priors, values, strict=True):
        rec = reconstruct(
            L, Y, noise_cov=R, theta0=theta0, q=q, transition=transition, path="dense"
        )
        direct = whitened_residual(L, Y, R, rec.x_filtered)
        assert value == pytest.approx(direct, rel=RESIDUAL_RTOL)
        alone = basis.residual_energy(Y, theta0, q, transition)
        assert isinstance(alone, float) and alone == pytest.approx(value, rel=1e-14)


def test_neither_exponent_nor_smoother_changes_the_likelihood():
    L, Y = state_space_data(1, T=20)
    values = {
        reconstruct(L, Y, noise_std=0.5, theta0=0.8, q=0.05, exponent=e, smoother=s).log_likelihood
        for e in (0.5, 1.25)
        for s in (None, "rts-standardized", "rts-state")
    }
    assert len(values) == 1


def test_the_maximum_lands_near_the_truth():
    # theta0 is seen through x_0 alone: 40 draws give a variance estimate with relative
    # standard error sqrt(2 / 40) ~ 1 dB, more with 16 channels seeing 40 sources (over 20
    # seeds the error's standard deviation was 1.7 dB, the largest 4.7 dB); q through all
    # 40 x 200 increments (0.13 dB and 0.31 dB). Bounds: about 3.5 standard deviations.
    L, Y = state_space_data(2)
    result = tune(L, Y, noise_std=0.5)
    assert abs(10 * np.log10(result.theta0 / 0.8)) < 6.0
    assert abs(10 * np.log10(result.q / 0.05)) < 0.5
    rec = reconstruct(L, Y, noise_std=0.5, theta0=result.theta0, q=result.q)
    assert result.log_likelihood == pytest.approx(rec.log_likelihood, rel=LIKELIHOOD_RTOL)
    # the refinement starts from the best cell and can only improve on the grid
    assert result.log_likelihood >= result.landscape["log_likelihood"].max()
    assert result.landscape.shape == (169, 5)


@pytest.mark.parametrize("pm_snr_db", [10.0, "auto"])
@pytest.mark.parametrize("full_cov", [False, True])
def test_the_discrepancy_puts_the_dense_paths_residual_at_its_expected_value(pm_snr_db, full_cov):
    L, Y = state_space_data(2, T=60)
    m, T = Y.shape
    if full_cov:
        B = np.random.default_rng(2).standard_normal((m, m))
        noise = dict(noise_cov=0.25 * np.eye(m) + 0.01 * B @ B.T)
    else:
        noise = dict(noise_std=0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an interior solution: no bound warning
        result = tune(L, Y, pm_snr_db=pm_snr_db, criterion="discrepancy", **noise)
    assert result.criterion == "discrepancy" and result.at_bound == {}
    rec = reconstruct(L, Y, theta0=result.theta0, q=result.q, path="dense", **noise)
    R = noise.get("noise_cov", 0.25 * np.eye(m))
    residual = whitened_residual(L, Y, R, rec.x_filtered)
    assert residual == pytest.approx(m * T, rel=DISCREPANCY_RTOL)
    assert result.residual_energy == pytest.approx(m * T, rel=DISCREPANCY_RTOL)
    assert result.log_likelihood == pytest.approx(rec.log_likelihood, rel=LIKELIHOOD_RTOL)
    if pm_snr_db == "auto":
        # PM-SNR by the likelihood along the curve: no solved point of the grid scores higher
        solved = result.curve[result.curve["solved"]]
        assert result.log_likelihood >= solved["log_likelihood"].max()
    else:
        assert result.pm_snr_db == 10.0 and len(result.curve) == 1


@pytest.mark.parametrize("criterion", ["likelihood", "discrepancy"])
def test_an_interior_choice_does_not_warn(criterion):
    L, Y = state_space_data(2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = tune(L, Y, noise_std=0.5, criterion=criterion)
    assert result.at_bound == {}
    assert repr(result).endswith(f", by {criterion}>")


def test_the_discrepancy_asks_for_less_process_noise_than_the_truth():
    # docs/model.md §4: the target m T exceeds the filtered residual expected at the true
    # priors, so the principle chooses a smaller q (here 3.7 dB against 11 dB EP-SNR)
    L, Y = state_space_data(2)
    likelihood = tune(L, Y, noise_std=0.5)
    discrepancy = tune(L, Y, noise_std=0.5, criterion="discrepancy")
    assert discrepancy.q < 0.05 / 2 < likelihood.q  # the truth: q = 0.05
    assert discrepancy.ep_snr_db == pytest.approx(3.7, abs=0.1)


@pytest.mark.parametrize(
    "criterion, ranges, name, end, bound",
    [
        # the truth is PM ~ 21 dB, EP ~ 11 dB (state_space_data's theta0 and q)
        ("likelihood", dict(pm_snr_db=(-20, 0)), "pm_snr_db", "upper", "0"),
        ("likelihood", dict(ep_snr_db=(20, 40)), "ep_snr_db", "lower", "20"),
        ("discrepancy", dict(pm_snr_db=(-20, 0)), "pm_snr_db", "upper", "0"),
        # no root inside: the residual stays above its target up to -10 dB
        ("discrepancy", dict(ep_snr_db=(-20, -10)), "ep_snr_db", "upper", "-10"),
    ],
)
def test_a_choice_on_a_bound_warns_naming_the_parameter_and_the_bound(
    criterion, ranges, name, end, bound
):
    L, Y = state_space_data(2)
    match = rf"{name} = {float(bound):.2f} dB lies on the {end} bound {bound} dB .*widen {name}"
    with pytest.warns(UserWarning, match=match) as record:
        result = tune(L, Y, noise_std=0.5, criterion=criterion, **ranges)
    assert result.at_bound[name] == end
    assert f"{name} on its {end} bound" in repr(result)
    assert {w.filename for w in record} == {__file__}  # the warning points at the caller


def test_a_fixed_snr_never_warns():
    L, Y = state_space_data(2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for criterion in ("likelihood", "discrepancy"):
            # 40 dB is the end of the default range, but it was given, not chosen
            result = tune(L, Y, noise_std=0.5, pm_snr_db=40.0, criterion=criterion)
            assert "pm_snr_db" not in result.at_bound


def test_choose_priors_passes_the_criterion_and_warns_at_its_caller():
    L, Y = state_space_data(2, T=60)
    theta0, q, transition, result = skf_ref.method._tuning.choose_priors(
        L, Y, noise_std=0.5, pm_snr_db=10.0, ep_snr_db="auto", criterion="discrepancy"
    )
    assert result.criterion == "discrepancy" and (theta0, q) == (result.theta0, result.q)
    assert transition == result.transition == 1.0
    assert result.residual_energy == pytest.approx(Y.size, rel=DISCREPANCY_RTOL)
    with pytest.warns(UserWarning, match="pm_snr_db = -20.00 dB lies on the lower") as record:
        skf_ref.method._tuning.choose_priors(
            L, 0.5 * np.ones_like(Y), noise_std=0.5, pm_snr_db="auto", ep_snr_db=40.0
        )
    assert {w.filename for w in record} == {__file__}


def test_landscape_is_finite_over_the_default_grid_of_the_study():
    from skf_ref.study._head import make_head_model
    from skf_ref.study._scenario import p20n20_scenario, simulate

    head = make_head_model(500)
    sim = simulate(head, p20n20_scenario(), 10.0, seed=0)
    # on the study's data the likelihood prefers a PM-SNR below the fine map's span
    with pytest.warns(UserWarning, match="pm_snr_db = -20.00 dB lies on the lower bound"):
        result = tune(head.leadfield, sim.Y, noise_std=sim.sigma)
    assert result.at_bound == {"pm_snr_db": "lower"}
    assert np.isfinite(result.landscape["log_likelihood"]).all()
    assert result.landscape["pm_snr_db"].min() == -20 and result.landscape["ep_snr_db"].max() == 40


def test_a_fixed_snr_and_auto_everywhere(mne_setup):
    L, Y = state_space_data(3, T=60)
    fixed = tune(L, Y, noise_std=0.5, pm_snr_db=0.0, grid=9)
    assert fixed.pm_snr_db == 0.0 and fixed.landscape.shape == (9, 5)
    theta0, q, _, _ = skf_ref.method._tuning.choose_priors(
        L, Y, noise_std=0.5, pm_snr_db=0.0, ep_snr_db="auto"
    )
    assert (theta0, q) == pytest.approx((fixed.theta0, fixed.q), rel=1e-6)
    epochs = mne_setup["make_epochs"](target=300, seed=7)
    with pytest.warns(UserWarning, match="lies on the .* bound") as record:
        stc, rec = skf_ref.apply_skf(
            epochs.average(),
            mne_setup["forward"],
            noise_std=1e-6,
            pm_snr_db="auto",
            ep_snr_db="auto",
            return_reconstruction=True,
        )
    assert {w.filename for w in record} == {__file__}  # through apply_skf to its caller
    assert rec.tuning is not None and rec.theta0 == rec.tuning.theta0
    assert np.isfinite(stc.data).all()


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(pm_snr_db=(40, -20)), r"pm_snr_db must be a range \(lo, hi\) with lo < hi"),
        (dict(ep_snr_db=(10, 10)), r"got \(10, 10\); give one number to fix it"),
        (dict(pm_snr_db=(float("nan"), 40)), r"pm_snr_db\[0\] must be finite"),
        (dict(ep_snr_db=(-20, 400)), r"ep_snr_db\[1\] must be <= 300 dB"),
        (dict(pm_snr_db=(1, 2, 3)), "pm_snr_db must be a number or a range"),
        (dict(grid=1), "grid must be >= 2"),
        (dict(convention="toolbox", noise_std=None, noise_cov=np.eye(16)), "needs noise_std"),
        (dict(transition=np.eye(40)), "transition must be a scalar"),
        (
            dict(criterion="morozov"),
            r"criterion must be one of \['likelihood', 'discrepancy'\], got 'morozov'",
        ),
    ],
)
def test_bad_ranges_are_refused(change, match):
    L, Y = state_space_data(4, T=10)
    kwargs = dict(noise_std=0.5) | change
    with pytest.raises(InputError, match=match):
        tune(L, Y, **kwargs)
    with pytest.raises(InputError, match="priors chosen by the data .'auto'. are skf_ref.tune's"):
        skf_ref.priors_from_snr(L, 0.5, "auto", 20.0, 10)
    with pytest.raises(InputError, match="criterion must be one of"):
        skf_ref.method._tuning.choose_priors(
            L, Y, noise_std=0.5, pm_snr_db=0.0, ep_snr_db=0.0, criterion="morozov"
        )


def test_landscape_figure_marks_the_chosen_point():
    from skf_ref.study._plots import plot_landscape

    L, Y = state_space_data(5, T=20)
    result = tune(L, Y, noise_std=0.5, grid=5)
    fig = plot_landscape(result)
    (ax,) = [ax for ax in fig.axes if ax.get_xlabel() == "EP-SNR (dB)"]
    star = [line for line in ax.get_lines() if line.get_marker() == "*"][0]
    assert (star.get_xdata()[0], star.get_ydata()[0]) == (result.ep_snr_db, result.pm_snr_db)
