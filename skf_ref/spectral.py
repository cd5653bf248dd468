r"""The exact fast path: the SKF and both smoothers in the singular basis of the lead field.

It applies to the paper's model: ``A = a I``, ``Q = q I``, ``P_0 = theta0 I`` and a constant
SPD noise covariance ``R``. Nothing is approximated; the result equals :mod:`skf_ref.dense`
to rounding. Cost: one thin SVD, O(r) work per step, and a few (n, r) x (r, T) products,
with ``r = rank(L) <= n_channels``. Memory O(n r + n T); no (n, n) matrix is formed.

Why it equals the dense recursion, equation by equation (docs/model.md §2-3)
---------------------------------------------------------------------------
**Whitening.** With ``R = C C^T`` (Cholesky), ``L~ = C^{-1} L``, ``y~ = C^{-1} y`` and noise
covariance I give the same means and covariances: ``S~ = C^{-1} S C^{-T}`` and
``K~ = K C``, so ``K S K^T = K~ S~ K~^T`` and the weights §2.2 (7) are unchanged. The
log-likelihood changes by the Jacobian: ``log N(e; 0, S) = log N(e~; 0, S~) - log|det C|``.

**Basis.** Let ``L~ = U diag(s) V^T`` (thin SVD, ``V`` (n, r) with orthonormal columns,
``V_perp`` its orthogonal complement, never formed). Claim: every covariance has the form
``P = V diag(p) V^T + c (I - V V^T)``, with a vector ``p`` (r,) and one scalar ``c``.
``P_0 = theta0 I`` has it (``p = theta0``, ``c = theta0``). If ``P_{t-1|t-1}`` has it:

- predict §2.2 (4): ``a^2 P + q I`` has it with ``p_pred = a^2 p + q``, ``c_pred = a^2 c + q``;
- update §2.2 (5): ``S~ = U diag(s^2 p_pred) U^T + I``, so in the basis ``U`` (completed to R^m)
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

**Weights, §2.2 (7).** ``w = diag(P^{1/2} L~^T S~^{-1} L~ P^{1/2})`` (docs/model.md §2) and
``L~ P^{1/2} = U diag(s sqrt(p_pred)) V^T``, so
``w = (V o V) omega`` with ``omega = s^2 p_pred / (s^2 p_pred + 1)`` (``o``: elementwise).
**Output, §2.2 (6).** ``P_pred^{-1/2} x = V diag(p_pred^{-1/2}) xi``.

**Smoother gains, §2.3 (4).** ``G_t = P_{t|t} a P_{t+1|t}^{-1} = V diag(gamma_t) V^T
+ beta_t (I - V V^T)`` with ``gamma_t = a p_{t|t} / p_{t+1|t}`` and the scalar
``beta_t = a c_{t|t} / c_{t+1|t} = a / (a^2 + q / c_{t|t})``, computed from the ratio
``q / c`` so that it stays finite when ``c`` grows past the largest float (``|a| > 1``).

- ``"rts-state"``: ``x^s`` stays in ``span V``:
  ``xi^s_t = xi_t + gamma_t (xi^s_{t+1} - a xi_t)``, then §2.2 (6) as above.
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

from . import memory
from .checks import InputError
from .result import Reconstruction
from .standardization import overflow_cause, standardization_weights, standardize

__all__ = ["SpectralModel", "run"]

_LOG_2PI = np.log(2 * np.pi)
# Temporaries of at most this size when forming (T, n) outputs: small enough for the
# allocator to reuse them (a fresh large allocation costs a page fault per 4 KiB).
_CHUNK_BYTES = 4 * 2**20
# Lead fields below this many entries are decomposed on one BLAS thread. On the project's
# 2-core machine (validation/bench.py, --blas-threads) two threads sped the SVD of a
# 64 x 9048 lead field up 1.24x when the machine was idle and slowed it 2-25x when another
# process held a core; from 128 x 150 000 on, two threads gained 1.4x idle and lost 2x
# loaded, so larger problems keep the library's default.
_THREADED_SVD_ENTRIES = 2_000_000


@functools.cache
def _blas():
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def _whitener(R):
    """``M -> C^{-1} M`` and ``log|det C|`` with ``R = C C^T`` (Cholesky)."""
    C = linalg.cholesky(R, lower=True)
    if np.array_equal(C, C[0, 0] * np.eye(len(C))):
        return (lambda M: M / C[0, 0]), len(C) * np.log(C[0, 0])
    return functools.partial(linalg.solve_triangular, C, lower=True), np.sum(np.log(np.diag(C)))


def _basis(Lw):
    """Thin SVD of the whitened lead field, truncated to its numerical rank."""
    # SVD of the transpose: (n, m) in C order is LAPACK's column-major (m, n), no copy.
    threads = 1 if Lw.size < _THREADED_SVD_ENTRIES else None
    with _blas().limit(limits=threads, user_api="blas"):
        V, s, Ut = linalg.svd(Lw.T, full_matrices=False, lapack_driver="gesdd")
    rank = int(np.sum(s > s[0] * max(Lw.shape) * np.finfo(float).eps))
    U, s, V = Ut[:rank].T, s[:rank], V[:, :rank]
    # The SVD gives each row V_j of V to an absolute accuracy of about eps: a column of L~
    # much weaker than the others (||l_j|| << s_1) gets a row of size ~||l_j|| / s and only
    # eps s / ||l_j|| relative accuracy. V_j = l_j^T U diag(1/s) (from L~ = U diag(s) V^T)
    # is as accurate relative to its own size; for ||l_j|| < s_r its absolute error is at
    # most the SVD's, so V stays orthonormal to rounding.
    weak = np.linalg.norm(Lw, axis=0) < s[-1]
    if weak.any():
        V[weak] = (Lw[:, weak].T @ U) / s
    return U, s, V


def _covariances(s, a, q, theta0, n_times):
    """``p_{t|t-1}``, ``p_{t|t}`` (T, r) and ``u_t = q / c_{t|t-1}`` (T,): data-free.

    The complement's variance ``c`` grows as ``a^(2t)`` when ``|a| > 1`` and overflows on
    long runs; only its ratio to ``q`` enters the smoother (:func:`_rts_gains`), so the
    recursion carries ``u = q / c`` in [0, 1] instead: ``c' = a^2 c + q`` gives
    ``u' = u / (a^2 + u)``.
    """
    p_pred, p_filt, u = np.empty((n_times, len(s))), np.empty((n_times, len(s))), np.empty(n_times)
    p = np.full(len(s), theta0)
    u_next = q / (a**2 * theta0 + q)
    for t in range(n_times):
        # P_{t|t-1} = a^2 P_{t-1|t-1} + q I                            §2.2 (4)
        p_pred[t], u[t] = a**2 * p + q, u_next
        # P_{t|t} = P_{t|t-1} - K S K^T: on span V p / (s^2 p + 1), none on the rest §2.2 (5)
        p = p_filt[t] = p_pred[t] / (s**2 * p_pred[t] + 1)
        u_next = u[t] / (a**2 + u[t])
    return p_pred, p_filt, u


def _means(s, eta, p_pred, a):
    """``xi_t = V^T x_{t|t}`` (T, r) and the whitened innovations' log-likelihood terms."""
    xi, x = np.empty_like(eta), np.zeros(eta.shape[1])
    quadratic = 0.0
    for t in range(len(eta)):
        denom = s**2 * p_pred[t] + 1  # eigenvalues of S~ on span U
        innovation = eta[t] - s * a * x  # U^T (y~_t - L~ x_{t|t-1})
        # x_{t|t} = x_{t|t-1} + K~ e~_t with K~ = V diag(p s / (s^2 p + 1)) U^T §2.2 (5)
        x = xi[t] = a * x + p_pred[t] * s / denom * innovation
        quadratic += np.sum(innovation**2 / denom)
    return xi, quadratic


def _rts_gains(p_pred, p_filt, u, a):
    """gamma_t (T-1, r) on span V and the scalar beta_t (T-1,) on its complement."""
    gamma = a * p_filt[:-1] / p_pred[1:]
    # beta_t = a c_{t|t} / c_{t+1|t} = a c_t / (a^2 c_t + q) = a / (a^2 + u_t)
    beta = a / (a**2 + u[:-1])
    return gamma, beta


def _backward(z, gain, a, overwrite=False):
    """``s_t = z_t + G_t (s_{t+1} - a z_t)``, ``s_T = z_T``; gain per step, (T-1, ...).

    With ``overwrite`` the result replaces ``z`` (step t reads only ``z_t`` and ``s_{t+1}``).
    """
    s = z if overwrite else z.copy()
    for t in range(len(z) - 2, -1, -1):
        # the same, in place: s_t = (1 - a G_t) z_t + G_t s_{t+1}
        s[t] *= 1 - a * gain[t]
        s[t] += gain[t] * s[t + 1]
    return s


def _by_columns(n, T, fill):
    """A (T, n) array filled by ``fill(columns, view, work)`` in chunks of bounded size.

    ``work`` is a contiguous (T, chunk) scratch array, the same memory for every chunk.
    """
    memory.require(8 * n * T, f"a ({n}, {T}) output array")
    out = np.empty((T, n))
    step = max(1, _CHUNK_BYTES // (8 * T))
    work = np.empty(T * min(step, n))
    for start in range(0, n, step):
        columns = slice(start, min(start + step, n))
        fill(columns, out[:, columns], work[: T * (columns.stop - start)].reshape(T, -1))
    return out


class SpectralModel:
    """The data-independent part of the spectral path, prepared once, applied many times.

    Whitening, the SVD and the whole covariance recursion depend on the model and the number
    of steps only, so runs that share them (several seeds of a simulation, several
    exponents and smoothers) pay for them once.

    Parameters
    ----------
    model : StateSpaceModel
        With ``transition``, ``q`` and ``theta0`` scalars or scalar multiples of the
        identity (:meth:`StateSpaceModel.isotropic_problem` is None).
    n_times : int

    Examples
    --------
    >>> from skf_ref.model import StateSpaceModel
    >>> rng = np.random.default_rng(0)
    >>> model = StateSpaceModel.create(rng.standard_normal((6, 9)), noise_std=1.0,
    ...                                theta0=1.0, q=0.1)
    >>> prepared = SpectralModel(model, n_times=5)
    >>> a = prepared.apply(rng.standard_normal((6, 5)), exponent=0.5, smoother=None)
    >>> b = prepared.apply(rng.standard_normal((6, 5)), exponent=1.25, smoother="rts-state")
    >>> a.z.shape, b.z.shape, prepared.rank
    ((9, 5), (9, 5), 6)
    """

    def __init__(self, model, n_times):
        problem = model.isotropic_problem()
        if problem:
            raise InputError(
                f"the spectral path needs A = a I, Q = q I, P_0 = theta0 I: {problem}"
            )
        a, q, theta0 = (model.scalar(name) for name in ("transition", "q", "theta0"))
        self.model, self.a, self.n_times = model, a, n_times
        self.n_channels, self.n_sources = model.L.shape
        self._whiten, self._log_det_C = _whitener(model.R)
        self.U, self.s, self.V = _basis(self._whiten(model.L))
        self._V_squared = self.V**2
        self.p_pred, self.p_filt, self._u = _covariances(self.s, a, q, theta0, n_times)
        # w = (V o V) omega, omega = s^2 p / (s^2 p + 1)               §2.2 (7)
        self.omega = self.s**2 * self.p_pred / (self.s**2 * self.p_pred + 1)
        self._log_det_S = np.sum(np.log(self.s**2 * self.p_pred + 1))
        self._check_range()

    def _check_range(self):
        """Refuse, before any output, a model whose covariances leave double precision."""
        if not (np.isfinite(self.p_pred).all() and np.isfinite(self._log_det_S)):
            raise InputError(
                f"the predicted covariance overflows: theta0={self.model.theta0:g}, "
                f"q={self.model.q:g} and transition={self.a:g} are out of range at this lead "
                f"field's scale (largest whitened singular value {self.s[0]:.3g}); rescale L, "
                "the noise or the priors"
            )
        if not self.omega.min() > 0:
            raise InputError(overflow_cause(self.omega.min(), 0.0))

    @property
    def rank(self):
        """int : Numerical rank of the whitened lead field."""
        return len(self.s)

    def _raw_weights(self, columns, out):
        # w_t = (V o V) omega_t                                        §2.2 (7)
        return np.matmul(self.omega, self._V_squared[columns].T, out=out)

    def _standardized(self, xi, exponent, project=False):
        """z (T, n) from singular coordinates; with ``project``, also ``z V`` (T, r)."""
        # z_t = W_t^(alpha) V diag(p_pred^{-1/2}) xi_t           §2.2 (6)-(7)
        u = xi / np.sqrt(self.p_pred)
        projection = np.zeros_like(u) if project else None

        def fill(c, view, work):
            np.matmul(u, self.V[c].T, out=view)  # P_{t|t-1}^{-1/2} x_{t|t}
            standardize(self._raw_weights(c, work), view, exponent, out=view, overwrite_w=True)
            if project:  # while the chunk is in cache
                projection[:] += view @ self.V[c]

        return _by_columns(self.n_sources, self.n_times, fill), projection

    def _expand(self, xi):
        return _by_columns(
            self.n_sources,
            self.n_times,
            lambda c, view, work: np.matmul(xi, self.V[c].T, out=view),
        )

    def apply(self, Y, exponent, smoother):
        """Filter and smooth data ``Y``; equal to :func:`skf_ref.dense.run` on the model.

        Parameters
        ----------
        Y : ndarray, shape (n_channels, n_times)
        exponent : float
        smoother : {None, "rts-standardized", "rts-state"}

        Returns
        -------
        Reconstruction
            Its arrays are computed on first access.
        """
        m, T, a = self.n_channels, self.n_times, self.a
        Y = self.model.check_data(Y)
        if Y.shape != (m, T):
            raise InputError(f"Y must have shape ({m}, {T}), got {Y.shape}")
        Yw = self._whiten(Y)
        eta = Yw.T @ self.U  # (T, r)
        rho_sq = np.sum((Yw - self.U @ eta.T) ** 2)  # data outside span U
        xi, quadratic = _means(self.s, eta, self.p_pred, a)
        log_likelihood = -0.5 * (T * m * _LOG_2PI + self._log_det_S + quadratic + rho_sq)
        z_filtered = functools.cache(lambda: self._standardized(xi, exponent)[0])
        x_filtered = functools.cache(lambda: self._expand(xi))
        x, z = x_filtered, z_filtered
        gamma, beta = _rts_gains(self.p_pred, self.p_filt, self._u, a)
        if smoother == "rts-state":
            xi_s = _backward(xi, gamma, a)
            x = functools.cache(lambda: self._expand(xi_s))
            z = functools.cache(lambda: self._standardized(xi_s, exponent)[0])
        elif smoother == "rts-standardized":
            # z smooths its own z_{t|t} in place: asking for z alone holds one (T, n) array
            z = functools.cache(
                lambda: _smooth_standardized(
                    *self._standardized(xi, exponent, project=True), self.V, gamma, beta, a
                )
            )
        return Reconstruction(
            z=lambda: z().T,
            x=lambda: x().T,
            z_filtered=lambda: z_filtered().T,
            x_filtered=lambda: x_filtered().T,
            weights=lambda: self._weights(exponent).T,
            log_likelihood=log_likelihood - T * self._log_det_C,
            n_sources=self.n_sources,
            n_times=T,
            exponent=exponent,
            smoother=smoother,
            method="spectral",
            theta0=self.model.theta0,
            q=self.model.q,
            transition=self.model.transition,
            diagnose=lambda: overflow_cause(self._min_raw_weight(), exponent),
        )

    def _min_raw_weight(self):
        """The smallest raw weight over every source and step (only to explain a failure)."""
        step = max(1, _CHUNK_BYTES // (8 * self.n_times))
        return min(
            np.min(self.omega @ self._V_squared[start : start + step].T)
            for start in range(0, self.n_sources, step)
        )

    def _weights(self, exponent):
        return _by_columns(
            self.n_sources,
            self.n_times,
            lambda c, view, work: standardization_weights(
                self._raw_weights(c, view), exponent, out=view
            ),
        )


def run(model, Y, exponent, smoother):
    """Filter and optionally smooth in the singular basis; equal to :func:`skf_ref.dense.run`.

    Parameters
    ----------
    model : StateSpaceModel
        Isotropic: see :class:`SpectralModel`.
    Y : ndarray, shape (n_channels, n_times)
    exponent : float
    smoother : {None, "rts-standardized", "rts-state"}

    Returns
    -------
    Reconstruction
        Its arrays are computed on first access.
    """
    return SpectralModel(model, Y.shape[1]).apply(Y, exponent, smoother)


def _smooth_standardized(zf, zeta, V, gamma, beta, a):
    """``s = h + V delta`` of the module docstring, written over zf (T, n); ``zeta = zf V``."""
    beta_col = beta[:, None]
    h = _backward(zf, beta_col, a, overwrite=True)  # scalar gains on whole vectors: O(n T)
    chi = _backward(zeta, beta_col, a)  # = V^T h
    delta = np.zeros_like(zeta)
    for t in range(len(zf) - 2, -1, -1):
        delta[t] = gamma[t] * delta[t + 1] + (gamma[t] - beta[t]) * (chi[t + 1] - a * zeta[t])
    step = max(1, _CHUNK_BYTES // (8 * V.shape[0]))
    work = np.empty((min(step, len(h)), V.shape[0]))
    for start in range(0, len(h), step):
        rows = slice(start, min(start + step, len(h)))
        h[rows] += np.matmul(delta[rows], V.T, out=work[: rows.stop - start])
    return h
