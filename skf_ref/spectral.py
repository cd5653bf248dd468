r"""The exact fast path: the SKF and both smoothers in the singular basis of the lead field.

It applies to the paper's model: ``A = a I``, ``Q = q I``, ``P_0 = theta0 I`` and a constant
SPD noise covariance ``R``. Nothing is approximated; the result equals :mod:`skf_ref.dense`
to rounding. Cost: one thin SVD, O(r) work per step, and a few (n, r) x (r, T) products,
with ``r = rank(L) <= n_channels``. Memory O(n r + n T); no (n, n) matrix is formed.

Why it equals the dense recursion, equation by equation (spec §2-3)
-------------------------------------------------------------------
**Whitening.** With ``R = C C^T`` (Cholesky), ``L~ = C^{-1} L``, ``y~ = C^{-1} y`` and noise
covariance I give the same means and covariances: ``S~ = C^{-1} S C^{-T}`` and
``K~ = K C``, so ``K S K^T = K~ S~ K~^T`` and the weights (7) are unchanged. The
log-likelihood changes by the Jacobian: ``log N(e; 0, S) = log N(e~; 0, S~) - log|det C|``.

**Basis.** Let ``L~ = U diag(s) V^T`` (thin SVD, ``V`` (n, r) with orthonormal columns,
``V_perp`` its orthogonal complement, never formed). Claim: every covariance has the form
``P = V diag(p) V^T + c (I - V V^T)``, with a vector ``p`` (r,) and one scalar ``c``.
``P_0 = theta0 I`` has it (``p = theta0``, ``c = theta0``). If ``P_{t-1|t-1}`` has it:

- predict (4): ``a^2 P + q I`` has it with ``p_pred = a^2 p + q``, ``c_pred = a^2 c + q``;
- update (5): ``S~ = U diag(s^2 p_pred) U^T + I``, so in the basis ``U`` (completed to R^m)
  ``S~`` is diagonal with entries ``s^2 p_pred + 1`` on ``U`` and 1 elsewhere, and
  ``K~ = P L~^T S~^{-1} = V diag(g) U^T`` with ``g = p_pred s / (s^2 p_pred + 1)``;
  ``P_{t|t} = P_pred - K~ S~ K~^T`` has ``p = p_pred / (s^2 p_pred + 1)``, ``c = c_pred``
  (the lead field does not see ``V_perp``: no update there).

**Means.** ``x_0 = 0`` and ``K~`` maps into ``span V``, so ``x_t = V xi_t`` with
``xi_t = a xi_{t-1} + g (eta_t - s a xi_{t-1})``, ``eta_t = U^T y~_t``.

**Log-likelihood.** The innovation ``e~ = y~ - U (s a xi)`` has ``U^T e~ = eta - s a xi``
and, on the complement of ``U``, the part of ``y~`` that no source explains, ``rho_t``:
``log N(e~; 0, S~) = -(m log 2 pi + sum log(s^2 p_pred + 1)
+ sum (U^T e~)^2 / (s^2 p_pred + 1) + ||rho_t||^2) / 2``.

**Weights (7).** ``w = diag(P^{1/2} L~^T S~^{-1} L~ P^{1/2})`` (spec §2) and
``L~ P^{1/2} = U diag(s sqrt(p_pred)) V^T``, so
``w = (V o V) omega`` with ``omega = s^2 p_pred / (s^2 p_pred + 1)`` (``o``: elementwise).
**Output (6).** ``P_pred^{-1/2} x = V diag(p_pred^{-1/2}) xi``.

**Smoother gains (3).** ``G_t = P_{t|t} a P_{t+1|t}^{-1} = V diag(gamma_t) V^T
+ beta_t (I - V V^T)`` with ``gamma_t = a p_{t|t} / p_{t+1|t}`` and the scalar
``beta_t = a c_{t|t} / c_{t+1|t}``.

- ``"rts-state"``: ``x^s`` stays in ``span V``:
  ``xi^s_t = xi_t + gamma_t (xi^s_{t+1} - a xi_t)``, then (6) as above.
- ``"rts-standardized"``: ``z`` is not in ``span V``. Write ``G_t = beta_t I +
  V diag(gamma_t - beta_t) V^T``. The scalar part gives, on whole vectors,
  ``h_t = z_t + beta_t (h_{t+1} - a z_t)``, ``h_T = z_T`` (O(n) per step, no product with
  a matrix). The rest ``d_t = s_t - h_t`` satisfies ``d_T = 0`` and
  ``d_t = beta_t d_{t+1} + V diag(gamma_t - beta_t) V^T (s_{t+1} - a z_t)``, so it lies in
  ``span V``: ``d_t = V delta_t``. With ``zeta = V^T z``, ``chi = V^T h`` (which obeys the
  scalar recursion on ``zeta``) and ``V^T s_{t+1} = chi_{t+1} + delta_{t+1}``:
  ``delta_T = 0``, ``delta_t = gamma_t delta_{t+1} + (gamma_t - beta_t)(chi_{t+1} - a zeta_t)``.
  So ``s = h + V delta``: one product ``V^T z``, one product ``V delta``, O(r T) recursions.

Arrays are kept time-major, (T, n), internally; the result is handed out as (n, T) views.
"""

import functools

import numpy as np
from scipy import linalg

from ._standardize import standardization_weights, standardize
from .result import Reconstruction

__all__ = ["run", "qualification_problem"]

_LOG_2PI = np.log(2 * np.pi)
# Temporaries of at most this size when forming (T, n) outputs: small enough for the
# allocator to reuse them (a fresh large allocation costs a page fault per 4 KiB).
_CHUNK_BYTES = 4 * 2**20


def qualification_problem(transition, q, theta0):
    """Why a model does not qualify for the spectral path, or ``None`` if it does.

    Parameters
    ----------
    transition, q, theta0 : float or ndarray, shape (n_sources, n_sources)
        As checked by :func:`skf_ref.reconstruct`.

    Returns
    -------
    str or None

    Examples
    --------
    >>> qualification_problem(1.0, 0.1, np.eye(3))
    >>> qualification_problem(1.0, np.diag([1.0, 2.0]), 1.0)
    'q is not a scalar multiple of the identity'
    """
    for name, value in (("transition", transition), ("q", q), ("theta0", theta0)):
        if _isotropic(value) is None:
            return f"{name} is not a scalar multiple of the identity"
    return None


def _isotropic(value):
    """The scalar c if value is c or c I, else None."""
    if np.ndim(value) == 0:
        return float(value)
    c = value[0, 0]
    return float(c) if np.array_equal(value, c * np.eye(len(value))) else None


def _whiten(L, Y, R):
    """``C^{-1} L``, ``C^{-1} Y`` and ``log|det C|`` with ``R = C C^T``."""
    C = linalg.cholesky(R, lower=True)
    if np.array_equal(C, C[0, 0] * np.eye(len(C))):
        return L / C[0, 0], Y / C[0, 0], len(C) * np.log(C[0, 0])
    solve = functools.partial(linalg.solve_triangular, C, lower=True)
    return solve(L), solve(Y), np.sum(np.log(np.diag(C)))


def _basis(Lw):
    """Thin SVD of the whitened lead field, truncated to its numerical rank."""
    # SVD of the transpose: (n, m) in C order is LAPACK's column-major (m, n), no copy.
    V, s, Ut = linalg.svd(Lw.T, full_matrices=False, lapack_driver="gesdd")
    rank = int(np.sum(s > s[0] * max(Lw.shape) * np.finfo(float).eps))
    return Ut[:rank].T, s[:rank], V[:, :rank]


def _forward(s, eta, rho_sq, a, q, theta0, n_channels):
    """The filter in singular coordinates: O(r) per step. Arrays are time-major."""
    T, r = eta.shape
    p_pred, p_filt, xi = np.empty((T, r)), np.empty((T, r)), np.empty((T, r))
    c_pred = np.empty(T)
    p, c, x, log_likelihood = np.full(r, theta0), theta0, np.zeros(r), 0.0
    for t in range(T):
        p_pred[t], c_pred[t] = a**2 * p + q, a**2 * c + q
        x_pred = a * x
        denom = s**2 * p_pred[t] + 1  # eigenvalues of S~ on span U
        innovation = eta[t] - s * x_pred
        x = xi[t] = x_pred + p_pred[t] * s / denom * innovation
        p = p_filt[t] = p_pred[t] / denom
        c = c_pred[t]  # no update on the complement of span V
        log_likelihood -= 0.5 * (
            n_channels * _LOG_2PI
            + np.sum(np.log(denom))
            + np.sum(innovation**2 / denom)
            + rho_sq[t]
        )
    return dict(p_pred=p_pred, p_filt=p_filt, c_pred=c_pred, xi=xi, log_likelihood=log_likelihood)


def _rts_gains(f, a):
    """gamma_t (T-1, r) on span V and the scalar beta_t (T-1,) on its complement."""
    gamma = a * f["p_filt"][:-1] / f["p_pred"][1:]
    beta = a * f["c_pred"][:-1] / f["c_pred"][1:]  # c_{t|t} = c_{t|t-1}
    return gamma, beta


def _backward(z, gamma, a):
    """``s_t = z_t + gamma_t (s_{t+1} - a z_t)``, ``s_T = z_T``; gamma per step, (T-1, ...)."""
    s = z.copy()
    for t in range(len(z) - 2, -1, -1):
        s[t] = z[t] + gamma[t] * (s[t + 1] - a * z[t])
    return s


def _by_columns(n, T, block):
    """Fill a (T, n) array from ``block(columns) -> (T, len(columns))`` in bounded chunks."""
    out = np.empty((T, n))
    step = max(1, _CHUNK_BYTES // (8 * T))
    for start in range(0, n, step):
        columns = slice(start, min(start + step, n))
        out[:, columns] = block(columns)
    return out


def run(L, Y, R, transition, q, theta0, exponent, smoother):
    """Filter and optionally smooth in the singular basis; equal to :func:`skf_ref.dense.run`.

    Parameters
    ----------
    L : ndarray, shape (n_channels, n_sources)
    Y : ndarray, shape (n_channels, n_times)
    R : ndarray, shape (n_channels, n_channels)
    transition, q, theta0 : float or ndarray, shape (n_sources, n_sources)
        Scalars or scalar multiples of the identity (see :func:`qualification_problem`).
    exponent : float
    smoother : {None, "rts-standardized", "rts-state"}

    Returns
    -------
    Reconstruction
        Its arrays are computed on first access.
    """
    a, q, theta0 = (_isotropic(v) for v in (transition, q, theta0))
    (m, n), T = L.shape, Y.shape[1]
    Lw, Yw, log_det_C = _whiten(L, Y, R)
    U, s, V = _basis(Lw)
    eta = Yw.T @ U  # (T, r)
    rho_sq = np.sum((Yw - U @ eta.T) ** 2, axis=0)  # data outside span U
    f = _forward(s, eta, rho_sq, a, q, theta0, m)
    omega = s**2 * f["p_pred"] / (s**2 * f["p_pred"] + 1)  # w = (V o V) omega
    inv_sqrt_p = 1 / np.sqrt(f["p_pred"])

    def raw_weights(cols):
        return omega @ (V[cols] ** 2).T

    def standardized(xi):
        # z_t = W_t^(alpha) V diag(p_pred^{-1/2}) xi_t                    (6)-(7)
        u = xi * inv_sqrt_p
        return _by_columns(n, T, lambda c: standardize(raw_weights(c), u @ V[c].T, exponent)[1])

    z_filtered = functools.cache(lambda: standardized(f["xi"]))
    x_filtered = functools.cache(lambda: _by_columns(n, T, lambda c: f["xi"] @ V[c].T))
    x, z = x_filtered, z_filtered
    if smoother == "rts-state":
        gamma, _ = _rts_gains(f, a)
        xi_s = _backward(f["xi"], gamma, a)
        x = functools.cache(lambda: _by_columns(n, T, lambda c: xi_s @ V[c].T))
        z = functools.cache(lambda: standardized(xi_s))
    elif smoother == "rts-standardized":
        z = functools.cache(lambda: _smooth_standardized(z_filtered(), V, *_rts_gains(f, a), a))
    return Reconstruction(
        z=lambda: z().T,
        x=lambda: x().T,
        z_filtered=lambda: z_filtered().T,
        x_filtered=lambda: x_filtered().T,
        weights=lambda: (
            _by_columns(n, T, lambda c: standardization_weights(raw_weights(c), exponent)).T
        ),
        log_likelihood=float(f["log_likelihood"] - T * log_det_C),
        exponent=exponent,
        smoother=smoother,
        method="spectral",
    )


def _smooth_standardized(zf, V, gamma, beta, a):
    """``s = h + V delta`` of the module docstring; zf is (T, n), returns (T, n)."""
    beta_col = beta[:, None]
    h = _backward(zf, beta_col, a)  # scalar gains on whole vectors: O(n T)
    zeta = zf @ V  # (T, r)
    chi = _backward(zeta, beta_col, a)  # = V^T h
    delta = np.zeros_like(zeta)
    for t in range(len(zf) - 2, -1, -1):
        delta[t] = gamma[t] * delta[t + 1] + (gamma[t] - beta[t]) * (chi[t + 1] - a * zeta[t])
    step = max(1, _CHUNK_BYTES // (8 * V.shape[0]))
    for start in range(0, len(h), step):
        rows = slice(start, start + step)
        h[rows] += delta[rows] @ V.T
    return h
