"""The standardization step of the SKF: the one home of §2.2 eqs. (6)-(7) (docs/model.md §2).

The raw weights ``w_t = diag(P^{-1/2} K S K^T P^{-1/2})`` come from the matrices in
:func:`raw_weights` (the dense path and the filterpy subclass) or from singular values (the
spectral path); every path then calls :func:`standardize`. :func:`restandardize` is the
standardization of a smoothed state for ``"rts-state"`` (docs/model.md §3).
"""

import numpy as np
from numpy.typing import NDArray
from scipy import linalg

_Array = NDArray[np.float64]

__all__ = [
    "inverse_sqrt",
    "overflow_cause",
    "raw_weights",
    "restandardize",
    "standardization_weights",
    "standardize",
    "standardized_means",
]


def raw_weights(P_pred_inv_sqrt: _Array, K: _Array, S: _Array) -> _Array:
    """The raw weights of §2.2 eq. (7) from the filter's matrices.

    Parameters
    ----------
    P_pred_inv_sqrt : ndarray, shape (n_sources, n_sources)
        ``P_{t|t-1}^{-1/2}``.
    K : ndarray, shape (n_sources, n_channels)
        Kalman gain ``K_t``.
    S : ndarray, shape (n_channels, n_channels)
        Innovation covariance ``S_t``.

    Returns
    -------
    ndarray, shape (n_sources,)
        ``w_t = diag(P_{t|t-1}^{-1/2} K_t S_t K_t^T P_{t|t-1}^{-1/2})``.

    Examples
    --------
    >>> raw_weights(np.eye(2), np.array([[1.0], [2.0]]), np.array([[3.0]])).tolist()
    [3.0, 12.0]
    """
    # w_t = diag(P_{t|t-1}^{-1/2} K_t S_t K_t^T P_{t|t-1}^{-1/2})           (7)
    M = P_pred_inv_sqrt @ K
    return np.einsum("ij,jk,ik->i", M, S, M)


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


def restandardize(w: _Array, P_pred_inv_sqrt: _Array, x: _Array, exponent: float) -> _Array:
    """Standardize a smoothed state with the filter's own weights (``"rts-state"``).

    ``z^s_t = W_t^(alpha) P_{t|t-1}^{-1/2} x^s_t`` (docs/model.md §3).

    Parameters
    ----------
    w : ndarray, shape (n_times, n_sources)
        The filter's raw weights ``w_t``.
    P_pred_inv_sqrt : ndarray, shape (n_times, n_sources, n_sources)
        ``P_{t|t-1}^{-1/2}`` of every step.
    x : ndarray, shape (n_times, n_sources)
        Smoothed state ``x^s_t``.
    exponent : float

    Returns
    -------
    ndarray, shape (n_times, n_sources)

    Examples
    --------
    >>> restandardize(np.array([[4.0]]), np.array([[[0.5]]]), np.array([[6.0]]), 0.5)
    array([[1.5]])
    """
    return standardize(w, np.einsum("tij,tj->ti", P_pred_inv_sqrt, x), exponent)[1]


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
