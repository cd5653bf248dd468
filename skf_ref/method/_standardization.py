"""The standardization step of the SKF, §2.2 eqs. (6)-(7) (docs/model.md §2): shared parts.

The dense path and the filterpy subclass state eqs. (6)-(7) in their own lines; they share
:func:`inverse_sqrt` (``P_{t|t-1}^{-1/2}``), :func:`diagonal_blocks` and :func:`apply_blocks`
(the standardization per position, docs/model.md §2), :func:`restandardize_blocks` (the
smoothed state of ``"rts-state"``) and :func:`standardize_smoothed` (the smoothed state over
its own variance, ``"rts-smoothed-weights"``, docs/model.md §3). The spectral path computes
the raw weights from singular values and applies :func:`standardization_weights`, ``w **
-alpha`` in its fastest exact form; :func:`standardize` is that with eq. (6).
"""

import numpy as np
from numpy.typing import NDArray
from scipy import linalg

from .._utils.checks import InputError
from ._powers import block_power

_Array = NDArray[np.float64]

__all__ = [
    "apply_blocks",
    "block_diagonal",
    "check_positions_seen",
    "diagonal_blocks",
    "inverse_sqrt",
    "overflow_cause",
    "restandardize_blocks",
    "standardization_weights",
    "standardize",
    "standardize_smoothed",
    "standardized_means",
    "weight_blocks",
]


def standardization_weights(w: _Array, exponent: float, out: _Array | None = None) -> _Array:
    """The diagonal of ``W_t^(alpha) = Diag(w_t)^(-alpha)``, §2.2 eq. (7).

    ``out`` (which may be ``w`` itself) receives the result. An overflow gives ``inf``
    without a warning; the result type refuses it with the cause (:func:`overflow_cause`).

    ``w ** -alpha`` in its fastest exact form, measured on (1000, 150 000) arrays on one
    core: ``exp(-alpha log w)`` in place (0.30 s; relative error ``eps (2 + alpha |log w|)``,
    3e-15 for w >= 1e-6 and alpha = 1.25) against ``numpy.power`` (0.44 s) and a chain of
    square roots (0.53 s at 1.25); ``1 / sqrt(w)`` for 0.5, ``1 / w`` and ``1 / w^2`` for 1
    and 2 (one or two roundings).

    Examples
    --------
    >>> standardization_weights(np.array([0.25, 4.0]), 0.5).tolist()
    [2.0, 0.5]
    >>> w = np.array([0.3, 0.7])
    >>> bool(np.allclose(standardization_weights(w, 1.25), w**-1.25, rtol=1e-15))
    True
    """
    out = np.empty_like(w, dtype=float) if out is None else out
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        if exponent == 0:  # 1, NaN kept (a missing step has no weights)
            np.add(np.multiply(w, 0.0, out=out), 1.0, out=out)
        elif exponent == 0.5:
            np.reciprocal(np.sqrt(w, out=out), out=out)
        elif exponent == 1:
            np.reciprocal(w, out=out)
        elif exponent == 2:
            np.reciprocal(np.square(w, out=out), out=out)
        else:
            np.exp(np.multiply(np.log(w, out=out), -exponent, out=out), out=out)
    return out


def standardize(
    w: _Array, whitened: _Array, exponent: float, out: _Array | None = None
) -> tuple[_Array, _Array]:
    """Apply §2.2 eqs. (7) and (6) to raw weights and whitened means.

    Parameters
    ----------
    w : ndarray, shape (n_sources,) or (..., n_sources)
        ``diag(P_{t|t-1}^{-1/2} K_t S_t K_t^T P_{t|t-1}^{-1/2})``.
    whitened : ndarray, same shape as ``w``
        ``P_{t|t-1}^{-1/2} x``.
    exponent : float
        The standardization exponent alpha.
    out : ndarray, optional
        Where to write ``z`` (may be ``whitened`` itself).

    Returns
    -------
    weights : ndarray, same shape as ``w``
        The diagonal of ``W_t^(alpha) = Diag(w_t ** -alpha)`` (7).
    z : ndarray, same shape as ``w``
        ``W_t^(alpha) P_{t|t-1}^{-1/2} x`` (6).

    Examples
    --------
    >>> weights, z = standardize(np.array([0.25, 1.0]), np.array([1.0, 2.0]), 0.5)
    >>> weights.tolist(), z.tolist()
    ([2.0, 1.0], [2.0, 2.0])
    """
    # W_t^(alpha) = Diag(w_t)^(-alpha)                                     (7)
    weights = standardization_weights(w, exponent)
    with np.errstate(over="ignore", invalid="ignore"):
        # z = W_t^(alpha) P^{-1/2} x                                       (6)
        return weights, np.multiply(whitened, weights, out=out)


def standardized_means(
    w: _Array, whitened: _Array, exponent: float, out: _Array | None = None
) -> _Array:
    """``z`` of :func:`standardize` alone.

    Examples
    --------
    >>> standardized_means(np.array([0.25, 1.0]), np.array([1.0, 2.0]), 0.5).tolist()
    [2.0, 2.0]
    """
    return standardize(w, whitened, exponent, out=out)[1]


def overflow_cause(w_min: float, exponent: float) -> str:
    """Why ``W_t = w_t^-exponent`` (7) or ``z`` overflowed, from the smallest raw weight.

    Parameters
    ----------
    w_min : float
        The smallest raw weight ``w_t`` of the run.
    exponent : float

    Returns
    -------
    str

    Examples
    --------
    >>> print(overflow_cause(1e-20, 1e3))
    exponent=1000 is too large for these weights: w_t reaches 1e-20 and w_t**-exponent
    overflows above exponent 15.4
    """
    if not w_min > 0:
        return (
            f"the raw weights w_t of eq. (7) reach {w_min:.3g}: in double precision the lead "
            "field is too weak against the noise at these priors (rescale L or the noise, "
            "e.g. to other units), or the covariances are too ill-conditioned"
        )
    limit = np.log(np.finfo(float).max) / -np.log(w_min) if w_min < 1 else np.inf
    if exponent > limit:
        return (
            f"exponent={exponent:g} is too large for these weights: w_t reaches {w_min:.3g} "
            f"and w_t**-exponent overflows above exponent {limit:.3g}"
        )
    return (
        "the scales of Y, L, the noise and the priors are out of the range of double "
        "precision: rescale them (e.g. to other units)"
    )


def inverse_sqrt(P: _Array) -> _Array:
    """Symmetric inverse square root ``P^{-1/2}`` of an SPD matrix, by ``eigh``.

    Parameters
    ----------
    P : ndarray, shape (n, n)
        Symmetric positive definite.

    Returns
    -------
    ndarray, shape (n, n)
        Symmetric ``M`` with ``M @ P @ M = I``.

    Raises
    ------
    numpy.linalg.LinAlgError
        If ``P`` has an eigenvalue <= 0.

    Examples
    --------
    >>> inverse_sqrt(np.diag([4.0, 0.25])).tolist()
    [[0.5, 0.0], [0.0, 2.0]]
    """
    eigenvalues, eigenvectors = linalg.eigh(P)
    if not eigenvalues[0] > 0:
        raise np.linalg.LinAlgError(
            "P_t|t-1 is not positive definite in double precision (eigenvalues from "
            f"{eigenvalues[0]:.3g} to {eigenvalues[-1]:.3g})"
        )
    return (eigenvectors / np.sqrt(eigenvalues)) @ eigenvectors.T


# --- standardization per position (docs/model.md §2) -------------------------------------


#: A position whose columns of the whitened lead field have a Gram matrix with an
#: eigenvalue below this fraction of its largest is not seen in every orientation: its
#: block is singular to double precision (rounding alone leaves about eps there).
POSITION_RCOND = 1e-12


def check_positions_seen(L: _Array, R: _Array, n_orient: int, what: str = "L") -> None:
    """Refuse the standardization per position where a position's block is singular.

    With isotropic priors (``P_{t|t-1} = p I`` at the first step) ``B_1(i)`` is singular
    exactly when the ``n_orient`` columns of the whitened lead field ``C^{-1} L`` at
    position ``i`` (``R = C C^T``) are linearly dependent: the sensors do not see every
    orientation there (MEG's radial orientation in a spherical head; fewer independent
    channels than orientations). Its power ``B^(-alpha)`` is then undefined.

    Parameters
    ----------
    L : ndarray, shape (n_channels, n_sources)
    R : ndarray, shape (n_channels, n_channels)
    n_orient : int
    what : str
        How to name the lead field in the error.

    Raises
    ------
    skf_ref.InputError
        Naming the first such position and its columns.

    Examples
    --------
    >>> L = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])  # 3 orientations, 2 channels
    >>> check_positions_seen(L, np.eye(2), 3)
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: standardize='position' needs every orientation of a \
position seen by the sensors: position 0 (columns 0-2 of L) has a singular block, rank 2 < 3 \
orientations ...
    """
    if n_orient == 1:
        return
    Lw = linalg.solve_triangular(linalg.cholesky(R, lower=True), L, lower=True)
    columns = Lw.T.reshape(-1, n_orient, Lw.shape[0])
    gram = columns @ np.swapaxes(columns, 1, 2)  # (positions, k, k)
    eigenvalues = np.linalg.eigvalsh(gram)
    singular = np.flatnonzero(~(eigenvalues[:, 0] > POSITION_RCOND * eigenvalues[:, -1]))
    if len(singular):
        i = int(singular[0])
        values = eigenvalues[i]
        rank = int(np.count_nonzero(values > POSITION_RCOND * values[-1]))
        whole = int(np.linalg.matrix_rank(Lw))  # only here, to say why
        if whole < n_orient:
            cause = (
                f"{what}, whitened, has rank {whole} ({Lw.shape[0]} rows; a reference and the "
                "noise covariance's projections each take one away): with fewer than "
                f"{n_orient}, no position's {n_orient} orientations can be told apart; give "
                "more channels"
            )
        else:
            cause = (
                "the sensors do not see one orientation of it (as MEG the radial one, in a "
                "spherical head)"
            )
        raise InputError(
            "standardize='position' needs every orientation of a position seen by the "
            f"sensors: position {i} (columns {n_orient * i}-{n_orient * i + n_orient - 1} of "
            f"{what}) has a singular block, rank {rank} < {n_orient} orientations "
            f"({len(singular)} such positions; condition number over "
            f"{1 / POSITION_RCOND:.0e}): {cause}; or use standardize='column', or fixed "
            "orientation"
        )


def diagonal_blocks(M: _Array, k: int) -> _Array:
    """The ``k x k`` diagonal blocks of a square matrix, (n // k, k, k).

    Examples
    --------
    >>> diagonal_blocks(np.arange(16.0).reshape(4, 4), 2).tolist()
    [[[0.0, 1.0], [4.0, 5.0]], [[10.0, 11.0], [14.0, 15.0]]]
    """
    n = len(M) // k
    blocks = M.reshape(n, k, n, k)
    return np.ascontiguousarray(blocks[np.arange(n), :, np.arange(n), :])


def weight_blocks(B: _Array, exponent: float) -> _Array:
    """``W_t^(alpha)`` block by block: ``B_t(i)^(-alpha)`` (docs/model.md §2).

    Parameters
    ----------
    B : ndarray, shape (..., k, k)
        Symmetric positive definite blocks; blocks of one are the raw weights ``w_t``.
    exponent : float

    Returns
    -------
    ndarray, shape (..., k, k)
        The blocks' powers through their eigendecomposition; for ``k = 1`` the diagonal
        weights ``w_t ** -alpha`` of §2.2 eq. (7).

    Examples
    --------
    >>> weight_blocks(np.array([[[0.25]], [[4.0]]]), 0.5).ravel().tolist()
    [2.0, 0.5]
    """
    if B.shape[-1] == 1:
        with np.errstate(over="ignore", divide="ignore"):  # the result refuses inf, with why
            # W_t^(alpha) = Diag(w_t)^(-alpha)                             §2.2 (7)
            return B**-exponent
    # W_t^(alpha) = blockdiag_i B_t(i)^(-alpha), by eigh          docs/model.md §2
    return block_power(B, exponent)


def apply_blocks(W: _Array, v: _Array) -> _Array:
    """``W v`` for a block-diagonal ``W`` given by its blocks: ``z = W_t^(alpha) v``.

    Parameters
    ----------
    W : ndarray, shape (..., n // k, k, k)
    v : ndarray, shape (..., n)

    Returns
    -------
    ndarray, shape (..., n)

    Examples
    --------
    >>> apply_blocks(np.array([[[2.0, 1.0], [1.0, 2.0]]]), np.array([1.0, 1.0])).tolist()
    [3.0, 3.0]
    """
    k = W.shape[-1]
    with np.errstate(over="ignore", invalid="ignore"):
        if k == 1:  # a diagonal W: z = W_t^(alpha) v, elementwise          §2.2 (6)
            return np.multiply(v, W.reshape(v.shape))
        blocks = v.reshape(*v.shape[:-1], -1, k)
        return np.einsum("...ij,...j->...i", W, blocks).reshape(v.shape)


def block_diagonal(W: _Array) -> _Array:
    """The diagonal of a block-diagonal matrix given by its blocks, (..., n).

    Examples
    --------
    >>> block_diagonal(np.array([[[2.0, 1.0], [1.0, 3.0]], [[4.0, 0.0], [0.0, 5.0]]])).tolist()
    [2.0, 3.0, 4.0, 5.0]
    """
    diagonal = np.diagonal(W, axis1=-2, axis2=-1)
    return diagonal.reshape(*diagonal.shape[:-2], -1)


def restandardize_blocks(W: _Array, P_pred_inv_sqrt: _Array, x: _Array) -> _Array:
    """Standardize a smoothed state with the filter's own weight blocks (``"rts-state"``).

    ``z^s_t = W_t^(alpha) P_{t|t-1}^{-1/2} x^s_t`` (docs/model.md §3), for a
    block-diagonal ``W_t^(alpha)`` (a diagonal one: blocks of one).

    Parameters
    ----------
    W : ndarray, shape (n_times, n_sources // k, k, k)
        The filter's ``W_t^(alpha)`` blocks (:func:`weight_blocks`).
    P_pred_inv_sqrt : ndarray, shape (n_times, n_sources, n_sources)
    x : ndarray, shape (n_times, n_sources)

    Returns
    -------
    ndarray, shape (n_times, n_sources)

    Examples
    --------
    >>> restandardize_blocks(np.array([[[[0.5]]]]), np.array([[[0.5]]]), np.array([[6.0]]))
    array([[1.5]])
    """
    return apply_blocks(W, np.einsum("tij,tj->ti", P_pred_inv_sqrt, x))


def standardize_smoothed(
    x_smoothed: _Array, P_smoothed: _Array, Sigma: _Array, exponent: float, n_orient: int
) -> _Array:
    """The smoothed state over its own variance, ``"rts-smoothed-weights"`` (docs/model.md §3).

    ``Psi^s_t = Sigma_t^{-1/2} (Sigma_t - P^s_t) Sigma_t^{-1/2}`` is the covariance, under
    the model, of the whitened smoothed state ``Sigma_t^{-1/2} x^s_t``; its diagonal (or its
    blocks, ``n_orient`` > 1) to the power ``-alpha`` standardize it:
    ``z^s_t = W^s_t Sigma_t^{-1/2} x^s_t``.

    Parameters
    ----------
    x_smoothed : ndarray, shape (n_times, n_sources)
        ``x^s_t``.
    P_smoothed : ndarray, shape (n_times, n_sources, n_sources)
        ``P^s_t`` from the RTS covariance recursion (§2.3 eq. (4)).
    Sigma : ndarray, shape (n_times, n_sources, n_sources)
        The prior covariance of ``x_t``: ``Sigma_t = A Sigma_{t-1} A^T + Q``,
        ``Sigma_0 = P_0``, for ``t = 1 .. T``.
    exponent : float
    n_orient : int
        Columns standardized together (1: each on its own).

    Returns
    -------
    ndarray, shape (n_times, n_sources)
        ``z^s_t``.

    Examples
    --------
    One source, one step: ``Sigma = 4``, ``P^s = 3``, so ``x^s`` has variance 1 under the
    model and at ``alpha = 1/2`` is its own z-score:

    >>> standardize_smoothed(np.array([[2.0]]), np.array([[[3.0]]]), np.array([[[4.0]]]),
    ...                      0.5, 1).tolist()
    [[2.0]]
    """
    z = np.empty_like(x_smoothed)
    for t in range(len(z)):
        Sigma_inv_sqrt = inverse_sqrt(Sigma[t])
        # Psi^s_t = Sigma_t^{-1/2} (Sigma_t - P^s_t) Sigma_t^{-1/2}      docs/model.md §3
        Psi = Sigma_inv_sqrt @ (Sigma[t] - P_smoothed[t]) @ Sigma_inv_sqrt
        # W^s_t = its diagonal (or blocks) to the power -alpha
        W = weight_blocks(diagonal_blocks((Psi + Psi.T) / 2, n_orient), exponent)
        # z^s_t = W^s_t Sigma_t^{-1/2} x^s_t
        z[t] = apply_blocks(W, Sigma_inv_sqrt @ x_smoothed[t])
    return z
