"""Properties of the SKF core: every reconstruct path against closed forms and invariants.

The class ``TestPaths`` runs over every computational path through the ``method`` fixture;
add a path to ``PATHS`` and every property below is proved for it too.
"""

import tracemalloc

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter
from scipy import linalg, stats

from skf_ref import Reconstruction, StandardizedKalmanFilter, priors_from_snr, reconstruct
from skf_ref._utils.memory import covariance_memory
from skf_ref.method._paths import dense

PATHS = ("filterpy", "dense", "spectral")
# Paths for general linear-Gaussian models (spectral needs A = a I, P_0 = theta0 I, Q = q I
# and raises otherwise), and the paths that store covariances (the memory guard's).
GENERAL_PATHS = ("filterpy", "dense")
COVARIANCE_PATHS = ("filterpy", "dense")
SMOOTHERS = ("rts-standardized", "rts-state")

# Closed forms (SVD, a solve with S) and the filter reach the same numbers through
# different, well-conditioned (cond(S) < 1e4) factorizations: they agree to rounding,
# a few 1e-14 relative; 1e-10 leaves a wide margin and still catches any formula error.
CLOSED_FORM_RTOL = 1e-10
# Rescaling L and Y is exact in exact arithmetic; the rescaled run rounds differently in
# every eigh and solve of the ~10 steps. Measured differences are ~1e-13.
INVARIANCE_RTOL = 1e-9
# A change of units with the "toolbox" convention moves the prior by tens of dB; the
# resulting z must differ by far more than rounding. 1e-2 is a floor well below the change.
TOOLBOX_MIN_CHANGE = 1e-2
# At t = T the smoothed z is the filtered z recomputed through the same standardization:
# equal up to a few roundings of one matrix-vector product.
LAST_STEP_RTOL = 1e-12
# The memory guard's estimate may miss working arrays of O(n^2) (a few percent at T = 12) but
# no stored O(n^2 T) term: each such term would add a third of the estimate or more.
MEMORY_ESTIMATE_SLACK = 1.25
# Two paths of the package on a well-conditioned problem: as in validation/crosscheck.py.
CROSS_PATH_RTOL = 1e-8
# The independent plain-loop filter in this file uses other factorizations than the package.
PLAIN_LOOP_RTOL = 1e-9


@pytest.fixture(params=PATHS)
def method(request):
    """Every computational path of ``reconstruct``."""
    return request.param


def assert_relative(actual, desired, rtol, err_msg=""):
    """``max|actual - desired| <= rtol * max|desired|``: the scale-aware comparison."""
    actual, desired = np.asarray(actual), np.asarray(desired)
    assert actual.shape == desired.shape, err_msg
    difference = np.max(np.abs(actual - desired))
    assert difference <= rtol * np.max(np.abs(desired)), (err_msg, difference)


def relative_change(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def lead_field(rng, n_channels, n_sources, reference="none", scale=1e2):
    L = scale * rng.standard_normal((n_channels, n_sources))
    if reference == "average":
        L -= L.mean(axis=0)
    return L


def random_spd(rng, n, scale):
    B = rng.standard_normal((n, n))
    return scale * (B @ B.T / n + 0.5 * np.eye(n))


def simulate(rng, L, n_times, noise_std, source_std):
    """Random-walk sources and white noise: data of a realistic scale for the priors."""
    X = np.cumsum(source_std * rng.standard_normal((L.shape[1], n_times)), axis=1)
    return L @ X + noise_std * rng.standard_normal((L.shape[0], n_times))


def sqrtm_spd(P):
    eigenvalues, eigenvectors = linalg.eigh(P)
    return (eigenvectors * np.sqrt(eigenvalues)) @ eigenvectors.T


def plain_skf(L, Y, R, A, Q, P0, exponent):
    """A textbook Kalman filter loop and the SKF standardization, written independently.

    Uses the identity of docs/model.md §2, ``w_t = diag(B^T S_t^{-1} B)`` with
    ``B = L P_{t|t-1}^{1/2}``, and solves instead of the package's inverse square root.
    """
    n, T = L.shape[1], Y.shape[1]
    x, P = np.zeros(n), P0
    out = {k: [] for k in ("x_filt", "x_pred", "P_filt", "P_pred", "z", "log_pdf", "sqrt")}
    for t in range(T):
        x_pred, P_pred = A @ x, A @ P @ A.T + Q
        S = L @ P_pred @ L.T + R
        e = Y[:, t] - L @ x_pred
        K = linalg.solve(S, L @ P_pred, assume_a="pos").T
        x, P = x_pred + K @ e, P_pred - K @ S @ K.T
        P_sqrt = sqrtm_spd(P_pred)
        B = L @ P_sqrt
        w = np.sum(B * linalg.solve(S, B, assume_a="pos"), axis=0)
        z = w ** (-exponent) * linalg.solve(P_sqrt, x, assume_a="pos")
        out["log_pdf"].append(stats.multivariate_normal.logpdf(e, mean=np.zeros(len(e)), cov=S))
        for key, value in zip(out, (x, x_pred, P, P_pred, z), strict=False):
            out[key].append(value)
        out["sqrt"].append(P_sqrt)
    return {k: np.array(v) for k, v in out.items()}


class TestPaths:
    """Every property here must hold for every path."""

    # --- docs/model.md §2: the sLORETA identity and the exponent -----------------------

    @staticmethod
    def sloreta(L, y, p, sigma=None, R=None):
        """sLORETA of Pascual-Marqui (2002) in closed form: ``x`` and ``diag(P L^T S^-1 L P)``.

        With ``R = sigma**2 I`` through the SVD ``L = U s V^T`` (the null space of ``L^T`` does
        not enter ``L^T S^-1``); with a full ``R`` by a solve with ``S = p L L^T + R``.
        """
        if R is None:
            U, s, Vt = linalg.svd(L, full_matrices=False)
            d = p * s**2 + sigma**2
            x = p * Vt.T @ ((s / d) * (U.T @ y))
            resolution = p**2 * (Vt.T**2 @ (s**2 / d))
        else:
            S = p * L @ L.T + R
            x = p * L.T @ linalg.solve(S, y, assume_a="pos")
            resolution = p**2 * np.sum(L * linalg.solve(S, L, assume_a="pos"), axis=0)
        return x, resolution

    @pytest.mark.parametrize("reference", ["none", "average"])
    @pytest.mark.parametrize("noise", ["noise_std", "noise_cov"])
    @pytest.mark.parametrize("split", [0.0, 0.25], ids=["q=0", "q=p/4"])
    def test_sloreta_identity(self, method, reference, noise, split):
        rng = np.random.default_rng(1)
        L = lead_field(rng, 16, 40, reference)
        sigma, p = 1e-6, 2e-16
        y = simulate(rng, L, 1, sigma, np.sqrt(p))[:, 0]
        if noise == "noise_std":
            R, noise_kwargs = None, {"noise_std": sigma}
        else:
            R = random_spd(rng, 16, sigma**2)
            noise_kwargs = {"noise_cov": R}
        # P_{1|0} = theta0 + q = p
        theta0, q = (1 - split) * p, split * p
        rec = reconstruct(
            L, y[:, None], **noise_kwargs, theta0=theta0, q=q, exponent=0.5, path=method
        )
        x, resolution = self.sloreta(L, y, p, sigma=sigma, R=R)
        assert_relative(rec.x_filtered[:, 0], x, CLOSED_FORM_RTOL)
        assert_relative(rec.z[:, 0], x / np.sqrt(resolution), CLOSED_FORM_RTOL)

    @pytest.mark.parametrize("exponent", [0.0, 1.0, 1.25, 1.5])
    def test_exponent_in_closed_form(self, method, exponent):
        # T = 1, P_{1|0} = p I: w = diag(P^-1/2 K S K^T P^-1/2) = resolution / p, so
        # z = (resolution / p)**(-exponent) * x / sqrt(p)      (6)-(7)
        rng = np.random.default_rng(2)
        L = lead_field(rng, 12, 30, "average")
        sigma, p = 1e-6, 5e-16
        y = simulate(rng, L, 1, sigma, np.sqrt(p))[:, 0]
        rec = reconstruct(
            L, y[:, None], noise_std=sigma, theta0=p, q=0.0, exponent=exponent, path=method
        )
        x, resolution = self.sloreta(L, y, p, sigma=sigma)
        weights = (resolution / p) ** (-exponent)
        assert_relative(rec.weights[:, 0], weights, CLOSED_FORM_RTOL)
        assert_relative(rec.z[:, 0], weights * x / np.sqrt(p), CLOSED_FORM_RTOL)
        assert rec.exponent == exponent

    @pytest.mark.parametrize("reference", ["none", "average"])
    def test_single_source_is_localized_exactly(self, method, reference):
        # sLORETA's property: for noise-free data from column j, argmax_i |z_i| = j, since
        # |z_i| = |Res_ij| / sqrt(Res_ii) <= sqrt(Res_jj) (Cauchy-Schwarz on the PSD Res).
        rng = np.random.default_rng(3)
        L = lead_field(rng, 16, 40, reference)
        theta0, _ = priors_from_snr(L, 1e-6, 10.0, 0.0, 1)
        for j in range(L.shape[1]):
            rec = reconstruct(L, L[:, [j]], noise_std=1e-6, theta0=theta0, q=0.0, path=method)
            assert np.argmax(np.abs(rec.z[:, 0])) == j

    # --- invariance under a change of units --------------------------------------------------

    @staticmethod
    def scaled_run(L, Y, sigma, method, smoother, c, b, convention="gain"):
        theta0, q = priors_from_snr(c * L, b * sigma, 0.0, 20.0, Y.shape[1], convention)
        return reconstruct(
            c * L,
            b * Y,
            noise_std=b * sigma,
            theta0=theta0,
            q=q,
            exponent=1.25,
            smoother=smoother,
            path=method,
        )

    @pytest.mark.parametrize("smoother", SMOOTHERS)
    @pytest.mark.parametrize("c, b", [(1e-3, 1e4), (1e6, 1e-6)])
    def test_gain_convention_is_unit_free(self, method, smoother, c, b):
        rng = np.random.default_rng(4)
        L = lead_field(rng, 12, 30, "average")
        sigma = 1e-6
        Y = simulate(rng, L, 10, sigma, 1e-8)
        base = self.scaled_run(L, Y, sigma, method, smoother, 1.0, 1.0)
        scaled = self.scaled_run(L, Y, sigma, method, smoother, c, b)
        assert_relative(scaled.z, base.z, INVARIANCE_RTOL, "smoothed z")
        assert_relative(scaled.z_filtered, base.z_filtered, INVARIANCE_RTOL, "filtered z")
        # the state itself is in source units: it scales by b / c
        assert_relative(scaled.x_filtered, base.x_filtered * b / c, INVARIANCE_RTOL, "x")

    @pytest.mark.parametrize("c", [1e-3, 1e6])
    def test_toolbox_convention_depends_on_units(self, method, c):
        rng = np.random.default_rng(4)
        L = lead_field(rng, 12, 30, "average")
        Y = simulate(rng, L, 10, 1e-6, 1e-8)
        sigma = 1e-6 / np.max(np.abs(Y))  # the toolbox works on Y / max|Y|
        Y = Y / np.max(np.abs(Y))
        base = self.scaled_run(L, Y, sigma, method, None, 1.0, 1.0, "toolbox")
        scaled = self.scaled_run(L, Y, sigma, method, None, c, 1.0, "toolbox")
        assert relative_change(scaled.z, base.z) > TOOLBOX_MIN_CHANGE

    # --- smoothers ---------------------------------------------------------------------------

    @pytest.fixture
    def problem(self):
        rng = np.random.default_rng(5)
        L = lead_field(rng, 12, 30, "average")
        Y = simulate(rng, L, 8, 1e-6, 1e-8)
        theta0, q = priors_from_snr(L, 1e-6, 0.0, 20.0, 8)
        return {"L": L, "Y": Y, "noise_std": 1e-6, "theta0": theta0, "q": q}

    @pytest.mark.parametrize("smoother", SMOOTHERS)
    def test_smoothed_equals_filtered_at_last_step(self, method, problem, smoother):
        rec = reconstruct(**problem, exponent=1.25, smoother=smoother, path=method)
        assert_relative(rec.z[:, -1], rec.z_filtered[:, -1], LAST_STEP_RTOL)
        # ... and smoothing did change the earlier steps
        assert relative_change(rec.z[:, :-1], rec.z_filtered[:, :-1]) > 1e-3
        if smoother == "rts-state":
            np.testing.assert_array_equal(rec.x[:, -1], rec.x_filtered[:, -1])
            assert relative_change(rec.x[:, :-1], rec.x_filtered[:, :-1]) > 1e-3
        else:
            np.testing.assert_array_equal(rec.x, rec.x_filtered)

    def test_the_filter_is_causal(self, method, problem):
        # z_{t|t} uses y_1..y_t only: the first steps of a longer run equal a shorter run
        full = reconstruct(**problem, exponent=1.25, path=method)
        short = reconstruct(**problem | {"Y": problem["Y"][:, :4]}, exponent=1.25, path=method)
        assert_relative(full.z_filtered[:, :4], short.z_filtered, LAST_STEP_RTOL)
        assert_relative(full.weights[:, :4], short.weights, LAST_STEP_RTOL)
        # ... and no smoother means the filter's own sequence
        assert full.smoother is None
        np.testing.assert_array_equal(full.z, full.z_filtered)

    @pytest.mark.parametrize("smoother", [None, *SMOOTHERS])
    def test_raw_weights_lie_in_zero_one(self, method, problem, smoother):
        # w_t = diag(P^-1/2 K S K^T P^-1/2) with K S K^T = P_{t|t-1} - P_{t|t} <= P_{t|t-1}:
        # every raw weight is in (0, 1], so W = w^-alpha >= 1. Weights from P_{t|t} instead of
        # P_{t|t-1} (a known slip) exceed 1.
        rec = reconstruct(**problem, exponent=1.25, smoother=smoother, path=method)
        raw = rec.weights ** (-1 / 1.25)
        assert raw.min() > 0 and raw.max() <= 1 + 1e-12

    # --- against an independent plain loop ---------------------------------------------------

    @pytest.fixture
    def general(self, method):
        """A tiny general linear-Gaussian model: full R, P_0, Q and a non-identity A."""
        rng = np.random.default_rng(6)
        m, n, T = 4, 6, 5
        L = rng.standard_normal((m, n))
        G = rng.standard_normal((n, n))
        return {
            "L": L,
            "Y": rng.standard_normal((m, T)),
            "noise_cov": random_spd(rng, m, 0.5),
            "theta0": random_spd(rng, n, 2.0),
            "q": random_spd(rng, n, 0.3),
            "transition": 0.7 * np.eye(n) + 0.2 * G / np.linalg.norm(G, 2),
        }

    def plain(self, general, exponent):
        g = general
        return plain_skf(
            g["L"], g["Y"], g["noise_cov"], g["transition"], g["q"], g["theta0"], exponent
        )

    @pytest.mark.parametrize("method", GENERAL_PATHS)
    def test_log_likelihood(self, method, general):
        rec = reconstruct(**general, path=method)
        expected = np.sum(self.plain(general, 0.5)["log_pdf"])
        assert rec.log_likelihood == pytest.approx(expected, rel=PLAIN_LOOP_RTOL)

    @pytest.mark.parametrize("method", GENERAL_PATHS)
    @pytest.mark.parametrize("exponent", [0.5, 1.25])
    def test_filter_matches_plain_loop(self, method, general, exponent):
        rec = reconstruct(**general, exponent=exponent, path=method)
        f = self.plain(general, exponent)
        assert_relative(rec.x_filtered, f["x_filt"].T, PLAIN_LOOP_RTOL)
        assert_relative(rec.z_filtered, f["z"].T, PLAIN_LOOP_RTOL)

    @pytest.mark.parametrize("method", GENERAL_PATHS)
    def test_rts_state_matches_textbook(self, method, general):
        rec = reconstruct(**general, exponent=1.25, smoother="rts-state", path=method)
        f = self.plain(general, 1.25)
        A, xs = general["transition"], f["x_filt"].copy()
        for t in range(len(xs) - 2, -1, -1):
            G = f["P_filt"][t] @ A.T @ np.linalg.inv(f["P_pred"][t + 1])
            xs[t] = f["x_filt"][t] + G @ (xs[t + 1] - f["x_pred"][t + 1])
        assert_relative(rec.x, xs.T, PLAIN_LOOP_RTOL)
        # z^s_t = W_t P_{t|t-1}^{-1/2} x^s_t with the filter's weights
        whitened = np.array([linalg.solve(s, x) for s, x in zip(f["sqrt"], xs, strict=True)])
        assert_relative(rec.z, rec.weights * whitened.T, PLAIN_LOOP_RTOL)

    @pytest.mark.parametrize("method", GENERAL_PATHS)
    def test_rts_standardized_matches_recursion(self, method, general):
        rec = reconstruct(**general, exponent=1.25, smoother="rts-standardized", path=method)
        f = self.plain(general, 1.25)
        A, z = general["transition"], f["z"]
        s = z.copy()
        for t in range(len(s) - 2, -1, -1):
            G = f["P_filt"][t] @ A.T @ np.linalg.inv(f["P_pred"][t + 1])
            # s_t = z_{t|t} + G_t (s_{t+1} - A z_{t|t})
            s[t] = z[t] + G @ (s[t + 1] - A @ z[t])
        assert_relative(rec.z, s.T, PLAIN_LOOP_RTOL)

    # --- the result object, inputs, memory ---------------------------------------------------

    @pytest.mark.parametrize("smoother", [None, *SMOOTHERS])
    def test_result_records_what_produced_it(self, method, smoother):
        rng = np.random.default_rng(7)
        L = lead_field(rng, 8, 15)  # 5 free-orientation positions
        Y = simulate(rng, L, 6, 1e-6, 1e-8)
        rec = reconstruct(
            L, Y, noise_std=1e-6, theta0=1e-16, q=1e-17, smoother=smoother, path=method
        )
        assert isinstance(rec, Reconstruction)
        assert repr(rec).startswith("<Reconstruction | 15 sources x 6 steps")
        assert rec.settings == {
            "path": method,
            "exponent": 0.5,
            "smoother": smoother,
            "standardize": "column",
            "n_orient": None,
            "theta0": 1e-16,
            "q": 1e-17,
            "transition": 1.0,
        }
        assert isinstance(rec.log_likelihood, float)
        for name in ("z", "x", "z_filtered", "x_filtered", "weights"):
            array = getattr(rec, name)
            assert array.shape == (15, 6), name
            with pytest.raises(ValueError, match="read-only"):
                array[0, 0] = 0.0
        # MNE's free-orientation order: position p holds columns 3p, 3p+1, 3p+2
        for p in range(5):
            np.testing.assert_allclose(
                rec.amplitude(3)[p], np.linalg.norm(rec.z[3 * p : 3 * p + 3], axis=0), rtol=1e-15
            )
        with pytest.raises(ValueError, match="components must divide n_sources=15, got 2"):
            rec.amplitude(2)

    @pytest.mark.parametrize("smoother", [None, *SMOOTHERS])
    def test_inputs_not_mutated(self, method, problem, smoother):
        copies = {k: np.copy(v) for k, v in problem.items()}
        reconstruct(**problem, smoother=smoother, path=method)
        for name, value in problem.items():
            np.testing.assert_array_equal(value, copies[name], err_msg=name)

    @pytest.mark.parametrize("method", GENERAL_PATHS)
    @pytest.mark.parametrize("smoother", [None, *SMOOTHERS])
    def test_matrix_inputs_not_mutated(self, method, general, smoother):
        copies = {k: v.copy() for k, v in general.items()}
        reconstruct(**general, smoother=smoother, path=method)
        for name, value in general.items():
            np.testing.assert_array_equal(value, copies[name], err_msg=name)

    @pytest.mark.parametrize("method", COVARIANCE_PATHS)
    def test_memory_guard(self, method, problem):
        with pytest.raises(MemoryError, match=r"about [0-9.e+-]+ GiB.*path='spectral'"):
            reconstruct(**problem, path=method, memory_limit=1000)
        # enough memory: no error
        reconstruct(**problem, path=method, memory_limit=2**30)

    @pytest.mark.parametrize("method", COVARIANCE_PATHS)
    @pytest.mark.parametrize(
        "smoother", [None, *(pytest.param(s, marks=pytest.mark.slow) for s in SMOOTHERS)]
    )
    def test_memory_guard_estimate_covers_the_run(self, method, smoother):
        # A run just inside memory_limit must not use much more than memory_limit.
        rng = np.random.default_rng(12)
        L = lead_field(rng, 12, 100)
        Y = simulate(rng, L, 12, 1e-6, 1e-8)
        limit = covariance_memory(100, 12, method, smoother)
        tracemalloc.start()
        try:
            reconstruct(
                L,
                Y,
                noise_std=1e-6,
                theta0=1e-16,
                q=1e-17,
                smoother=smoother,
                path=method,
                memory_limit=limit,
            )
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak <= MEMORY_ESTIMATE_SLACK * limit, peak / limit


@pytest.mark.parametrize(
    "change, expected",
    [({}, "spectral"), ({"q": 1e-17 * np.diag(np.arange(1.0, 10))}, "dense")],
    ids=["isotropic", "general"],
)
def test_auto_takes_spectral_exactly_when_the_model_qualifies(change, expected):
    rng = np.random.default_rng(8)
    L = lead_field(rng, 6, 9)
    kwargs = {"noise_std": 1e-6, "theta0": 1e-16, "q": 1e-17, "smoother": "rts-state"} | change
    Y = simulate(rng, L, 3, 1e-6, 1e-8)
    auto, reference = reconstruct(L, Y, **kwargs), reconstruct(L, Y, **kwargs, path="dense")
    assert auto.path == expected
    for name in ("z", "x", "z_filtered", "x_filtered", "weights"):
        assert_relative(getattr(auto, name), getattr(reference, name), CROSS_PATH_RTOL, name)


# --- the dense oracle's covariances ---------------------------------------------------------


def covariance_problem():
    rng = np.random.default_rng(9)
    L = lead_field(rng, 12, 30, "average")
    Y = simulate(rng, L, 20, 1e-6, 1e-8)
    theta0, q = priors_from_snr(L, 1e-6, 20.0, 0.0, 20)
    n = L.shape[1]
    return L, Y, 1e-12 * np.eye(12), np.eye(n), q * np.eye(n), theta0 * np.eye(n)


def test_dense_covariances_are_spd():
    f = dense.kalman_filter(*covariance_problem(), exponent=1.25)
    for t in range(f["P_filt"].shape[0]):
        for name in ("P_filt", "P_pred"):
            P = f[name][t]
            np.testing.assert_array_equal(P, P.T, err_msg=f"{name}[{t}]")
            assert np.min(linalg.eigvalsh(P)) > 0, f"{name}[{t}]"
        # P_{t|t-1}^{-1/2} P_{t|t-1} P_{t|t-1}^{-1/2} = I
        M = f["P_pred_inv_sqrt"][t]
        np.testing.assert_allclose(M @ f["P_pred"][t] @ M, np.eye(30), atol=1e-9)


# --- the filterpy subclass --------------------------------------------------------------------


class TestStandardizedKalmanFilter:
    def test_is_a_filterpy_kalman_filter(self):
        assert issubclass(StandardizedKalmanFilter, KalmanFilter)
        assert StandardizedKalmanFilter.predict is KalmanFilter.predict
        assert StandardizedKalmanFilter.rts_smoother is KalmanFilter.rts_smoother
        assert StandardizedKalmanFilter.update is not KalmanFilter.update

    @staticmethod
    def make(exponent=0.5, dim_x=4, dim_z=3):
        rng = np.random.default_rng(10)
        kf = StandardizedKalmanFilter(dim_x=dim_x, dim_z=dim_z, exponent=exponent)
        kf.H = rng.standard_normal((dim_z, dim_x))
        kf.P = random_spd(rng, dim_x, 1.0)
        kf.Q = 0.1 * np.eye(dim_x)
        kf.R = 0.2 * np.eye(dim_z)
        return kf

    def test_alpha_keeps_its_fading_memory_meaning(self):
        kf = self.make(exponent=1.25)
        assert kf.alpha == 1.0 and kf.exponent == 1.25
        P0 = kf.P.copy()
        kf.alpha = 1.02
        assert kf.exponent == 1.25
        kf.predict()
        # filterpy: P = alpha**2 F P F^T + Q
        np.testing.assert_allclose(kf.P, 1.02**2 * P0 + kf.Q, rtol=1e-14)
        plain = self.make(exponent=1.25)
        plain.predict()
        np.testing.assert_allclose(plain.P, P0 + plain.Q, rtol=1e-14)
        # the exponent does not touch the fading memory
        assert self.make(exponent=1.5).alpha == 1.0

    def test_update_sets_weights_and_standardized_state(self):
        kf = self.make(exponent=1.25)
        kf.predict()
        P_prior = kf.P.copy()
        kf.update(np.array([0.3, -1.0, 0.5]))
        for name in ("weights", "x_standardized", "raw_weights"):
            value = getattr(kf, name)
            assert value.shape == (4,), name
            assert np.all(np.isfinite(value)), name
        # docs/model.md §2 identity: w = diag(B^T S^-1 B), B = H P_{t|t-1}^{1/2}
        B = kf.H @ sqrtm_spd(P_prior)
        w = np.sum(B * linalg.solve(kf.S, B), axis=0)
        np.testing.assert_allclose(kf.raw_weights, w, rtol=1e-12)
        np.testing.assert_allclose(kf.weights, w**-1.25, rtol=1e-12)
        z = w**-1.25 * linalg.solve(sqrtm_spd(P_prior), kf.x.ravel())
        np.testing.assert_allclose(kf.x_standardized, z, rtol=1e-12)

    def test_missing_measurement_gives_nan(self):
        kf = self.make()
        kf.predict()
        kf.update(np.array([0.3, -1.0, 0.5]))
        kf.predict()
        kf.update(None)  # nothing of the previous step may look like this step's
        for name in ("weights", "x_standardized", "raw_weights", "P_prior_inv_sqrt"):
            assert np.all(np.isnan(getattr(kf, name))), name
