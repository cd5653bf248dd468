"""Both standardizations and every smoother agree across the three paths (hypothesis).

The dense path is the definition (docs/model.md §2-3); the filterpy path computes the
smoothed weights from filterpy's own ``rts_smoother`` covariances; the spectral path from
its rank-r recursions and the 3 x 3 closed form. The default run draws the same models
every time (tests/conftest.py); ``--hypothesis-profile=explore`` draws thousands.
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skf_ref import priors_from_snr, reconstruct
from skf_ref.method._paths import dense

QUANTITIES = ("z", "x", "z_filtered", "x_filtered", "weights")
SMOOTHERS = (None, "rts-standardized", "rts-state", "rts-smoothed-weights")
# What the issue asks: 1e-10 relative on random problems. Rounding grows with the condition
# numbers kappa of S_t, P_{t|t-1}, Sigma_t and of the blocks B_t(i) (the dense path solves
# and takes eigh of each; the smoothed weights subtract Sigma_t - P^s_t there), so models
# with kappa > 1e5 are held to CONDITION_FACTOR eps kappa instead.
EQUALITY_RTOL = 1e-10
CONDITION_FACTOR = 1e3


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


#: rho of the stationary AR(1) prior, exp(-dt / tau): (0, 1], 1 the static prior (q = 0).
stationary_rho = st.one_of(st.just(1.0), st.floats(1e-3, 1.0, exclude_max=True))


@st.composite
def models(draw):
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    n_orient = draw(st.sampled_from([1, 3]))
    m = draw(st.integers(5 if n_orient == 3 else 3, 10))  # a position seen in 3 orientations
    n = n_orient * draw(st.integers(1, 5))
    T = draw(st.integers(1, 6))
    L = rng.standard_normal((m, n)) * rng.uniform(0.2, 2.0, n)
    if draw(st.booleans()):
        L -= L.mean(axis=0)  # average reference: rank m - 1
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
        pm_snr_db=draw(st.sampled_from([-10.0, 0.0, 10.0])),
        ep_snr_db=draw(st.sampled_from([-10.0, 0.0, 20.0])),
        n_steps=T,
    )
    q, transition = draw(st.sampled_from([0.0, q])), draw(st.sampled_from([1.0, 0.8, -0.5]))
    if draw(st.booleans()):  # the stationary AR(1) prior (ar1_priors): rho in (0, 1]
        transition = draw(stationary_rho)
        q = -np.expm1(2 * np.log(transition)) * theta0  # (1 - rho^2) theta0
    return dict(
        L=L,
        Y=Y,
        theta0=theta0,
        q=q,
        transition=transition,
        exponent=draw(st.sampled_from([0.0, 0.5, 1.0, 1.25, 1.5, 2.0, 0.7])),
        smoother=draw(st.sampled_from(SMOOTHERS)),
        standardize=draw(st.sampled_from(["column", "position"])),
        n_orient=n_orient,
        **noise,
    )


def condition_number(model):
    """The largest condition number the dense path meets: S_t, P_{t|t-1}, Sigma_t, blocks."""
    L, Y = model["L"], model["Y"]
    m, n = L.shape
    R = model.get("noise_cov", model.get("noise_std", 1.0) ** 2 * np.eye(m))
    eye = np.eye(n)
    a, q, theta0 = model["transition"], model["q"], model["theta0"]
    f = dense.kalman_filter(L, Y, R, a * eye, q * eye, theta0 * eye, 0.5)
    kappa = 1.0
    for P, P_filt in zip(f["P_pred"], f["P_filt"], strict=True):
        kappa = max(kappa, np.linalg.cond(L @ P @ L.T + R), np.linalg.cond(P))
        k = model["n_orient"]
        whiten = np.linalg.inv(np.linalg.cholesky(P))
        Psi = whiten @ (P - P_filt) @ whiten.T
        for i in range(0, n, k):
            kappa = max(kappa, np.linalg.cond(Psi[i : i + k, i : i + k]))
    sigma = theta0
    for _ in range(Y.shape[1]):
        sigma = a**2 * sigma + q
    return max(kappa, theta0 / sigma, sigma / theta0)


def tolerance(model):
    return max(EQUALITY_RTOL, CONDITION_FACTOR * np.finfo(float).eps * condition_number(model))


@given(models())
def test_spectral_and_filterpy_equal_dense(model):
    reference = reconstruct(**model, path="dense")
    rtol = tolerance(model)
    for method in ("spectral", "filterpy"):
        other = reconstruct(**model, path=method)
        for name in QUANTITIES:
            assert relative(getattr(other, name), getattr(reference, name)) <= rtol, (
                method,
                name,
            )


@given(models())
def test_streamed_blocks_equal_the_whole_arrays(model):
    # the long-recording route: rows computed block by block (docs/model.md §9)
    rec = reconstruct(**model, path="spectral")
    again = reconstruct(**model, path="spectral")
    for name in ("z", "weights"):
        whole = getattr(rec, name)
        blocks = np.vstack([block for _, block in again.blocks(name, rows=model["n_orient"])])
        np.testing.assert_allclose(blocks, whole, rtol=1e-13, atol=1e-13 * np.abs(whole).max())


@given(models(), st.data())
def test_missing_steps_agree_across_paths(model, data):
    # a column of NaN is a missing step (docs/model.md §2): no estimate there on any
    # smoother (the smoothed weights would be defined, but a bad segment has no estimate)
    T = model["Y"].shape[1]
    if model["smoother"] == "rts-standardized" or T < 2:
        return  # refused over gaps (test_entry_point); one step leaves nothing observed
    gap = data.draw(st.integers(0, T - 1))
    model = dict(model, Y=model["Y"].copy())
    model["Y"][:, gap] = np.nan
    reference = reconstruct(**model, path="dense")
    assert reference.missing[gap]
    assert np.isnan(reference.z[:, gap]).all()
    rtol = tolerance(model)
    for method in ("spectral", "filterpy"):
        other = reconstruct(**model, path=method)
        for name in QUANTITIES:
            a, b = getattr(other, name), getattr(reference, name)
            np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
            kept = ~np.isnan(b)
            scale = np.max(np.abs(b[kept]))
            assert np.max(np.abs(a[kept] - b[kept])) <= rtol * scale, (method, name)


@pytest.mark.parametrize("smoother", SMOOTHERS)
@pytest.mark.parametrize("standardize", ["column", "position"])
def test_held_recursions_equal_the_full_ones(monkeypatch, smoother, standardize):
    # a recording long enough to settle: the held blocks F V (docs/model.md §9) against the
    # full recursion; the smoothed weights never settle (every step its own)
    from skf_ref.method._paths import recursions

    rng = np.random.default_rng(3)
    L = rng.standard_normal((8, 9))
    Y = np.cumsum(rng.standard_normal((8, 150)), axis=1)
    theta0, q = priors_from_snr(L, 1.0, pm_snr_db=0.0, ep_snr_db=20.0, n_steps=20)
    common = dict(
        noise_std=1.0, theta0=theta0, q=q, exponent=1.25, smoother=smoother,
        standardize=standardize, n_orient=3, path="spectral",
    )  # fmt: skip
    held = reconstruct(L, Y, **common)
    with monkeypatch.context() as patch:
        patch.setattr(recursions, "STEADY_RTOL", -1.0)
        full = reconstruct(L, Y, **common)
    dense_result = reconstruct(L, Y, **dict(common, path="dense"))
    for name in QUANTITIES:
        assert relative(getattr(held, name), getattr(full, name)) < 1e-12, name
        assert relative(getattr(held, name), getattr(dense_result, name)) < 1e-10, name
