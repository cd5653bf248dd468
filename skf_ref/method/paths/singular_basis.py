r"""The SKF in the singular basis of the whitened lead field: the rank-r recursions.

:mod:`skf_ref.method.paths.spectral` derives, equation by equation, why the filter and both
smoothers of the paper's model (``A = a I``, ``Q = q I``, ``P_0 = theta0 I``) reduce to recursions
on ``r = rank(L)`` numbers per step in the basis of the thin SVD ``L~ = U diag(s) V^T`` of the
whitened lead field. This module holds those recursions and :class:`SpectralBasis`, the whitening
and the SVD, which depend on ``L`` and ``R`` only.

The recursions broadcast over leading dimensions of ``theta0`` and ``q``: with arrays of K
priors they run K filters at once, which is how :meth:`SpectralBasis.log_likelihood` and
:meth:`SpectralBasis.residual_energy` evaluate a whole grid of priors (docs/model.md §4) for
about the cost of one filter.
"""

import collections
import functools
import itertools
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from scipy import linalg
from scipy.linalg import lapack

from ..._utils.checks import InputError

__all__ = [
    "SpectralBasis",
    "backward",
    "covariances",
    "filter_means",
    "log_det_innovations",
    "log_likelihood",
    "map_threads",
    "rts_gains",
    "thin_svd",
    "whitener",
]

_LOG_2PI = np.log(2 * np.pi)
# Rows of L~^T in one block of the SVD's first stage: about 8 MiB (measured against 2 and
# 16 MiB with two BLAS threads).
_SVD_BLOCK_BYTES = 8 * 2**20
# Reflectors per block of LAPACK's compact WY QR (geqrt's nb).
_QR_PANEL = 64
# Priors evaluated at once by SpectralBasis.log_likelihood: bounds its (T, K, r) arrays.
_PRIORS_AT_ONCE = 16


@functools.cache
def _blas():
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def map_threads(func, items):
    """``func`` over ``items`` in worker threads, the results in the order of ``items``.

    One worker per BLAS thread this process may use (threadpoolctl: a caller that limits
    BLAS, as joblib's workers do, limits this too), each on one BLAS thread, so the
    elementwise work between BLAS calls runs on every core as well. Results are consumed
    in order, at most two per worker ahead, so sums over them are the same whatever the
    number of workers, and memory stays bounded.

    Parameters
    ----------
    func : callable
        Must release the GIL for most of its time (numpy, BLAS, LAPACK do).
    items : iterable

    Yields
    ------
    object
        ``func(item)`` for each item, in order.

    Examples
    --------
    >>> list(map_threads(lambda k: k * k, range(5)))
    [0, 1, 4, 9, 16]
    """
    controller = _blas().select(user_api="blas")
    workers = max((entry["num_threads"] for entry in controller.info()), default=1)
    if workers < 2:
        yield from map(func, items)
        return
    items = iter(items)
    with controller.limit(limits=1), ThreadPoolExecutor(workers) as pool:
        pending = collections.deque(
            pool.submit(func, i) for i in itertools.islice(items, 2 * workers)
        )
        while pending:
            result = pending.popleft().result()
            pending.extend(pool.submit(func, i) for i in itertools.islice(items, 1))
            yield result


def whitener(R):
    """``M -> C^{-1} M`` and ``log|det C|`` with ``R = C C^T`` (Cholesky).

    Parameters
    ----------
    R : ndarray, shape (n_channels, n_channels)

    Returns
    -------
    whiten : callable
    log_det_C : float
    """
    C = linalg.cholesky(R, lower=True)
    if np.array_equal(C, C[0, 0] * np.eye(len(C))):
        return (lambda M: M / C[0, 0]), len(C) * np.log(C[0, 0])
    return functools.partial(linalg.solve_triangular, C, lower=True), np.sum(np.log(np.diag(C)))


def thin_svd(Lw):
    """Thin SVD of the whitened lead field, truncated to its numerical rank.

    Parameters
    ----------
    Lw : ndarray, shape (n_channels, n_sources)

    Returns
    -------
    U : ndarray, shape (n_channels, r)
    s : ndarray, shape (r,)
    V : ndarray, shape (n_sources, r)
        C-contiguous.

    Examples
    --------
    >>> Lw = np.random.default_rng(0).standard_normal((4, 10))
    >>> U, s, V = thin_svd(Lw)
    >>> bool(np.allclose(U * s @ V.T, Lw)), V.shape
    (True, (10, 4))
    """
    # Tall-skinny QR of A = L~^T (n, m): the QR of each block of rows, A_i = Q_i R_i, then
    # of the stacked R_i = Q' R, and the SVD of R = X diag(s) Y^T gives A = (Q X) diag(s)
    # Y^T with Q = diag(Q_i) Q'. As stable as one QR of A (each step is orthogonal). Each Q
    # stays as Householder reflectors in LAPACK's compact WY form (geqrt), applied to X by
    # gemqrt, never formed. The blocks run one after the other on all BLAS threads: scipy's
    # LAPACK wrappers hold the GIL, so worker threads would take turns. At 150 000 x 128 on
    # two cores, 0.5-0.7 s against 1.0-1.5 s for the QR that formed each Q_i in worker
    # threads, and 1.3-1.8 s for LAPACK's SVD (gesdd) of the whole A.
    A = Lw.T
    n, m = A.shape
    step = max(2 * m, _SVD_BLOCK_BYTES // (8 * m))
    blocks = [slice(start, min(start + step, n)) for start in range(0, n, step)]

    factors = [_qr(A[rows]) for rows in blocks]
    stacked = np.vstack([np.triu(reflectors[:m]) for reflectors, _ in factors])
    top, T_top = _qr(stacked)
    X, s, Ut = linalg.svd(
        np.triu(top[:m]), full_matrices=False, check_finite=False, lapack_driver="gesdd"
    )
    rank = int(np.sum(s > s[0] * max(Lw.shape) * np.finfo(float).eps))
    U, s = Ut[:rank].T, s[:rank]
    B = _apply_q(top, T_top, X[:, :rank].T).T  # Q' X, one block of rows per block of A
    offsets = np.cumsum([0] + [min(m, rows.stop - rows.start) for rows in blocks])
    V = np.empty((n, rank))
    for (reflectors, T), rows, first, stop in zip(
        factors, blocks, offsets[:-1], offsets[1:], strict=True
    ):
        _apply_q(reflectors, T, B[first:stop].T, out=V[rows].T)
    # The SVD gives each row V_j of V to an absolute accuracy of about eps: a column of L~
    # much weaker than the others (||l_j|| << s_1) gets a row of size ~||l_j|| / s and only
    # eps s / ||l_j|| relative accuracy. V_j = l_j^T U diag(1/s) (from L~ = U diag(s) V^T)
    # is as accurate relative to its own size; for ||l_j|| < s_r its absolute error is at
    # most the SVD's, so V stays orthonormal to rounding.
    weak = np.einsum("ij,ij->j", Lw, Lw) < s[-1] ** 2  # squared norms of L~'s columns
    if weak.any():
        V[weak] = (Lw[:, weak].T @ U) / s
    return U, s, V


def _qr(A):
    """QR of ``A`` (k, m) as LAPACK's reflectors and compact WY factor (geqrt)."""
    reflectors, T, _ = lapack.dgeqrt(min(_QR_PANEL, *A.shape), A)
    return reflectors, T


def _apply_q(reflectors, T, Ct, out=None):
    """``(Q [C; 0])^T`` for the Q of :func:`_qr`, from ``Ct = C^T`` (p, <= k): (p, k).

    Written into ``out`` (p, k) when given; it must be Fortran-ordered, as the transpose of
    C-ordered rows is.
    """
    k = len(reflectors)
    reflectors = reflectors[:, : T.shape[1]]  # a wide block has fewer reflectors than columns
    out = np.zeros((len(Ct), k), order="F") if out is None else out
    out[:, : Ct.shape[1]] = Ct
    out[:, Ct.shape[1] :] = 0
    # (Q [C; 0])^T = [C^T, 0] Q^T
    result, _ = lapack.dgemqrt(reflectors, T, out, side="R", trans="T", overwrite_c=1)
    if not np.shares_memory(result, out):  # gemqrt wrote a copy: never with Fortran order
        out[...] = result
    return out


def covariances(s, a, q, theta0, n_times):
    """``p_{t|t-1}``, ``p_{t|t}`` (T, ..., r) and ``u_t = q / c_{t|t-1}`` (T, ...): data-free.

    ``q`` and ``theta0`` are scalars or arrays of the same batch shape ``...``. The
    complement's variance ``c`` grows as ``a^(2t)`` when ``|a| > 1`` and overflows on long
    runs; only its ratio to ``q`` enters the smoother (:func:`rts_gains`), so the recursion
    carries ``u = q / c`` in [0, 1] instead: ``c' = a^2 c + q`` gives ``u' = u / (a^2 + u)``.
    """
    q, theta0 = np.asarray(q, dtype=float), np.asarray(theta0, dtype=float)
    batch = np.broadcast_shapes(q.shape, theta0.shape)
    p_pred, p_filt = np.empty((n_times, *batch, len(s))), np.empty((n_times, *batch, len(s)))
    u = np.empty((n_times, *batch))
    q_, theta0_ = q[..., None], theta0[..., None]  # broadcast against s
    p = np.broadcast_to(theta0_, (*batch, len(s)))
    u_next = q / (a**2 * theta0 + q)
    for t in range(n_times):
        # P_{t|t-1} = a^2 P_{t-1|t-1} + q I                            §2.2 (4)
        p_pred[t], u[t] = a**2 * p + q_, u_next
        # P_{t|t} = P_{t|t-1} - K S K^T: on span V p / (s^2 p + 1), none on the rest §2.2 (5)
        p = p_filt[t] = p_pred[t] / (s**2 * p_pred[t] + 1)
        u_next = u[t] / (a**2 + u[t])
    return p_pred, p_filt, u


def filter_means(s, eta, p_pred, a):
    """The filtered means in the basis and two sums over their residuals, in one pass.

    ``eta`` is the whitened data in the basis ``U``, (T, r); ``p_pred`` from
    :func:`covariances`, with the same batch dimensions ``...`` as the result.

    Returns
    -------
    xi : ndarray, shape (T, ..., r)
        ``xi_t = V^T x_{t|t}``.
    quadratic : ndarray, shape (...)
        ``sum_t e~_t^T S~_t^{-1} e~_t`` over span U, the innovations' quadratic form.
    residual : ndarray, shape (...)
        ``sum_t ||U^T (y~_t - L~ x_{t|t})||^2``, the filtered residual's energy on span U:
        ``U^T y~_t - s xi_t = e~_t - s^2 p / (s^2 p + 1) e~_t = e~_t / (s^2 p + 1)``.
    """
    xi, x = np.empty(p_pred.shape), np.zeros(p_pred.shape[1:])
    quadratic = np.zeros(p_pred.shape[1:-1])
    residual = np.zeros(p_pred.shape[1:-1])
    for t in range(len(eta)):
        denom = s**2 * p_pred[t] + 1  # eigenvalues of S~ on span U
        innovation = eta[t] - s * a * x  # U^T (y~_t - L~ x_{t|t-1})
        # x_{t|t} = x_{t|t-1} + K~ e~_t with K~ = V diag(p s / (s^2 p + 1)) U^T §2.2 (5)
        x = xi[t] = a * x + p_pred[t] * s / denom * innovation
        quadratic += np.sum(innovation**2 / denom, axis=-1)
        residual += np.sum((innovation / denom) ** 2, axis=-1)  # U^T (y~_t - L~ x_{t|t})
    return xi, quadratic, residual


def rts_gains(p_pred, p_filt, u, a):
    """gamma_t (T-1, r) on span V and the scalar beta_t (T-1,) on its complement."""
    gamma = a * p_filt[:-1] / p_pred[1:]
    # beta_t = a c_{t|t} / c_{t+1|t} = a c_t / (a^2 c_t + q) = a / (a^2 + u_t)
    beta = a / (a**2 + u[:-1])
    return gamma, beta


#: The backward pass with one scalar gain per step runs CHUNK_STEPS steps as one matrix
#: product on arrays narrower than CHUNK_COLUMNS: a step costs a few microseconds of
#: interpreter whatever the width, a (b, b + 1) product 2 (b + 1) flops per number.
CHUNK_STEPS = 16
CHUNK_COLUMNS = 2048


def backward(z, gain, a, overwrite=False):
    """``s_t = z_t + G_t (s_{t+1} - a z_t)``, ``s_T = z_T``; gain per step, (T-1, ...).

    With ``overwrite`` the result replaces ``z`` (step t reads only ``z_t`` and ``s_{t+1}``).
    A scalar gain per step (``gain`` of shape (T-1,)) on a (T, k) array narrower than
    :data:`CHUNK_COLUMNS` is applied :data:`CHUNK_STEPS` steps at a time
    (:func:`_chunk_matrices`): the same linear map, rounded differently.

    Examples
    --------
    >>> z = np.arange(8.0).reshape(4, 2)
    >>> backward(z, np.full(3, 0.5), 1.0)
    array([[1.75, 2.75],
           [3.5 , 4.5 ],
           [5.  , 6.  ],
           [6.  , 7.  ]])
    """
    s = z if overwrite else z.copy()
    first = len(s) - 1  # steps 0 .. first-1 are computed; s_T = z_T
    if gain.ndim == 1 and s.ndim == 2 and s.shape[1] < CHUNK_COLUMNS:
        b = CHUNK_STEPS
        first %= b
        matrices = _chunk_matrices(gain[first:], a, b)[::-1]
        for chunk, M in zip(range(len(s) - 1 - b, first - 1, -b), matrices, strict=True):
            s[chunk : chunk + b] = M @ s[chunk : chunk + b + 1]
    for t in range(first - 1, -1, -1):
        # the same, in place: s_t = (1 - a G_t) z_t + G_t s_{t+1}
        s[t] *= 1 - a * gain[t]
        s[t] += gain[t] * s[t + 1]
    return s


def _chunk_matrices(gain, a, b):
    """The backward pass over chunks of ``b`` steps as matrices, (len(gain) // b, b, b + 1).

    For the chunk of steps ``t0 .. t0+b-1``, ``s[t0:t0+b] = M @ v`` with ``v`` the rows
    ``z_{t0} .. z_{t0+b-1}, s_{t0+b}``: row i of M is ``(1 - a G_i) e_i + G_i M_{i+1}``
    (unrolling ``s_i = (1 - a G_i) z_i + G_i s_{i+1}``), with ``M_b = e_b``.
    """
    G = gain.reshape(-1, b)
    M = np.zeros((len(G), b + 1, b + 1))
    M[:, b, b] = 1.0
    for i in range(b - 1, -1, -1):
        np.multiply(G[:, i, None], M[:, i + 1], out=M[:, i])
        M[:, i, i] = 1 - a * G[:, i]
    return M[:, :b]


def log_det_innovations(s, p_pred):
    """``sum_t log det S~_t`` (...): ``S~_t`` has ``s^2 p_{t|t-1} + 1`` on span U, 1 off it."""
    return np.sum(np.log(s**2 * p_pred + 1), axis=(0, -1))


def log_likelihood(quadratic, log_det_S, rho_sq, log_det_C, n_channels, n_times):
    """The innovation log-likelihood (docs/model.md §2) from the recursions' terms.

    ``sum_t log N(e~_t; 0, S~_t)``: ``-(T m log 2 pi + sum log det S~ + quadratic form of the
    innovations on span U + ||data off span U||^2) / 2``, minus ``T log|det C|`` for the
    whitening.
    """
    T = n_times
    return -0.5 * (T * n_channels * _LOG_2PI + log_det_S + quadratic + rho_sq) - T * log_det_C


class SpectralBasis:
    """Whitening and thin SVD of a lead field: the part of the spectral path set by L and R.

    Parameters
    ----------
    L : ndarray, shape (n_channels, n_sources)
    R : ndarray, shape (n_channels, n_channels)
        SPD noise covariance.

    Attributes
    ----------
    U : ndarray, shape (n_channels, r)
    s : ndarray, shape (r,)
    V : ndarray, shape (n_sources, r)

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> basis = SpectralBasis(rng.standard_normal((6, 9)), np.eye(6))
    >>> Y = rng.standard_normal((6, 5))
    >>> basis.log_likelihood(Y, theta0=[1.0, 2.0], q=[0.1, 0.1]).shape
    (2,)
    """

    def __init__(self, L, R):
        self.n_channels, self.n_sources = L.shape
        self.whiten, self.log_det_C = whitener(R)
        self.U, self.s, self.V = thin_svd(self.whiten(L))

    @property
    def rank(self):
        """int : Numerical rank of the whitened lead field."""
        return len(self.s)

    def project(self, Y):
        """Whitened data in the basis: ``eta = U^T y~`` (T, r) and ``||y~ - U eta||^2``."""
        Yw = self.whiten(Y)
        eta = Yw.T @ self.U
        return eta, float(np.sum((Yw - self.U @ eta.T) ** 2))

    def log_likelihood(self, Y, theta0, q, transition=1.0):
        """The innovation log-likelihood of ``Y`` for each of many priors, no (n, T) array.

        Parameters
        ----------
        Y : ndarray, shape (n_channels, n_times)
        theta0, q : float or array_like, shape (K,)
            Isotropic priors ``P_0 = theta0 I``, ``Q = q I``, K pairs (broadcast).
        transition : float
            ``A = transition I``.

        Returns
        -------
        ndarray, shape (K,), or float for scalar priors
            Equal to ``reconstruct(...).log_likelihood`` at each pair.
        """
        return self._sums(Y, theta0, q, transition)[0]

    def residual_energy(self, Y, theta0, q, transition=1.0):
        r"""The whitened residual of the filtered means, ``sum_t ||C^{-1} (y_t - L x_{t|t})||^2``.

        For each of many priors, with no (n, T) array: on span U the residual is the
        innovation divided by ``s^2 p_{t|t-1} + 1`` (:func:`filter_means`); off span U it is
        the data's own part there, whatever the priors. The discrepancy principle
        (docs/model.md §4) sets it to ``n_channels * n_times``.

        Parameters
        ----------
        Y : ndarray, shape (n_channels, n_times)
        theta0, q : float or array_like, shape (K,)
            Isotropic priors ``P_0 = theta0 I``, ``Q = q I``, K pairs (broadcast).
        transition : float
            ``A = transition I``.

        Returns
        -------
        ndarray, shape (K,), or float for scalar priors

        Examples
        --------
        >>> from skf_ref import reconstruct
        >>> rng = np.random.default_rng(0)
        >>> L, Y = rng.standard_normal((6, 9)), rng.standard_normal((6, 5))
        >>> basis = SpectralBasis(L, np.eye(6))
        >>> rec = reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1, method="dense")
        >>> direct = np.sum((Y - L @ rec.x_filtered) ** 2)
        >>> bool(np.isclose(basis.residual_energy(Y, 1.0, 0.1), direct, rtol=1e-12))
        True
        """
        return self._sums(Y, theta0, q, transition)[1]

    def _sums(self, Y, theta0, q, transition):
        """The log-likelihood and the filtered residual's energy, (K,) each or floats."""
        eta, rho_sq = self.project(Y)
        theta0, q = np.broadcast_arrays(np.asarray(theta0, float), np.asarray(q, float))
        flat_theta0, flat_q = theta0.ravel(), q.ravel()
        out = np.empty((2, len(flat_theta0)))
        for start in range(0, out.shape[1], _PRIORS_AT_ONCE):
            chunk = slice(start, start + _PRIORS_AT_ONCE)
            priors = flat_q[chunk], flat_theta0[chunk]
            p_pred = covariances(self.s, transition, *priors, len(eta))[0]
            _, quadratic, residual = filter_means(self.s, eta, p_pred, transition)
            log_det_S = log_det_innovations(self.s, p_pred)
            out[0, chunk] = log_likelihood(
                quadratic, log_det_S, rho_sq, self.log_det_C, self.n_channels, len(eta)
            )
            out[1, chunk] = residual + rho_sq
        if not np.isfinite(out).all():
            raise InputError(
                "the log-likelihood or the residual is not finite for some priors: they are "
                "out of range at this lead field's scale (largest whitened singular value "
                f"{self.s[0]:.3g})"
            )
        if theta0.ndim:
            return out[0].reshape(theta0.shape), out[1].reshape(theta0.shape)
        return float(out[0, 0]), float(out[1, 0])
