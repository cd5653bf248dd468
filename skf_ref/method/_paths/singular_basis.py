r"""The singular basis of the whitened lead field: the part of the spectral path set by L and R.

``skf_ref.method._paths.spectral`` derives, equation by equation, why the filter and both
smoothers of the paper's model (``A = a I``, ``Q = q I``, ``P_0 = theta0 I``) reduce to recursions
on ``r = rank(L)`` numbers per step in the basis of the thin SVD ``L~ = U diag(s) V^T`` of the
whitened lead field. This module holds :class:`SpectralBasis`, the whitening and the SVD, which
depend on ``L`` and ``R`` only (its blocks run on every core:
``skf_ref._utils.threads.map_threads``); the recursions are in
``skf_ref.method._paths.recursions``.

:meth:`SpectralBasis.log_likelihood` and :meth:`SpectralBasis.residual_energy` run the
recursions for arrays of K priors at once: a whole grid of priors (docs/model.md §4) for
about the cost of one filter.
"""

import functools
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import linalg
from scipy.linalg import lapack

from ..._utils.checks import InputError
from ..._utils.threads import map_threads
from .recursions import Recursions

__all__ = ["SpectralBasis", "log_likelihood", "thin_svd", "whitener"]

_LOG_2PI = np.log(2 * np.pi)
# Rows of L~^T in one block of the SVD's first stage (a work item of the worker threads).
_SVD_BLOCK_BYTES = 2 * 2**20
# Reflectors per block of LAPACK's compact WY QR (geqrt's nb).
_QR_PANEL = 64
# Priors evaluated at once by SpectralBasis.log_likelihood: bounds its (T, K, r) arrays.
_PRIORS_AT_ONCE = 16
# Steps of the data whitened and projected at once.
_PROJECT_STEPS = 8192


def whitener(R: NDArray[np.float64]) -> tuple[Callable[[Any], NDArray[np.float64]], float]:
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
    # functions of this module, not lambdas nor scipy's wrappers: a basis is sent to jobs
    # in other processes (skf_ref.io._jobs), which unpickle it
    if np.array_equal(C, C[0, 0] * np.eye(len(C))):
        return functools.partial(_divided, float(C[0, 0])), len(C) * np.log(C[0, 0])
    return functools.partial(_solved, C), np.sum(np.log(np.diag(C)))


def _divided(c: float, M: Any) -> NDArray[np.float64]:
    return M / c


def _solved(C: NDArray[np.float64], M: Any) -> NDArray[np.float64]:
    return linalg.solve_triangular(C, M, lower=True)


def thin_svd(
    Lw: NDArray[np.float64], whiten: Callable[[Any], NDArray[np.float64]] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Thin SVD of the whitened lead field, truncated to its numerical rank.

    Parameters
    ----------
    Lw : ndarray, shape (n_channels, n_sources)
        The whitened lead field, or the lead field itself with ``whiten``.
    whiten : callable, optional
        ``M -> C^{-1} M`` (:func:`whitener`), applied here block of columns by block: no
        whitened copy of the whole lead field is made.

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
    # gemqrt, never formed. The blocks run in worker threads, each LAPACK call on one BLAS
    # thread (scipy's geqrt and gemqrt release the GIL): a busy core slows one worker, not
    # every call, as OpenBLAS's own threads would.
    m, n = Lw.shape
    whiten = (lambda M: M) if whiten is None else whiten
    step = max(2 * m, _SVD_BLOCK_BYTES // (8 * m))
    blocks = [slice(start, min(start + step, n)) for start in range(0, n, step)]

    def factor(rows: slice) -> tuple[Any, Any, NDArray[np.float64]]:
        block = whiten(Lw[:, rows]).T  # A_i, Fortran-ordered as LAPACK uses it
        block = block.copy(order="F") if np.shares_memory(block, Lw) else block
        block = np.asfortranarray(block)
        norms = np.einsum("ij,ij->i", block, block)  # squared norms of L~'s columns
        return (*_qr(block, overwrite=True), norms)

    factors = list(map_threads(factor, blocks))
    stacked = np.vstack([np.triu(reflectors[:m]) for reflectors, _, _ in factors])
    top, T_top = _qr(stacked)
    X, s, Ut = linalg.svd(
        np.triu(top[:m]), full_matrices=False, check_finite=False, lapack_driver="gesdd"
    )
    rank = int(np.sum(s > s[0] * max(m, n) * np.finfo(float).eps))
    U, s = Ut[:rank].T, s[:rank]
    B = _apply_q(top, T_top, X[:, :rank].T).T  # Q' X, one block of rows per block of A
    offsets = np.cumsum([0] + [min(m, rows.stop - rows.start) for rows in blocks])
    V = np.empty((n, rank))

    def fill(i: int) -> None:
        reflectors, T, _ = factors[i]
        _apply_q(reflectors, T, B[offsets[i] : offsets[i + 1]].T, out=V[blocks[i]].T)

    for _ in map_threads(fill, range(len(blocks))):
        pass
    # The SVD gives each row V_j of V to an absolute accuracy of about eps: a column of L~
    # much weaker than the others (||l_j|| << s_1) gets a row of size ~||l_j|| / s and only
    # eps s / ||l_j|| relative accuracy. V_j = l_j^T U diag(1/s) (from L~ = U diag(s) V^T)
    # is as accurate relative to its own size; for ||l_j|| < s_r its absolute error is at
    # most the SVD's, so V stays orthonormal to rounding.
    weak = np.concatenate([norms for _, _, norms in factors]) < s[-1] ** 2
    if weak.any():
        V[weak] = (whiten(Lw[:, weak]).T @ U) / s
    return U, s, V


def _qr(A: NDArray[np.float64], overwrite: bool = False) -> tuple[Any, Any]:
    """QR of ``A`` (k, m) as LAPACK's reflectors and compact WY factor (geqrt); with
    ``overwrite`` the reflectors take the place of a Fortran-ordered ``A``."""
    reflectors, T, _ = lapack.dgeqrt(min(_QR_PANEL, *A.shape), A, overwrite_a=overwrite)
    return reflectors, T


def _apply_q(
    reflectors: NDArray[np.float64],
    T: NDArray[np.float64],
    Ct: NDArray[np.float64],
    out: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
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


def log_likelihood(
    quadratic: ArrayLike,
    log_det_S: ArrayLike,
    rho_sq: float,
    log_det_C: float,
    n_channels: int,
    n_times: int,
) -> Any:
    """The innovation log-likelihood (docs/model.md §2) from the recursions' terms.

    ``sum_t log N(e~_t; 0, S~_t)``: ``-(T m log 2 pi + sum log det S~ + quadratic form of the
    innovations on span U + ||data off span U||^2) / 2``, minus ``T log|det C|`` for the
    whitening, with ``T`` the observed steps (``n_times``; the sums are theirs only).
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

    def __init__(self, L: NDArray[np.float64], R: NDArray[np.float64]) -> None:
        self.n_channels, self.n_sources = L.shape
        self.whiten, self.log_det_C = whitener(R)
        self.U, self.s, self.V = thin_svd(L, self.whiten)

    @property
    def rank(self) -> int:
        """Numerical rank of the whitened lead field (int)."""
        return len(self.s)

    def project(self, Y: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
        """Whitened data in the basis: ``eta = U^T y~`` (T, r) and ``||y~ - U eta||^2``.

        A few thousand steps at a time: no temporary of the data's size. A missing step
        (a column of NaN) gives zeros: it has no measurement to project.

        Parameters
        ----------
        Y : ndarray, shape (n_channels, n_times)
            The data, a column of NaN for a missing step.

        Returns
        -------
        eta : ndarray, shape (n_times, rank)
            The whitened data's coordinates in the basis ``U``.
        rho_sq : float
            The whitened data's energy outside the basis.
        """
        eta = np.empty((Y.shape[1], self.rank))
        rho_sq = 0.0
        for start in range(0, Y.shape[1], _PROJECT_STEPS):
            steps = slice(start, start + _PROJECT_STEPS)
            block = Y[:, steps]
            gaps = np.isnan(block[0])
            Yw = self.whiten(np.where(gaps, 0.0, block) if gaps.any() else block)
            np.matmul(Yw.T, self.U, out=eta[steps])
            rho_sq += float(np.sum((Yw - self.U @ eta[steps].T) ** 2))
        return eta, rho_sq

    def log_likelihood(
        self, Y: NDArray[np.float64], theta0: ArrayLike, q: ArrayLike, transition: Any = 1.0
    ) -> Any:
        """The innovation log-likelihood of ``Y`` for each of many priors, no (n, T) array.

        Parameters
        ----------
        Y : ndarray, shape (n_channels, n_times)
            A column of NaN is a missing step (docs/model.md §2).
        theta0, q : float or array_like, shape (K,)
            Isotropic priors ``P_0 = theta0 I``, ``Q = q I``, K pairs (broadcast).
        transition : float or array_like, shape (K,)
            ``A = transition I``: one for every pair, or one each (the AR(1) prior's).

        Returns
        -------
        ndarray, shape (K,), or float for scalar priors
            Equal to ``reconstruct(...).log_likelihood`` at each pair.
        """
        return self._sums(Y, theta0, q, transition)[0]

    def residual_energy(
        self, Y: NDArray[np.float64], theta0: ArrayLike, q: ArrayLike, transition: Any = 1.0
    ) -> Any:
        r"""The whitened residual of the filtered means, ``sum_t ||C^{-1} (y_t - L x_{t|t})||^2``.

        For each of many priors, with no (n, T) array: on span U the residual is the
        innovation divided by ``s^2 p_{t|t-1} + 1``
        (``Recursions.filter_means``); off span U it is the data's own part there,
        whatever the priors. The discrepancy principle (docs/model.md §4) sets it to
        ``n_channels`` times the observed steps.

        Parameters
        ----------
        Y : ndarray, shape (n_channels, n_times)
            A column of NaN is a missing step (docs/model.md §2), which adds nothing.
        theta0, q : float or array_like, shape (K,)
            Isotropic priors ``P_0 = theta0 I``, ``Q = q I``, K pairs (broadcast).
        transition : float or array_like, shape (K,)
            ``A = transition I``: one for every pair, or one each.

        Returns
        -------
        ndarray, shape (K,), or float for scalar priors

        Examples
        --------
        >>> from skf_ref import reconstruct
        >>> rng = np.random.default_rng(0)
        >>> L, Y = rng.standard_normal((6, 9)), rng.standard_normal((6, 5))
        >>> basis = SpectralBasis(L, np.eye(6))
        >>> rec = reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1, path="dense")
        >>> direct = np.sum((Y - L @ rec.x_filtered) ** 2)
        >>> bool(np.isclose(basis.residual_energy(Y, 1.0, 0.1), direct, rtol=1e-12))
        True
        """
        return self._sums(Y, theta0, q, transition)[1]

    def _sums(
        self, Y: NDArray[np.float64], theta0: ArrayLike, q: ArrayLike, transition: Any
    ) -> tuple[Any, Any]:
        """The log-likelihood and the filtered residual's energy, (K,) each or floats."""
        eta, rho_sq = self.project(Y)
        return self.sums(eta, rho_sq, np.isnan(Y[0]), theta0, q, transition)

    def sums(
        self,
        eta: NDArray[np.float64],
        rho_sq: float,
        missing: NDArray[np.bool_],
        theta0: ArrayLike,
        q: ArrayLike,
        transition: Any = 1.0,
    ) -> tuple[Any, Any]:
        """The log-likelihood and the filtered residual's energy of data projected once.

        What :meth:`log_likelihood` and :meth:`residual_energy` compute, from the data's
        :meth:`project`: a search over many priors (:func:`skf_ref.tune`) projects the data
        once and runs only the rank-r recursions for each batch of priors.

        Parameters
        ----------
        eta : ndarray, shape (n_times, rank)
        rho_sq : float
            :meth:`project`'s answer for the data.
        missing : ndarray of bool, shape (n_times,)
            The data's missing steps (columns of NaN).
        theta0, q : float or array_like, shape (K,)
        transition : float or array_like, shape (K,)
            As for :meth:`log_likelihood`.

        Returns
        -------
        log_likelihood, residual_energy : ndarray, shape (K,), or float for scalar priors

        Examples
        --------
        >>> rng = np.random.default_rng(0)
        >>> basis = SpectralBasis(rng.standard_normal((6, 9)), np.eye(6))
        >>> Y = rng.standard_normal((6, 5))
        >>> eta, rho_sq = basis.project(Y)
        >>> ll, _ = basis.sums(eta, rho_sq, np.zeros(5, bool), [1.0, 2.0], 0.1, [1.0, 0.5])
        >>> bool(ll[1] == basis.log_likelihood(Y, 2.0, 0.1, 0.5))
        True
        """
        theta0, q = np.broadcast_arrays(np.asarray(theta0, float), np.asarray(q, float))
        if np.ndim(transition):  # one transition per prior: broadcast with them
            theta0, q, transition = np.broadcast_arrays(theta0, q, np.asarray(transition, float))
        flat_theta0, flat_q = theta0.ravel(), q.ravel()
        out = np.empty((2, len(flat_theta0)))
        for start in range(0, out.shape[1], _PRIORS_AT_ONCE):
            chunk = slice(start, start + _PRIORS_AT_ONCE)
            a = transition if np.ndim(transition) == 0 else transition.ravel()[chunk]
            recursions = Recursions(
                self.s, a, flat_q[chunk], flat_theta0[chunk], len(eta), missing=missing
            )
            _, quadratic, residual = recursions.filter_means(eta)
            log_det_S = recursions.log_det_innovations()
            out[0, chunk] = log_likelihood(
                quadratic,
                log_det_S,
                rho_sq,
                self.log_det_C,
                self.n_channels,
                recursions.n_observed,
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
