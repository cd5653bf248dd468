"""Missing observations: a column of Y that is all NaN is a step without a measurement.

The filter predicts across it without an update (docs/model.md §2): nothing of that step
reaches the state, its standardized outputs are NaN, and every path computes the same thing
to rounding, the spectral one exactly (its steady state held after the last gap).
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skf_ref import InputError, Reconstruction, priors_from_snr, reconstruct
from skf_ref.method import SpectralBasis, SpectralModel, StateSpaceModel

PATHS = ("dense", "filterpy", "spectral")
#: The paths agree to rounding on these small problems: filterpy updates P in Joseph form
#: and forms S^-1, the spectral path works in the singular basis (test_core's tolerance).
PATHS_RTOL = 1e-10
OUTPUTS = ("z", "x", "z_filtered", "x_filtered", "weights")


def relative(a, b):
    """Largest difference relative to the largest entry, over the entries that are numbers;
    NaN must be in the same places."""
    assert np.array_equal(np.isnan(a), np.isnan(b))
    return np.nanmax(np.abs(a - b)) / np.nanmax(np.abs(b))


def problem(seed=0, m=6, n=9, T=40, gaps=((0, 1), (12, 17), (38, 40))):
    rng = np.random.default_rng(seed)
    L = rng.standard_normal((m, n))
    Y = L @ np.cumsum(0.3 * rng.standard_normal((n, T)), axis=1)
    Y += 0.5 * rng.standard_normal((m, T))
    for start, stop in gaps:
        Y[:, start:stop] = np.nan
    theta0, q = priors_from_snr(L, 0.5, pm_snr_db=0.0, ep_snr_db=20.0, n_steps=T)
    return dict(L=L, Y=Y, noise_std=0.5, theta0=theta0, q=q)


@pytest.mark.parametrize("smoother", [None, "rts-state"])
@pytest.mark.parametrize("method", ["filterpy", "spectral"])
def test_every_path_treats_a_gap_as_the_dense_one(method, smoother):
    kwargs = dict(problem(), smoother=smoother, exponent=1.25)
    dense = reconstruct(**kwargs, path="dense")
    other = reconstruct(**kwargs, path=method)
    for name in OUTPUTS:
        assert relative(getattr(other, name), getattr(dense, name)) <= PATHS_RTOL, name
    assert other.log_likelihood == pytest.approx(dense.log_likelihood, rel=PATHS_RTOL)
    np.testing.assert_array_equal(other.missing, dense.missing)


@pytest.mark.parametrize("method", PATHS)
def test_a_missing_step_is_a_prediction_without_an_update(method):
    kwargs = problem(gaps=((12, 17),))
    rec = reconstruct(**kwargs, transition=0.9, path=method)
    gap = np.zeros(40, bool)
    gap[12:17] = True
    np.testing.assert_array_equal(rec.missing, gap)
    assert repr(rec).startswith("<Reconstruction | 9 sources x 40 steps, 5 missing,")
    for name in ("z", "z_filtered", "weights"):  # no measurement, no weights, no z
        values = getattr(rec, name)
        assert np.isnan(values[:, gap]).all() and np.isfinite(values[:, ~gap]).all(), name
    # x_{t|t} = x_{t|t-1} = A x_{t-1|t-1}: the state decays across the gap, nothing added
    x = rec.x_filtered
    np.testing.assert_allclose(x[:, 12:17], 0.9 * x[:, 11:16], rtol=1e-13, atol=0)
    assert np.isnan(rec.amplitude(3)[:, gap]).all()


@pytest.mark.parametrize("method", PATHS)
def test_the_estimate_before_a_gap_is_that_of_the_data_before_it(method):
    # the filter is causal: a gap at the end changes nothing before it, and the
    # log-likelihood sums the observed steps only
    kwargs = problem(gaps=((30, 40),))
    gapped = reconstruct(**kwargs, path=method)
    cut = reconstruct(**{**kwargs, "Y": kwargs["Y"][:, :30]}, path=method)
    for name in ("z", "x", "weights"):
        np.testing.assert_allclose(getattr(gapped, name)[:, :30], getattr(cut, name), rtol=1e-12)
    assert gapped.log_likelihood == pytest.approx(cut.log_likelihood, rel=1e-12)


def test_the_data_inside_a_gap_never_matter():
    # whatever a gap hides, it is NaN: here the same data with another gap pattern inside
    # the gap give bit-equal estimates outside it, on the dense path (one operation order)
    kwargs = problem(gaps=((12, 17),))
    first = reconstruct(**kwargs, path="dense", smoother="rts-state")
    Y = kwargs["Y"].copy()
    Y[:, 12:17] = np.nan  # the same gap, re-made
    second = reconstruct(**{**kwargs, "Y": Y}, path="dense", smoother="rts-state")
    for name in OUTPUTS:
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name))


@pytest.mark.parametrize("method", PATHS)
def test_the_state_smoother_interpolates_across_a_gap(method):
    kwargs = problem(gaps=((12, 17),))
    smoothed = reconstruct(**kwargs, path=method, smoother="rts-state")
    filtered = reconstruct(**kwargs, path=method)
    assert np.isfinite(smoothed.x).all()
    assert np.isnan(smoothed.z[:, 12:17]).all() and np.isfinite(smoothed.z[:, 17:]).all()
    # the data after the gap reach the smoothed state inside it (the filter's cannot)
    assert not np.allclose(smoothed.x[:, 12:17], filtered.x_filtered[:, 12:17])


@pytest.mark.parametrize("method", PATHS)
def test_the_papers_smoother_is_refused_over_a_gap(method):
    with pytest.raises(InputError, match=r"smoother='rts-standardized' is undefined over missing"):
        reconstruct(**problem(), path=method, smoother="rts-standardized")
    model = StateSpaceModel.create(**{k: v for k, v in problem().items() if k != "Y"})
    with pytest.raises(InputError, match=r"use smoother='rts-state'"):
        SpectralModel(model, 40).apply(problem()["Y"], 0.5, "rts-standardized")


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda Y: Y.__setitem__((2, 5), np.nan), r"Y\[:, 5\] is NaN in 1 of its 6 channels"),
        (lambda Y: Y.__setitem__((2, 5), np.inf), r"Y contains Inf \(first in column 5\)"),
        (lambda Y: Y.__setitem__(..., np.nan), r"every column of Y is NaN: no step is observed"),
    ],
)
def test_a_step_is_measured_on_every_channel_or_missing(change, match):
    kwargs = problem(gaps=())
    change(kwargs["Y"])
    for method in PATHS:
        with pytest.raises(InputError, match=match):
            reconstruct(**kwargs, path=method)


def test_the_result_refuses_nan_outside_the_missing_steps():
    z = np.ones((2, 3))
    given = dict(log_likelihood=0.0, n_sources=2, n_times=3, exponent=0.5, smoother=None)
    given |= dict(path="dense", theta0=1.0, q=1.0)
    gap = z.copy()
    gap[:, 1] = np.nan
    ok = Reconstruction(z=gap, x=z, z_filtered=gap, x_filtered=z, weights=gap, **given,
                        missing=[False, True, False])  # fmt: skip
    assert np.isnan(ok.z[:, 1]).all()
    with pytest.raises(InputError, match="the reconstruction's z is not finite"):
        Reconstruction(z=gap, x=z, z_filtered=z, x_filtered=z, weights=z, **given)
    with pytest.raises(InputError, match="the reconstruction's x is not finite"):
        Reconstruction(z=gap, x=gap, z_filtered=gap, x_filtered=z, weights=gap, **given,
                       missing=[False, True, False])  # fmt: skip
    inf = gap.copy()
    inf[0, 1] = np.inf
    with pytest.raises(InputError, match="z is infinite at a missing step"):
        Reconstruction(z=inf, x=z, z_filtered=gap, x_filtered=z, weights=gap, **given,
                       missing=[False, True, False])  # fmt: skip
    with pytest.raises(InputError, match="missing must be 3 booleans"):
        Reconstruction(z=z, x=z, z_filtered=z, x_filtered=z, weights=z, **given, missing=[1, 0])


def test_blocks_of_a_gapped_spectral_reconstruction_equal_its_arrays():
    rec = reconstruct(**problem(n=30), smoother="rts-state")
    for name in OUTPUTS:
        blocks = np.vstack([block for _, block in rec.blocks(name, rows=7)])
        fresh = reconstruct(**problem(n=30), smoother="rts-state")
        np.testing.assert_allclose(blocks, getattr(fresh, name), rtol=1e-13, equal_nan=True)


def test_the_steady_state_is_held_after_the_last_gap_only():
    kwargs = problem(T=600, gaps=((250, 260),))
    gapped = reconstruct(**kwargs)
    whole = reconstruct(**{**kwargs, "Y": np.nan_to_num(kwargs["Y"])})
    assert whole.lazy_outputs.steady < 250 < 260 < gapped.lazy_outputs.steady < 600
    dense = reconstruct(**kwargs, path="dense")
    for name in OUTPUTS:
        assert relative(getattr(gapped, name), getattr(dense, name)) <= PATHS_RTOL, name


def test_the_likelihood_of_many_priors_skips_the_gaps():
    kwargs = problem()
    basis = SpectralBasis(kwargs["L"], 0.25 * np.eye(6))
    priors = (np.array([0.5, 1.0, 2.0]) * kwargs["theta0"], kwargs["q"] * np.ones(3))
    many = basis.log_likelihood(kwargs["Y"], *priors)
    for theta0, q, value in zip(*priors, many, strict=True):
        one = reconstruct(**{**kwargs, "theta0": theta0, "q": q}, path="dense")
        assert value == pytest.approx(one.log_likelihood, rel=1e-12)


@st.composite
def gapped_problems(draw):
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    m, n, T = draw(st.integers(1, 6)), draw(st.integers(1, 8)), draw(st.integers(2, 60))
    L = draw(st.sampled_from([1e-3, 1.0, 1e3])) * rng.standard_normal((m, n))
    sigma = draw(st.sampled_from([1e-6, 1.0]))
    Y = sigma * 3 * np.cumsum(rng.standard_normal((m, T)), axis=1)
    missing = rng.random(T) < draw(st.sampled_from([0.05, 0.3, 0.7]))
    missing[rng.integers(T)] = False  # at least one step observed
    Y[:, missing] = np.nan
    theta0, q = priors_from_snr(
        L,
        sigma,
        pm_snr_db=draw(st.sampled_from([-20.0, 0.0, 20.0])),
        ep_snr_db=draw(st.sampled_from([-20.0, 0.0, 20.0])),
        n_steps=T,
    )
    return dict(
        L=L,
        Y=Y,
        noise_std=sigma,
        theta0=theta0,
        q=q,
        transition=draw(st.sampled_from([1.0, 0.9, -0.5])),
        exponent=draw(st.sampled_from([0.0, 0.5, 1.25])),
        smoother=draw(st.sampled_from([None, "rts-state"])),
    )


@pytest.mark.slow
@given(gapped_problems())
def test_paths_agree_on_random_gapped_problems(kwargs):
    dense = reconstruct(**kwargs, path="dense")
    for method in ("filterpy", "spectral"):
        other = reconstruct(**kwargs, path=method)
        for name in OUTPUTS:
            assert relative(getattr(other, name), getattr(dense, name)) <= 1e-8, (method, name)
        assert other.log_likelihood == pytest.approx(dense.log_likelihood, rel=1e-8, abs=1e-8)


@pytest.mark.parametrize("criterion", ["likelihood", "discrepancy"])
def test_priors_chosen_from_gapped_data(criterion):
    # tune's grid sums the observed steps, as reconstruct does at the priors it chose
    from skf_ref import tune

    kwargs = problem(T=60, gaps=((10, 20), (55, 60)))
    result = tune(kwargs["L"], kwargs["Y"], noise_std=0.5, grid=5, criterion=criterion,
                  pm_snr_db=0.0, ep_snr_db=(-20.0, 80.0))  # fmt: skip
    assert not result.at_bound
    rec = reconstruct(**{**kwargs, "theta0": result.theta0, "q": result.q}, path="dense")
    assert result.log_likelihood == pytest.approx(rec.log_likelihood, rel=1e-10)
    if criterion == "discrepancy":  # m T over the observed steps: 6 x 45
        residual = np.nansum((kwargs["Y"] - kwargs["L"] @ rec.x_filtered) ** 2) / 0.25
        assert result.residual_energy == pytest.approx(residual, rel=1e-10)
        assert result.residual_energy == pytest.approx(6 * 45, rel=1e-6)
