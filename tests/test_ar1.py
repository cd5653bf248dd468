"""The stationary AR(1) prior (docs/model.md §4, beyond the paper): every path, and its point.

``ar1_priors`` gives ``A = rho I``, ``Q = (1 - rho^2) theta0 I``, ``P_0 = theta0 I``: every path
computes it exactly (dense, filterpy with ``F = rho I``, spectral with its held steady state),
and, unlike the paper's random walk whose ``q`` is divided by the number of steps, the filtered
estimate at a step does not depend on how many steps follow.
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skf_ref import ar1_priors, priors_from_snr, reconstruct

QUANTITIES = ("z", "x", "z_filtered", "x_filtered", "weights")
SMOOTHERS = (None, "rts-standardized", "rts-state", "rts-smoothed-weights")
# What the issue asks: the paths agree to 1e-10 relative, and an epoch and its first half
# give the same filtered estimate to 1e-10 relative. Both are rounding apart on these
# well-conditioned problems (cond(S_t), cond(P_t|t-1) < 1e3).
EQUALITY_RTOL = 1e-10
# The paper's random walk on an epoch and its first half: q differs by a factor 2, and the
# filtered estimates by far more than rounding (a few percent here); this is a floor.
DIFFERENT = 1e-4


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def ar1_problem(seed, m=8, n_positions=4, T=60, time_constant_ms=20.0, sfreq=500.0):
    """A free-orientation lead field and data drawn from the AR(1) prior itself."""
    rng = np.random.default_rng(seed)
    L = rng.standard_normal((m, 3 * n_positions))
    theta0, q, rho = ar1_priors(L, 0.5, 0.0, time_constant_ms, sfreq)
    X = np.empty((L.shape[1], T))
    X[:, 0] = np.sqrt(theta0) * rng.standard_normal(L.shape[1])
    for t in range(1, T):
        X[:, t] = rho * X[:, t - 1] + np.sqrt(q) * rng.standard_normal(L.shape[1])
    Y = L @ X + 0.5 * rng.standard_normal((m, T))
    return dict(L=L, Y=Y, noise_std=0.5, theta0=theta0, q=q, transition=rho)


@pytest.mark.parametrize("time_constant_ms", [1.0, 20.0, 400.0])
@pytest.mark.parametrize("standardize", ["column", "position"])
@pytest.mark.parametrize("smoother", SMOOTHERS)
def test_every_path_computes_the_ar1_prior(smoother, standardize, time_constant_ms):
    # rho = 0.37, 0.90, 0.995 at 500 Hz; 60 steps: the spectral path holds its steady state
    problem = ar1_problem(1, time_constant_ms=time_constant_ms)
    assert 0 < problem["transition"] < 1
    options = dict(smoother=smoother, standardize=standardize, n_orient=3, exponent=1.25)
    reference = reconstruct(**problem, **options, path="dense")
    for method in ("filterpy", "spectral"):
        other = reconstruct(**problem, **options, path=method)
        for name in QUANTITIES:
            assert relative(getattr(other, name), getattr(reference, name)) <= EQUALITY_RTOL, (
                method,
                name,
            )
        assert other.log_likelihood == pytest.approx(reference.log_likelihood, rel=1e-12)


@st.composite
def epochs(draw):
    """A random problem, an AR(1) prior of rho in (0, 1) and a path."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    m, n, T = draw(st.integers(3, 8)), draw(st.integers(1, 10)), draw(st.integers(4, 80))
    L = rng.standard_normal((m, n))
    sigma = draw(st.sampled_from([1e-6, 1.0]))
    Y = sigma * 3 * rng.standard_normal((m, T))
    pm = draw(st.sampled_from([-10.0, 0.0, 10.0]))
    sfreq = draw(st.sampled_from([250.0, 1000.0, 5000.0]))
    tau = draw(st.floats(0.5, 2000.0))
    return dict(
        L=L,
        Y=Y,
        sigma=sigma,
        pm=pm,
        priors=ar1_priors(L, sigma, pm, tau, sfreq),
        method=draw(st.sampled_from(["spectral", "dense", "filterpy"])),
        exponent=draw(st.sampled_from([0.5, 1.0, 1.25])),
    )


@given(epochs())
def test_the_filtered_estimate_does_not_depend_on_the_steps_that_follow(problem):
    L, Y, sigma = problem["L"], problem["Y"], problem["sigma"]
    half = Y.shape[1] // 2
    common = dict(noise_std=sigma, path=problem["method"], exponent=problem["exponent"])
    theta0, q, rho = problem["priors"]
    whole = reconstruct(L, Y, theta0=theta0, q=q, transition=rho, **common)
    first = reconstruct(L, Y[:, :half], theta0=theta0, q=q, transition=rho, **common)
    for name in ("z_filtered", "x_filtered"):
        shared = getattr(whole, name)[:, :half]
        assert relative(getattr(first, name), shared) <= EQUALITY_RTOL, name
    # the paper's random walk: q = kappa^2 theta0 / K depends on K, and so does the estimate
    walks = [priors_from_snr(L, sigma, problem["pm"], 0.0, n_steps=k) for k in (Y.shape[1], half)]
    whole, first = (
        reconstruct(L, data, theta0=t0, q=qk, **common)
        for (t0, qk), data in zip(walks, (Y, Y[:, :half]), strict=True)
    )
    assert relative(first.z_filtered, whole.z_filtered[:, :half]) > DIFFERENT


# --- the time constant chosen by the data (tune) ------------------------------------------

TAUS = (5.0, 20.0, 80.0)
# What the issue asks: on data simulated from the model, the chosen time constant within 30 %
# of the truth in at least 8 of 10 seeds for each one. Measured on seeds (42, 0) .. (42, 9):
# every seed within 13 % at 5 and 20 ms; at 80 ms nine within 30 % and one 38 % off (0.6 s
# holds few independent stretches of 80 ms).
TAU_RTOL = 0.3


def simulate_ar1(seed, time_constant_ms, m=32, n=200, T=300, sfreq=500.0, pm_snr_db=0.0):
    """A random lead field, sources from the AR(1) prior itself, unit white noise."""
    rng = np.random.default_rng((42, seed))
    L = rng.standard_normal((m, n))
    theta0, q, rho = ar1_priors(L, 1.0, pm_snr_db, time_constant_ms, sfreq)
    X = np.empty((n, T))
    X[:, 0] = np.sqrt(theta0) * rng.standard_normal(n)
    for t in range(1, T):
        X[:, t] = rho * X[:, t - 1] + np.sqrt(q) * rng.standard_normal(n)
    return L, L @ X + rng.standard_normal((m, T))


def chosen_time_constants(tau, seeds):
    from skf_ref import tune

    chosen = []
    for seed in seeds:
        L, Y = simulate_ar1(seed, tau)
        result = tune(L, Y, noise_std=1.0, time_constant_ms="auto", sfreq=500.0)
        assert result.at_bound == {} and result.ep_snr_db is None
        assert result.transition == pytest.approx(np.exp(-2.0 / result.time_constant_ms))
        chosen.append(result.time_constant_ms)
    return np.array(chosen)


@pytest.mark.parametrize("tau", TAUS)
def test_tune_finds_the_time_constant_of_data_from_the_model(tau):
    # the default run: two seeds per time constant (the slow test below runs ten)
    chosen = chosen_time_constants(tau, seeds=range(2))
    assert np.all(np.abs(chosen / tau - 1) <= TAU_RTOL), chosen


@pytest.mark.slow
@pytest.mark.parametrize("tau", TAUS)
def test_tune_finds_the_time_constant_in_8_of_10_seeds(tau):
    chosen = chosen_time_constants(tau, seeds=range(10))
    assert np.count_nonzero(np.abs(chosen / tau - 1) <= TAU_RTOL) >= 8, chosen


def test_tune_over_a_fixed_time_constant_chooses_the_pm_snr_only():
    from skf_ref import tune

    L, Y = simulate_ar1(0, 20.0, T=100)
    result = tune(L, Y, noise_std=1.0, time_constant_ms=20.0, sfreq=500.0, grid=7)
    theta0, q, rho = ar1_priors(L, 1.0, result.pm_snr_db, 20.0, 500.0)
    assert result.time_constant_ms == 20.0 and result.landscape.shape == (7, 6)
    assert (result.theta0, result.q, result.transition) == pytest.approx((theta0, q, rho), 1e-12)
    rec = reconstruct(L, Y, noise_std=1.0, theta0=theta0, q=q, transition=rho)
    assert rec.log_likelihood == pytest.approx(result.log_likelihood, rel=1e-12)
    assert "time constant 20 ms" in repr(result) and "Time constant (ms)" in result._repr_html_()


def test_a_time_constant_on_its_bound_warns_with_the_remedy():
    from skf_ref import tune

    L, Y = simulate_ar1(1, 80.0, T=100)
    remedy = (
        r"time_constant_ms = 10 ms lies on the upper bound 10 ms of its search range \(1, "
        r"10\): the marginal likelihood is largest there or beyond; widen time_constant_ms "
        r"above 10 ms to let the data choose: time_constant_ms=\(1, 100\) in Python .* or "
        r"--time-constant-ms=1,100 on the command line"
    )
    with pytest.warns(UserWarning, match=remedy):
        result = tune(L, Y, noise_std=1.0, time_constant_ms=(1.0, 10.0), sfreq=500.0, grid=5)
    assert result.at_bound == {"time_constant_ms": "upper"} and result.time_constant_ms == 10.0


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(ep_snr_db=0.0), r"give ep_snr_db .* or time_constant_ms .* not both"),
        (dict(sfreq=None), r"time_constant_ms='auto' needs sfreq, the sampling rate of Y"),
        (dict(sfreq=-1.0), "sfreq must be > 0, got -1.0"),
        (dict(transition=0.9), "give transition or time_constant_ms, not both"),
        (dict(criterion="discrepancy"), "the time constant of the AR.1. prior is chosen by"),
        (dict(time_constant_ms=(5.0, 5.0)), r"give one number to fix it"),
        (dict(time_constant_ms=[1, 2, 3]), "must be a number of milliseconds, 'auto' or"),
    ],
)
def test_tune_refuses_a_contradictory_time_constant(change, match):
    from skf_ref import InputError, tune

    L, Y = simulate_ar1(2, 20.0, T=20)
    kwargs = dict(noise_std=1.0, time_constant_ms="auto", sfreq=500.0) | change
    with pytest.raises(InputError, match=match):
        tune(L, Y, **kwargs)
