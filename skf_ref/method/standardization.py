"""The standardization step of the SKF: the one home of §2.2 eqs. (6)-(7) (docs/model.md §2).

The raw weights ``w_t = diag(P^{-1/2} K S K^T P^{-1/2})`` come from the matrices in
:func:`raw_weights` (the dense path and the filterpy subclass) or from singular values (the
spectral path); every path then calls :func:`standardize`. :func:`restandardize` is the
standardization of a smoothed state for ``"rts-state"`` (docs/model.md §3).
"""

import numpy as np
from scipy import linalg

__all__ = [
    "inverse_sqrt",
    "overflow_cause",
    "raw_weights",
    "restandardize",
    "standardization_weights",
    "standardize",
    "standardized_means",
]


def raw_weights(P_pred_inv_sqrt, K, S):
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


def standardization_weights(w, exponent, out=None):
    """The diagonal of ``W_t^(alpha) = Diag(w_t)^(-alpha)``, §2.2 eq. (7).

    ``out`` (which may be ``w`` itself) receives the result. An overflow gives ``inf``
    without a warning; the result type refuses it with the cause (:func:`overflow_cause`).

    Examples
    --------
    >>> standardization_weights(np.array([0.25, 4.0]), 0.5).tolist()
    [2.0, 0.5]
    >>> w = np.array([0.3, 0.7])
    >>> bool(np.allclose(standardization_weights(w, 1.25), w**-1.25, rtol=1e-15))
    True
    """
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        return np.reciprocal(_power(w, exponent), out=out)


def standardize(w, whitened, exponent, out=None):
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
    power = _power(w, exponent)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        # z = W_t^(alpha) P^{-1/2} x = P^{-1/2} x / w_t^alpha                (6)
        z = np.divide(whitened, power, out=out)
        # W_t^(alpha) = Diag(w_t)^(-alpha)                                 (7)
        return np.reciprocal(power, out=power), z


def standardized_means(w, whitened, exponent, out=None):
    """``z`` of :func:`standardize` without the weights: one pass fewer over the arrays.

    Examples
    --------
    >>> standardized_means(np.array([0.25, 1.0]), np.array([1.0, 2.0]), 0.5).tolist()
    [2.0, 2.0]
    """
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        return np.divide(whitened, _power(w, exponent), out=out)  # (6)


def _power(w, exponent):
    """``w ** exponent`` in a new array.

    Exponents that are multiples of 1/4 up to 4 (0.5, 1, 1.25, 1.5, the paper's) are
    computed from square roots and products, ``w^(k + j/4) = w^k (w^(1/4))^j``: a few
    roundings, 1e-16 relative, and several times faster than ``pow`` on the n x T weights.
    """
    quarters = 4 * exponent
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        if quarters != round(quarters) or quarters > 16:
            return np.power(w, exponent)
        whole, fourths = divmod(round(quarters), 4)
        # w^(fourths / 4) * w^whole, from square roots and products in one array: a second
        # temporary as large as w costs more in page faults than all the arithmetic
        power = np.sqrt(w) if fourths else np.ones_like(w)
        if fourths in (1, 3):
            np.sqrt(power, out=power)  # w^(1/4)
        if fourths == 3:
            np.divide(w, power, out=power)  # w^(3/4) = w / w^(1/4)
        for _ in range(whole):
            np.multiply(power, w, out=power)
        return power


def overflow_cause(w_min, exponent):
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


def restandardize(w, P_pred_inv_sqrt, x, exponent):
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


def inverse_sqrt(P):
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
