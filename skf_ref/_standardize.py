"""The standardization step of the SKF: the one home of eqs. (6)-(7).

Every path computes the raw weight vector ``w_t = diag(P^{-1/2} K S K^T P^{-1/2})`` its own way
(dense: from the matrices; spectral: from singular values) and then calls :func:`standardize`.
"""

import numpy as np
from scipy import linalg

__all__: list[str] = []


def standardization_weights(w, exponent, out=None):
    """The diagonal of ``W_t^(alpha) = Diag(w_t)^(-alpha)``, eq. (7).

    ``out`` (which may be ``w`` itself) receives the result.

    Examples
    --------
    >>> standardization_weights(np.array([0.25, 4.0]), 0.5).tolist()
    [2.0, 0.5]
    """
    return np.power(w, -exponent, out=out)


def standardize(w, whitened, exponent, out=None, overwrite_w=False):
    """Apply eqs. (7) and (6) to raw weights and whitened means.

    Parameters
    ----------
    w : ndarray, shape (n_sources,) or (n_sources, n_times)
        ``diag(P_{t|t-1}^{-1/2} K_t S_t K_t^T P_{t|t-1}^{-1/2})``.
    whitened : ndarray, same shape as ``w``
        ``P_{t|t-1}^{-1/2} x``.
    exponent : float
        The standardization exponent alpha.
    out : ndarray, optional
        Where to write ``z`` (may be ``whitened`` itself).
    overwrite_w : bool
        Write the weights over ``w`` instead of a new array.

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
    weights = standardization_weights(w, exponent, out=w if overwrite_w else None)
    # z = W_t^(alpha) P^{-1/2} x                                            (6)
    return weights, np.multiply(weights, whitened, out=out)


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

    Examples
    --------
    >>> inverse_sqrt(np.diag([4.0, 0.25])).tolist()
    [[0.5, 0.0], [0.0, 2.0]]
    """
    eigenvalues, eigenvectors = linalg.eigh(P)
    if eigenvalues[0] <= 0:
        raise np.linalg.LinAlgError(
            f"covariance is not positive definite (smallest eigenvalue {eigenvalues[0]:.3g})"
        )
    return (eigenvectors / np.sqrt(eigenvalues)) @ eigenvectors.T
