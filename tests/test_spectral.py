"""The spectral path equals the dense reference on random small models (hypothesis).

The default run draws the same 150 models every time (tests/conftest.py); run
``python -m pytest tests/test_spectral.py --hypothesis-profile=explore`` to draw thousands
of new ones.
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from rounding import assert_same_to_rounding

from skf_ref import priors_from_snr, reconstruct
from skf_ref.method import SpectralModel, StateSpaceModel
from skf_ref.method._paths import dense

# Both paths are exact algebra, so they differ by rounding only, and rounding grows with the
# condition numbers kappa of S_t and P_{t|t-1}: the dense path solves with S and takes eigh
# of P. On models with kappa <= 1e4 the worst difference found in 20 000 drawn models was
# 2.4e-10, under EQUALITY_RTOL. Past that (PM-SNR high and EP-SNR low, so q >> theta0, or
# 1e-6 V noise on a 1e-3 V/(A m) lead field) the dense path keeps about log10(eps kappa)
# fewer digits: on 30 models with kappa > 1e7 a 40-digit mpmath run of the same equations
# put the dense path 2e-11 to 1.2e-8 off and the spectral path at most 8e-11 off. A
# hypothesis search steered toward large differences (30 000 models) reached 0.22 of this
# bound: the larger of EQUALITY_RTOL and CONDITION_FACTOR eps kappa.
EQUALITY_RTOL = 1e-8
CONDITION_FACTOR = 1e3
QUANTITIES = ("z", "x", "z_filtered", "x_filtered", "weights")
SMOOTHERS = (None, "rts-standardized", "rts-state", "rts-smoothed-weights")


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def noise_covariance(model):
    m = model["L"].shape[0]
    return model["noise_cov"] if "noise_cov" in model else model["noise_std"] ** 2 * np.eye(m)


def condition_number(model):
    """max over t of cond(S_t) and cond(P_{t|t-1}), from the dense path's covariances."""
    L, R, eye = model["L"], noise_covariance(model), np.eye(model["L"].shape[1])
    covariances = dense.kalman_filter(
        L,
        model["Y"],
        R,
        model["transition"] * eye,
        model["q"] * eye,
        model["theta0"] * eye,
        model["exponent"],
    )["P_pred"]
    return max(max(np.linalg.cond(L @ P @ L.T + R), np.linalg.cond(P)) for P in covariances)


def tolerance(model):
    return max(EQUALITY_RTOL, CONDITION_FACTOR * np.finfo(float).eps * condition_number(model))


@st.composite
def models(draw):
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    m = draw(st.integers(2, 9))
    n = draw(st.integers(1, 14))
    T = draw(st.integers(1, 7))
    L = draw(st.sampled_from([1e-3, 1.0, 1e3])) * rng.standard_normal((m, n))
    if draw(st.booleans()) and m > 2:
        L -= L.mean(axis=0)  # average reference: rank m - 1
    if draw(st.booleans()) and n > 2:
        L[:, -1] = L[:, 0] + L[:, 1]  # a dependent column
    sigma = draw(st.sampled_from([1e-6, 1.0]))
    Y = sigma * 3 * rng.standard_normal((m, T))
    if draw(st.booleans()):
        noise = dict(noise_std=sigma)
    else:
        B = rng.standard_normal((m, m))
        noise = dict(noise_cov=sigma**2 * (B @ B.T / m + 0.3 * np.eye(m)))
    theta0, q = priors_from_snr(
        L,
        sigma,
        pm_snr_db=draw(st.sampled_from([-20.0, 0.0, 20.0])),
        ep_snr_db=draw(st.sampled_from([-20.0, 0.0, 20.0, 40.0])),
        n_steps=T,
    )
    q, transition = draw(st.sampled_from([0.0, q])), draw(st.sampled_from([1.0, 0.8, -0.5]))
    if draw(st.booleans()):  # the stationary AR(1) prior (ar1_priors): rho in (0, 1]
        transition = draw(st.one_of(st.just(1.0), st.floats(1e-3, 1.0, exclude_max=True)))
        q = -np.expm1(2 * np.log(transition)) * theta0  # (1 - rho^2) theta0
    return dict(
        L=L,
        Y=Y,
        theta0=theta0,
        q=q,
        transition=transition,
        exponent=draw(st.sampled_from([0.0, 0.5, 1.0, 1.25, 1.5, 2.0])),
        smoother=draw(st.sampled_from(SMOOTHERS)),
        **noise,
    )


@given(models())
def test_spectral_equals_dense(model):
    reference = reconstruct(**model, path="dense")
    spectral = reconstruct(**model, path="spectral")
    rtol = tolerance(model)
    for name in QUANTITIES:
        assert relative(getattr(spectral, name), getattr(reference, name)) <= rtol, name
    assert np.isclose(spectral.log_likelihood, reference.log_likelihood, rtol=rtol)


def test_ill_conditioned_single_source_against_its_closed_form():
    # The model a random CI run drew (data rounded to 8 digits): one source, 1e-6 V noise on
    # a 1e-3 V/(A m) lead field and q = 1e4 theta0, so cond(S) ~ 6e6. With one source and one
    # step, x = p l^T y / (p |l|^2 + sigma^2) and z = x / sqrt(p) (exponent 0), evaluated
    # here without an ill-conditioned solve.
    L = np.array([[-1.4813e-4], [-4.9891e-4], [8.2745e-4], [-4.5936e-4], [2.7896e-4]])
    Y = np.array(
        [[-2.76916428e-8], [2.63735233e-6], [1.22845738e-6], [1.60781447e-6], [4.10559135e-6]]
    )
    theta0, q, sigma = 4.0180994562020577e-4, 4.018099456202058, 1e-6
    model = dict(L=L, Y=Y, noise_std=sigma, theta0=theta0, q=q, transition=1.0, exponent=0.0)
    p = theta0 + q
    x = p * (L[:, 0] @ Y[:, 0]) / (p * (L[:, 0] @ L[:, 0]) + sigma**2)
    assert condition_number(model) > 1e6
    spectral = reconstruct(**model, path="spectral")
    assert relative(spectral.x, x) < 1e-14
    assert relative(spectral.z, x / np.sqrt(p)) < 1e-14
    for method in ("dense", "filterpy"):  # both solve with S: accurate to ~eps cond(S) only
        assert relative(reconstruct(**model, path=method).x, x) <= tolerance(model), method


def test_auto_takes_spectral_when_the_model_qualifies():
    rng = np.random.default_rng(0)
    L, Y = rng.standard_normal((5, 8)), rng.standard_normal((5, 4))
    kwargs = dict(noise_std=1.0, theta0=1.0, q=0.1)
    assert reconstruct(L, Y, **kwargs).path == "spectral"
    assert reconstruct(L, Y, **kwargs, transition=0.5 * np.eye(8)).path == "spectral"
    assert reconstruct(L, Y, **kwargs, transition=np.diag(np.arange(1.0, 9))).path == "dense"


@pytest.mark.parametrize(
    "name, value",
    [
        ("transition", np.diag(np.arange(1.0, 9))),
        ("q", np.diag(np.arange(1.0, 9))),
        ("theta0", np.diag(np.arange(1.0, 9))),
    ],
)
def test_forcing_spectral_on_a_model_that_does_not_qualify(name, value):
    rng = np.random.default_rng(1)
    L, Y = rng.standard_normal((5, 8)), rng.standard_normal((5, 4))
    kwargs = dict(noise_std=1.0, theta0=1.0, q=0.1) | {name: value}
    with pytest.raises(ValueError, match=f"path='spectral'.*{name} is not a scalar multiple"):
        reconstruct(L, Y, **kwargs, path="spectral")


def test_prepared_model_applied_many_times_equals_fresh_runs():
    rng = np.random.default_rng(2)
    L = rng.standard_normal((6, 12))
    L -= L.mean(axis=0)
    model = SpectralModel(StateSpaceModel.create(L, noise_std=1.0, theta0=1.0, q=0.05), n_times=5)
    for exponent, smoother in [(0.5, None), (1.25, "rts-standardized"), (1.5, "rts-state")]:
        Y = rng.standard_normal((6, 5))
        prepared = model.apply(Y, exponent, smoother)
        fresh = reconstruct(
            L, Y, noise_std=1.0, theta0=1.0, q=0.05, exponent=exponent, smoother=smoother
        )
        for name in QUANTITIES:
            assert_same_to_rounding(getattr(prepared, name), getattr(fresh, name), what=name)
    assert model.rank == 5
    with pytest.raises(ValueError, match=r"Y must have shape \(6, 5\)"):
        model.apply(rng.standard_normal((6, 4)), 0.5, None)


def test_outputs_are_computed_on_access_only():
    rng = np.random.default_rng(3)
    rec = reconstruct(
        rng.standard_normal((4, 30)), rng.standard_normal((4, 3)), noise_std=1.0, theta0=1.0, q=1.0
    )
    assert not any(rec.computed(name) for name in ("z", "x", "weights"))
    assert rec.z.shape == (30, 3)
    assert rec.computed("z") and not rec.computed("weights")
    assert rec.z is rec.z  # computed once, then kept


@pytest.mark.parametrize("n_times", [2, 31, 32, 33, 97, 1000])
@pytest.mark.parametrize("transition", [0.7, 1.0, 2.0])
def test_backward_in_chunks_equals_the_step_by_step_recursion(n_times, transition):
    # narrow arrays take CHUNK_STEPS steps per matrix product: the same linear map, each
    # number a combination of at most CHUNK_STEPS + 1 terms with coefficients <= 1 / a
    # (gains below 1 / a, as the filter's are), so rounding stays at a few eps
    from skf_ref.method._paths.recursions import CHUNK_COLUMNS, backward

    rng = np.random.default_rng(n_times)
    gain = rng.uniform(0.05, 0.99, n_times - 1) / transition
    for width in (1, 64, CHUNK_COLUMNS):  # the last one step at a time
        z = rng.standard_normal((n_times, width))
        s = z.copy()
        for t in range(n_times - 2, -1, -1):
            s[t] = z[t] + gain[t] * (s[t + 1] - transition * z[t])
        got = backward(z, gain, transition)
        np.testing.assert_allclose(got, s, rtol=0, atol=1e-14 * np.abs(s).max())
        np.testing.assert_array_equal(got[-1], z[-1])


@pytest.mark.parametrize(
    "n_channels, n_sources, block_rows",
    [(6, 3, 64), (8, 40, 64), (8, 1000, 64), (8, 1000, 100), (16, 16, 64), (32, 5000, 4096)],
)
def test_thin_svd_in_blocks_against_numpy(monkeypatch, n_channels, n_sources, block_rows):
    # the first stage's blocks: one, many, a last one narrower than n_channels, wide ones
    from skf_ref.method._paths import singular_basis as singular

    monkeypatch.setattr(singular, "_SVD_BLOCK_BYTES", 8 * n_channels * block_rows)
    rng = np.random.default_rng(n_sources)
    L = rng.standard_normal((n_channels, n_sources))
    weak = n_sources >= 4 * n_channels  # else the weak columns make the small singular values
    if weak:
        L[:, :3] *= [1e-6, 1e-9, 1e-12]  # their rows of V come from L~^T U / s
    if n_channels > 3:
        L -= L.mean(axis=0)  # average reference: rank n_channels - 1
    given = L.copy()
    U, s, V = singular.thin_svd(L)
    np.testing.assert_array_equal(L, given)  # the blocks' QR works on copies
    expected = np.linalg.svd(L, compute_uv=False)
    rank = min(n_channels - (n_channels > 3), n_sources)
    assert s.shape == (rank,) and U.shape == (n_channels, rank) and V.shape == (n_sources, rank)
    assert V.flags.c_contiguous
    np.testing.assert_allclose(s, expected[:rank], rtol=0, atol=1e-14 * expected[0])
    np.testing.assert_allclose((U * s) @ V.T, L, rtol=0, atol=1e-14 * np.abs(L).max())
    np.testing.assert_allclose(V.T @ V, np.eye(rank), rtol=0, atol=1e-14)
    np.testing.assert_allclose(U.T @ U, np.eye(rank), rtol=0, atol=1e-14)
    if weak:  # a weak column's row is accurate relative to its own size, not only to eps
        np.testing.assert_allclose(V[2], (L[:, 2] @ U) / s, rtol=1e-12)
    # whitening block by block (no whitened copy of L) gives the SVD of the whitened L
    C = np.linalg.cholesky(np.eye(n_channels) + 0.1)
    whiten, _ = singular.whitener(C @ C.T)
    Uw, sw, Vw = singular.thin_svd(L, whiten)
    np.testing.assert_array_equal(L, given)
    np.testing.assert_allclose((Uw * sw) @ Vw.T, whiten(L), rtol=0, atol=1e-13 * sw[0])


@pytest.mark.parametrize("exponent", [0.0, 0.5, 0.75, 1.0, 1.25, 2.0, 0.3, 4.5])
def test_standardized_means_equal_the_z_of_standardize(exponent):
    from skf_ref.method._standardization import standardize, standardized_means

    rng = np.random.default_rng(3)
    w, whitened = rng.uniform(1e-3, 10.0, (5, 40)), rng.standard_normal((5, 40))
    weights, z = standardize(w, whitened, exponent)
    # two loops over the same powers (numpy dispatches them by layout and instruction set)
    assert_same_to_rounding(standardized_means(w, whitened, exponent), z, rtol=1e-14)
    np.testing.assert_allclose(weights, w**-exponent, rtol=4e-16 * (1 + 4 * exponent))
    np.testing.assert_allclose(z, whitened * w**-exponent, rtol=4e-16 * (2 + 4 * exponent))


def test_time_major_tiles_cover_every_entry_once_in_wide_runs():
    from skf_ref.method._paths.tiles import TIME_MAJOR_COLUMNS
    from skf_ref.method._paths.tiles import tiles as _tiles

    n, T = 2 * TIME_MAJOR_COLUMNS + 5, 300
    for target, width in ((np.empty((T, n)).T, TIME_MAJOR_COLUMNS), (np.empty((n, T)), None)):
        seen = np.zeros((n, T), dtype=int)
        tiles = _tiles(0, n, T, target)
        for rows, times in tiles:
            seen[rows, times] += 1
        assert np.all(seen == 1)
        if width:  # each step of a tile one contiguous run of TIME_MAJOR_COLUMNS rows
            assert tiles[0][0] == slice(0, width)
        else:  # source-major: whole rows
            assert all(times == slice(0, T) for _, times in tiles)


@pytest.mark.parametrize("order", ["C", "F"])
def test_amplitude_on_worker_threads_equals_the_norm(order):
    from skf_ref.method import amplitude_from_components

    z = np.asarray(np.random.default_rng(3).standard_normal((3 * 700, 900)), order=order)
    expected = np.linalg.norm(z.reshape(700, 3, 900), axis=1)
    np.testing.assert_allclose(amplitude_from_components(z, 3), expected, rtol=1e-15)


# --- deterministic cases: each part of the recursions on fixed problems ------------------
# (the hypothesis test above draws many models; these pin each piece of the recursions, the
# gains on span V and on its complement, the steady state and the numerical rank, on
# problems chosen to exercise it, so that a mistake in one is caught without luck)

#: Spectral and dense paths on these well-conditioned fixed problems: rounding only.
FIXED_RTOL = 1e-10


def fixed_problem(seed=5, m=5, n=9, T=30, transition=1.0):
    rng = np.random.default_rng(seed)
    L = rng.standard_normal((m, n))
    Y = L @ np.cumsum(0.3 * rng.standard_normal((n, T)), axis=1) + rng.standard_normal((m, T))
    theta0, q = priors_from_snr(L, 1.0, pm_snr_db=0.0, ep_snr_db=10.0, n_steps=30)
    return dict(L=L, Y=Y, noise_std=1.0, theta0=theta0, q=q, transition=transition)


def _agree_with_dense(problem, **settings):
    spectral = reconstruct(**problem, **settings, path="spectral")
    reference = reconstruct(**problem, **settings, path="dense")
    for name in QUANTITIES:
        assert relative(getattr(spectral, name), getattr(reference, name)) <= FIXED_RTOL, name
    assert spectral.log_likelihood == pytest.approx(reference.log_likelihood, rel=FIXED_RTOL)
    return spectral


@pytest.mark.parametrize("smoother", [None, "rts-standardized", "rts-state"])
@pytest.mark.parametrize("transition", [1.0, 0.8, -0.5, 1.1])
def test_transient_fixed_problems_equal_the_dense_path(transition, smoother):
    # 12 steps: the recursions never settle, every gain is its own
    problem = fixed_problem(T=12, transition=transition)
    rec = _agree_with_dense(problem, smoother=smoother, exponent=1.25)
    assert not rec.lazy_outputs.recursions.held


@pytest.mark.parametrize("smoother", [None, "rts-standardized", "rts-state"])
@pytest.mark.parametrize("transition", [1.0, 0.8, -0.5])
def test_settled_fixed_problems_equal_the_dense_path(transition, smoother):
    # 200 steps, held from step 40-80: the held gains, weights and log-determinants
    problem = fixed_problem(T=200, transition=transition)
    rec = _agree_with_dense(problem, smoother=smoother, exponent=0.5)
    assert 0 < rec.lazy_outputs.steady < 120


def _dense_gains(problem):
    """G_t = P_{t|t} A^T P_{t+1|t}^{-1} of the dense path, t = 0 .. T-2."""
    n = problem["L"].shape[1]
    a, eye = problem["transition"], np.eye(n)
    f = dense.kalman_filter(
        problem["L"], problem["Y"], eye[:5, :5], a * eye, problem["q"] * eye,
        problem["theta0"] * eye, 0.5,
    )  # fmt: skip
    return [
        np.linalg.solve(f["P_pred"][t + 1], a * f["P_filt"][t]).T
        for t in range(len(f["P_pred"]) - 1)
    ]


@pytest.mark.parametrize("transition", [1.0, 0.8, -0.5, 1.1])
def test_the_smoother_gains_are_the_dense_gains(transition):
    # in the singular basis G_t = V diag(gamma_t) V^T + beta_t (I - V V^T): read both off the
    # dense path's gain, on span V and on a vector orthogonal to it
    from skf_ref.method import SpectralBasis
    from skf_ref.method._paths.recursions import Recursions

    problem = fixed_problem(T=12, transition=transition)
    basis = SpectralBasis(problem["L"], np.eye(5))
    recursions = Recursions(basis.s, transition, problem["q"], problem["theta0"], 12)
    gamma, beta = recursions.gains
    V = basis.V
    perp = np.linalg.svd(V.T)[2][-1]  # orthogonal to span V (n = 9 > rank 5)
    for t, G in enumerate(_dense_gains(problem)):
        np.testing.assert_allclose(V.T @ G @ V, np.diag(gamma[t]), rtol=0, atol=1e-12)
        np.testing.assert_allclose(G @ perp, beta[t] * perp, rtol=0, atol=1e-12)


@pytest.mark.parametrize("transition", [1.0, 0.8, -0.5, 1.1])
def test_the_complement_gain_follows_its_covariance(transition):
    # off span V nothing is observed: c_{t+1|t} = a^2 c_{t|t-1} + q and c_{t|t} = c_{t|t-1},
    # so beta_t = a c_{t|t-1} / c_{t+1|t}
    from skf_ref.method._paths.recursions import Recursions

    theta0, q, T = 2.0, 0.3, 40
    c = [transition**2 * theta0 + q]
    for _ in range(T - 1):
        c.append(transition**2 * c[-1] + q)
    expected = transition * np.array(c[:-1]) / np.array(c[1:])
    recursions = Recursions(np.array([3.0, 1.0]), transition, q, theta0, T)
    np.testing.assert_allclose(recursions.gains[1], expected, rtol=1e-14)
    np.testing.assert_allclose(recursions.u, q / np.array(c), rtol=1e-14)


@pytest.mark.parametrize("transition", [1.0, 0.8, -0.5])
def test_the_held_recursion_is_the_full_one_from_the_steady_step_on(transition):
    from skf_ref.method._paths.recursions import STEADY_RTOL, Recursions, fixed_point

    s, q, theta0, T = np.array([4.0, 1.5, 0.2]), 0.05, 1.0, 600
    held = Recursions(s, transition, q, theta0, T)
    full = Recursions(s, transition, q, theta0, T, rtol=-1.0)
    assert held.held and held.steady < 500 and not full.held
    every = held.expand(held.p_pred, slice(0, T))
    np.testing.assert_allclose(every, full.p_pred, rtol=STEADY_RTOL, atol=0)
    # up to the steady step both run the same loop over the same numbers: by construction
    np.testing.assert_array_equal(every[: held.steady + 1], full.p_pred[: held.steady + 1])
    target = fixed_point(s, transition, q)
    np.testing.assert_allclose(held.p_pred[-1], target, rtol=STEADY_RTOL)
    gamma_held = held._gamma(slice(0, T - 1))
    np.testing.assert_allclose(gamma_held, full.gains[0], rtol=1e-13, atol=0)
    # beta is never held: the same loop over the same numbers, by construction
    np.testing.assert_array_equal(held.gains[1], full.gains[1])
    assert held.log_det_innovations() == pytest.approx(full.log_det_innovations(), rel=1e-14)
    eta = np.random.default_rng(0).standard_normal((T, 3))
    xi_held, quadratic_held, _ = held.filter_means(eta)
    xi_full, quadratic_full, _ = full.filter_means(eta)
    np.testing.assert_allclose(xi_held, xi_full, rtol=1e-12, atol=1e-14)
    assert quadratic_held == pytest.approx(quadratic_full, rel=1e-13)


@pytest.mark.parametrize("transition", [1.0, 0.8, -0.5])
def test_the_steady_state_starts_at_the_first_settled_step(transition):
    # held from the first step whose p_{t|t-1} is within STEADY_RTOL / 2 of the fixed point
    from skf_ref.method._paths.recursions import STEADY_RTOL, Recursions, fixed_point

    s, q, theta0, T = np.array([4.0, 1.5, 0.2]), 0.05, 1.0, 600
    full = Recursions(s, transition, q, theta0, T, rtol=-1.0).p_pred
    close = np.abs(full - fixed_point(s, transition, q)) <= STEADY_RTOL / 2 * full
    first = int(np.flatnonzero(close.all(axis=1))[0])
    assert Recursions(s, transition, q, theta0, T).steady == first


def _lead_field_of_singular_values(s, n=40, seed=0):
    """An (len(s), n) lead field with singular values exactly ``s`` (to rounding), whose
    column 0 lies along the fourth singular direction alone."""
    rng = np.random.default_rng(seed)
    m = len(s)
    U = np.linalg.qr(rng.standard_normal((m, m)))[0]
    rest = np.linalg.qr(rng.standard_normal((n - 1, m)))[0]  # orthonormal, zero in row 0
    V = np.vstack([np.zeros(m), rest])
    V[:, 3] = np.eye(n)[0]  # source 0: the weak direction only
    V[1:, 3] = 0.0
    return (U * s) @ V.T


def test_the_numerical_rank_keeps_what_double_precision_resolves():
    # the threshold is s_1 max(m, n) eps = 8.9e-15 s_1 here (m = 6, n = 40): 1e-9 is kept,
    # 4e-15 (above m eps s_1, below n eps s_1) and 0 are not
    from skf_ref.method import SpectralBasis

    L = _lead_field_of_singular_values(np.array([1.0, 0.5, 0.1, 1e-9, 4e-15, 0.0]))
    assert SpectralBasis(L, np.eye(6)).rank == 4
    strong = _lead_field_of_singular_values(np.array([1.0, 0.5, 0.1, 1e-9, 1e-13, 0.0]))
    assert SpectralBasis(strong, np.eye(6)).rank == 5


def test_a_weak_direction_above_the_threshold_is_computed_as_the_dense_path_does():
    # source 0 is seen only along the singular direction of 1e-9: dropping it from the
    # basis (a threshold too high) would leave that source without weights
    L = _lead_field_of_singular_values(np.array([1.0, 0.5, 0.1, 1e-9, 4e-15, 0.0]))
    rng = np.random.default_rng(1)
    Y = L @ rng.standard_normal((40, 8)) + 1e-3 * rng.standard_normal((6, 8))
    problem = dict(L=L, Y=Y, noise_std=1e-3, theta0=1.0, q=0.1)
    spectral = reconstruct(**problem, path="spectral")
    reference = reconstruct(**problem, path="dense")
    assert spectral.lazy_outputs.V.shape == (40, 4)  # the basis of rank 4
    for name in ("z", "weights"):
        np.testing.assert_allclose(getattr(spectral, name)[0], getattr(reference, name)[0],
                                   rtol=1e-6)  # fmt: skip
        assert relative(getattr(spectral, name), getattr(reference, name)) <= 1e-6
