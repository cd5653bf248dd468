"""The smoother standardized by its own variance (``"rts-smoothed-weights"``, docs/model.md §3).

Its output is checked against an independent computation: the smoothed mean and its
variance from conditioning the joint Gaussian of all states and all data at once (no
Kalman recursion), which gives ``x^s_t = E[x_t | Y]`` and, by the law of total covariance,
``Cov(x^s_t) = Sigma_t - P^s_t``.
"""

import numpy as np
import pytest
from scipy import linalg

from skf_ref import reconstruct
from skf_ref.method._paths import dense

PATHS = ("dense", "filterpy", "spectral")
# The batch computation solves one (m T) x (m T) system; both it and the recursions are
# exact algebra on well-conditioned problems (condition numbers below 1e3 here).
BATCH_RTOL = 1e-10


@pytest.fixture(params=PATHS)
def method(request):
    return request.param


def relative(actual, desired):
    return np.max(np.abs(actual - desired)) / np.max(np.abs(desired))


def prior_covariances(A, Q, P0, T):
    """Cov(x_t, x_u) for t, u = 1..T under x_t = A x_{t-1} + q_t, x_0 ~ N(0, P0): (T, T, n, n)."""
    n = len(A)
    Sigma = np.empty((T + 1, n, n))
    Sigma[0] = P0
    for t in range(1, T + 1):
        Sigma[t] = A @ Sigma[t - 1] @ A.T + Q
    C = np.empty((T, T, n, n))
    for t in range(1, T + 1):
        for u in range(1, T + 1):
            k = abs(t - u)
            power = np.linalg.matrix_power(A, k)
            if t >= u:  # Cov(x_t, x_u) = A^(t-u) Sigma_u
                C[t - 1, u - 1] = power @ Sigma[u]
            else:
                C[t - 1, u - 1] = Sigma[t] @ power.T
    return C, Sigma[1:]


def batch_smoother(L, Y, R, A, Q, P0):
    """x^s_t = E[x_t | Y] and Cov(x^s_t), by conditioning the joint Gaussian at once.

    Returns
    -------
    x_s : ndarray, shape (T, n)
    covariance : ndarray, shape (T, n, n)
        ``Cov(x^s_t) = C_{x_t Y} C_YY^-1 C_Y x_t``.
    Sigma : ndarray, shape (T, n, n)
        The prior covariance of x_t.
    """
    m, T = Y.shape
    n = L.shape[1]
    C, Sigma = prior_covariances(A, Q, P0, T)
    Cxx = C.transpose(0, 2, 1, 3).reshape(T * n, T * n)
    big_L = np.kron(np.eye(T), L)
    Cyy = big_L @ Cxx @ big_L.T + np.kron(np.eye(T), R)
    Cxy = Cxx @ big_L.T
    gain = linalg.solve(Cyy, Cxy.T, assume_a="pos").T
    x_s = (gain @ Y.T.ravel()).reshape(T, n)
    covariance = np.array([gain[t * n : t * n + n] @ Cxy[t * n : t * n + n].T for t in range(T)])
    return x_s, covariance, Sigma


def problem(seed, m=7, n=6, T=5):
    rng = np.random.default_rng(seed)
    L = rng.standard_normal((m, n)) * rng.uniform(0.3, 2.0, n)
    Y = rng.standard_normal((m, T))
    return L, Y


@pytest.mark.parametrize("q", [0.0, 0.3])
@pytest.mark.parametrize("noise", ["noise_std", "noise_cov"])
def test_at_one_half_each_output_is_the_smoothed_estimate_over_its_own_sd(method, q, noise):
    # docs/model.md §3: A = I, isotropic priors, alpha = 1/2: z^s_ti = x^s_ti / sd(x^s_ti)
    L, Y = problem(1)
    m, n = L.shape
    rng = np.random.default_rng(2)
    if noise == "noise_std":
        R, noise_kwargs = 0.49 * np.eye(m), dict(noise_std=0.7)
    else:
        B = rng.standard_normal((m, m))
        R = B @ B.T / m + 0.3 * np.eye(m)
        noise_kwargs = dict(noise_cov=R)
    theta0 = 0.8
    rec = reconstruct(
        L, Y, **noise_kwargs, theta0=theta0, q=q, exponent=0.5,
        smoother="rts-smoothed-weights", path=method,
    )  # fmt: skip
    x_s, covariance, _ = batch_smoother(L, Y, R, np.eye(n), q * np.eye(n), theta0 * np.eye(n))
    sd = np.sqrt(np.diagonal(covariance, axis1=1, axis2=2))
    assert relative(rec.x.T, x_s) < BATCH_RTOL
    assert relative(rec.z.T, x_s / sd) < BATCH_RTOL


@pytest.mark.parametrize("exponent", [0.5, 1.25])
def test_general_model_is_the_whitened_estimate_over_its_own_covariance(exponent):
    # any A, Q, P0 (dense and filterpy): w^s = diag(Sigma^-1/2 Cov(x^s) Sigma^-1/2) and
    # z^s = (w^s)^-alpha Sigma^-1/2 x^s, with Sigma_t the prior covariance of x_t
    L, Y = problem(3)
    m, n = L.shape
    rng = np.random.default_rng(4)
    A = 0.9 * np.eye(n) + 0.05 * rng.standard_normal((n, n))
    B = rng.standard_normal((n, n))
    Q = B @ B.T / n + 0.1 * np.eye(n)
    P0 = np.diag(rng.uniform(0.5, 2.0, n))
    R = 0.3 * np.eye(m)
    x_s, covariance, Sigma = batch_smoother(L, Y, R, A, Q, P0)
    expected = []
    for t in range(Y.shape[1]):
        eigenvalues, E = linalg.eigh(Sigma[t])
        whiten = (E / np.sqrt(eigenvalues)) @ E.T
        w = np.diag(whiten @ covariance[t] @ whiten)
        expected.append(w**-exponent * (whiten @ x_s[t]))
    for method in ("dense", "filterpy"):
        rec = reconstruct(
            L, Y, noise_cov=R, theta0=P0, q=Q, transition=A, exponent=exponent,
            smoother="rts-smoothed-weights", path=method,
        )  # fmt: skip
        assert relative(rec.z.T, np.array(expected)) < BATCH_RTOL, method


def test_one_step_is_the_filter(method):
    # T = 1: Sigma_1 = P_{1|0} and P^s_1 = P_{1|1}, the filter's standardization
    L, Y = problem(5, T=1)
    for standardize, n_orient in (("column", None), ("position", 3)):
        common = dict(
            noise_std=0.7, theta0=0.8, q=0.1, exponent=1.25, standardize=standardize,
            n_orient=n_orient, path=method,
        )  # fmt: skip
        smoothed = reconstruct(L, Y, smoother="rts-smoothed-weights", **common)
        filtered = reconstruct(L, Y, **common)
        assert relative(smoothed.z, filtered.z) < 1e-13


def test_means_and_weights_are_those_of_the_state_smoother(method):
    # x is the textbook smoothed state (as "rts-state"); weights and z_filtered the filter's
    L, Y = problem(6)
    common = dict(noise_std=0.7, theta0=0.8, q=0.3, exponent=1.25, path=method)
    ours = reconstruct(L, Y, smoother="rts-smoothed-weights", **common)
    state = reconstruct(L, Y, smoother="rts-state", **common)
    for name in ("x", "x_filtered", "z_filtered", "weights"):
        assert relative(getattr(ours, name), getattr(state, name)) < 1e-13, name
    assert relative(ours.z, state.z) > 1e-3  # another standardization
    assert ours.smoother == "rts-smoothed-weights"


def test_position_blocks_are_the_blocks_of_the_estimates_covariance(method):
    # standardize="position", alpha = 1/2, A = I, isotropic priors: each position's three
    # components are whitened jointly by their own covariance, so sum_t-free:
    # ||z^s_t[c(i)]||^2 = x^s[c(i)]^T Cov(x^s)[c(i), c(i)]^-1 x^s[c(i)]
    rng = np.random.default_rng(7)
    m, n_positions, T = 12, 3, 4
    L = rng.standard_normal((m, 3 * n_positions))
    Y = rng.standard_normal((m, T))
    theta0, q = 0.8, 0.3
    rec = reconstruct(
        L, Y, noise_std=0.7, theta0=theta0, q=q, exponent=0.5,
        smoother="rts-smoothed-weights", standardize="position", n_orient=3, path=method,
    )  # fmt: skip
    n = 3 * n_positions
    x_s, covariance, _ = batch_smoother(
        L, Y, 0.49 * np.eye(m), np.eye(n), q * np.eye(n), theta0 * np.eye(n)
    )
    expected = np.empty((T, n_positions))
    for t in range(T):
        for i in range(n_positions):
            c = slice(3 * i, 3 * i + 3)
            expected[t, i] = np.sqrt(x_s[t, c] @ linalg.solve(covariance[t][c, c], x_s[t, c]))
    assert relative(rec.amplitude(3).T, expected) < BATCH_RTOL


def test_a_long_random_walk_judges_late_activity_against_a_wider_prior():
    # docs/model.md §3, "Long recordings": Sigma_t grows like t q while P^s_t stays
    # bounded, so a constant source scores lower as the recording goes on
    rng = np.random.default_rng(8)
    L = rng.standard_normal((8, 5))
    T = 400
    Y = np.outer(L[:, 2], np.ones(T)) + 0.05 * rng.standard_normal((8, T))
    rec = reconstruct(
        L, Y, noise_std=0.05, theta0=1.0, q=0.01, exponent=0.5,
        smoother="rts-smoothed-weights", path="spectral",
    )  # fmt: skip
    early, late = np.abs(rec.z[2, 50]), np.abs(rec.z[2, 350])
    sigma = 1.0 + 0.01 * np.array([51, 351])
    assert late < early
    assert late / early == pytest.approx(np.sqrt(sigma[0] / sigma[1]), rel=0.05)


def test_the_dense_smoother_needs_the_prior_for_the_smoothed_weights():
    rng = np.random.default_rng(41)
    L, Y = rng.standard_normal((4, 6)), rng.standard_normal((4, 3))
    eye = np.eye(6)
    f = dense.kalman_filter(L, Y, np.eye(4), eye, 0.1 * eye, eye, 0.5)
    x, _ = dense.smooth(f, "rts-state", eye, 0.5)  # the other smoothers need only A
    assert x.shape == (3, 6)
    with pytest.raises(ValueError, match=r"needs prior=\(Q, P0\)"):
        dense.smooth(f, "rts-smoothed-weights", eye, 0.5)


def test_the_dense_smoother_takes_a_filter_output_with_column_weights_only():
    # skf_ref.conformance builds mistaken filters' outputs with the weights w and no blocks
    rng = np.random.default_rng(43)
    L, Y = rng.standard_normal((4, 6)), rng.standard_normal((4, 3))
    eye = np.eye(6)
    f = dense.kalman_filter(L, Y, np.eye(4), eye, 0.1 * eye, eye, 1.25)
    _, z = dense.smooth(f, "rts-state", eye, 1.25)
    _, z_columns = dense.smooth({k: v for k, v in f.items() if k != "W"}, "rts-state", eye, 1.25)
    np.testing.assert_allclose(z_columns, z, rtol=1e-12)


@pytest.mark.parametrize("standardize", ["column", "position"])
def test_weights_held_inside_a_long_ar1_recording_equal_every_steps_own(standardize):
    # The AR(1) prior's smoothed weights settle between the filter's transient at the start
    # and the smoother's at the end: those steps are one product with held weights
    # (smoothed_weights.HeldInterior), equal to the dense path's and to every step's own.
    from skf_ref.method import StateSpaceModel
    from skf_ref.method._paths import smoothed_weights
    from skf_ref.method._paths.spectral import SpectralModel
    from tests.rounding import ROUTE_RTOL
    from tests.rounding import relative as route_relative

    rng = np.random.default_rng(5)
    L, T = rng.standard_normal((8, 12)), 400
    Y = rng.standard_normal((8, T))
    settings = dict(noise_std=1.0, theta0=1.0, q=0.19, transition=0.9)
    kwargs = dict(standardize=standardize, n_orient=3)
    dense_z = reconstruct(
        L, Y, **settings, exponent=0.5, smoother="rts-smoothed-weights", path="dense", **kwargs
    ).z
    model = SpectralModel(StateSpaceModel.create(L, **settings), T)
    held = model.apply(Y, 0.5, "rts-smoothed-weights", standardize=standardize, n_orient=3)
    weights = model.standardization(
        0.5, block=3 if standardize == "position" else 1, smoothed=True
    )
    assert isinstance(weights, smoothed_weights.HeldInterior)
    first, stop = weights.held_steps
    assert 0 < first and stop < T and stop - first >= smoothed_weights.MIN_HELD
    every = SpectralModel(StateSpaceModel.create(L, **settings), T)
    every.standardization = lambda *args, smoothed=False: type(weights.parts[0][1])(
        every.V, every._smoothed_weights(None)[0] if smoothed else every.recursions.omega,
        T if smoothed else every.steady, T, 0.5
    )  # fmt: skip
    own = every.apply(Y, 0.5, "rts-smoothed-weights", standardize=standardize, n_orient=3)
    assert route_relative(held.z, own.z) < ROUTE_RTOL
    assert route_relative(held.z, dense_z) < ROUTE_RTOL
    for _ in range(2):  # the second data set keeps the powers of the steps not held
        again = model.apply(Y, 0.5, "rts-smoothed-weights", standardize=standardize, n_orient=3)
        assert route_relative(again.z, held.z) < ROUTE_RTOL
