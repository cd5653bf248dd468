"""The SKF and its smoothers in plain numpy: the readable statement of the algorithm.

One loop, one equation a line, equation numbers of shared/SKF_SPEC.md (the paper's). This
module is the oracle: every other path (the filterpy subclass, the spectral path) is
compared against it. It stores every covariance, so it costs O(n^3) per step and
O(T n^2) memory.

Symbols: ``L`` lead field (m, n), ``R`` noise covariance (m, m), ``A`` transition (n, n),
``Q`` process covariance (n, n), ``P0`` initial covariance (n, n). Internally time runs
along the first axis, (T, n); the public result is (n, T).
"""

import numpy as np
from scipy import linalg

from ._standardize import inverse_sqrt, standardize
from .result import Reconstruction

__all__ = ["run", "kalman_filter", "smooth_standardized", "smooth_state"]

_LOG_2PI = np.log(2 * np.pi)


def _predict(x, P, A, Q):
    # x_{t|t-1} = A x_{t-1|t-1}                                             (4)
    x_pred = A @ x
    # P_{t|t-1} = A P_{t-1|t-1} A^T + Q                                    (4)
    P_pred = A @ P @ A.T + Q
    return x_pred, (P_pred + P_pred.T) / 2


def _update(x_pred, P_pred, y, L, R):
    # S_t = L P_{t|t-1} L^T + R                                             (5)
    S = L @ P_pred @ L.T + R
    S_chol = linalg.cho_factor(S, lower=True)
    # K_t = P_{t|t-1} L^T S_t^{-1}   (a solve with S, never its inverse)   (5)
    K = linalg.cho_solve(S_chol, L @ P_pred).T
    # e_t = y_t - L x_{t|t-1}
    e = y - L @ x_pred
    # x_{t|t} = x_{t|t-1} + K_t e_t                                         (5)
    x = x_pred + K @ e
    # P_{t|t} = P_{t|t-1} - K_t S_t K_t^T                                   (5)
    P = P_pred - K @ S @ K.T
    # log N(e_t; 0, S_t) = -(m log 2 pi + log det S_t + e^T S_t^{-1} e) / 2
    log_det = 2 * np.sum(np.log(np.diag(S_chol[0])))
    log_likelihood = -0.5 * (len(y) * _LOG_2PI + log_det + e @ linalg.cho_solve(S_chol, e))
    return x, (P + P.T) / 2, K, S, log_likelihood


def _raw_weights(P_pred_inv_sqrt, K, S):
    # w_t = diag(P_{t|t-1}^{-1/2} K_t S_t K_t^T P_{t|t-1}^{-1/2})           (7)
    M = P_pred_inv_sqrt @ K
    return np.einsum("ij,jk,ik->i", M, S, M)


def kalman_filter(L, Y, R, A, Q, P0, exponent):
    """Run the SKF forward pass (eqs. 4-7), keeping every mean and covariance.

    Parameters
    ----------
    L : ndarray, shape (n_channels, n_sources)
    Y : ndarray, shape (n_channels, n_times)
    R : ndarray, shape (n_channels, n_channels)
    A, Q, P0 : ndarray, shape (n_sources, n_sources)
    exponent : float

    Returns
    -------
    dict
        ``x_filt``, ``x_pred``, ``z``, raw weights ``w`` and ``weights`` (the diagonal of
        ``W_t^(alpha)``) of shape (n_times, n_sources);
        ``P_filt``, ``P_pred``, ``P_pred_inv_sqrt`` of shape (n_times, n_sources, n_sources);
        ``log_likelihood`` (float).
    """
    n, T = L.shape[1], Y.shape[1]
    out = {key: np.empty((T, n)) for key in ("x_filt", "x_pred", "z", "w", "weights")}
    for key in ("P_filt", "P_pred", "P_pred_inv_sqrt"):
        out[key] = np.empty((T, n, n))
    x, P, total = np.zeros(n), P0, 0.0
    for t in range(T):
        x_pred, P_pred = _predict(x, P, A, Q)
        x, P, K, S, log_likelihood = _update(x_pred, P_pred, Y[:, t], L, R)
        P_pred_inv_sqrt = inverse_sqrt(P_pred)
        w = _raw_weights(P_pred_inv_sqrt, K, S)
        weights, z = standardize(w, P_pred_inv_sqrt @ x, exponent)
        total += log_likelihood
        out["x_filt"][t], out["x_pred"][t], out["z"][t] = x, x_pred, z
        out["w"][t], out["weights"][t] = w, weights
        out["P_filt"][t], out["P_pred"][t], out["P_pred_inv_sqrt"][t] = P, P_pred, P_pred_inv_sqrt
    out["log_likelihood"] = total
    return out


def _smoother_gain(P_filt, P_pred_next, A):
    # G_t = P_{t|t} A^T P_{t+1|t}^{-1}  (a solve: P_{t+1|t} G_t^T = A P_{t|t})   (3)
    return linalg.solve(P_pred_next, A @ P_filt, assume_a="pos").T


def smooth_standardized(z, P_filt, P_pred, A):
    """The paper's RTS smoother over the standardized sequence (``"rts-standardized"``).

    ``s_T = z_{T|T}``;  ``s_t = z_{t|t} + G_t (s_{t+1} - A z_{t|t})``.

    Parameters
    ----------
    z : ndarray, shape (n_times, n_sources)
    P_filt, P_pred : ndarray, shape (n_times, n_sources, n_sources)
        ``P_{t|t}`` and ``P_{t|t-1}``; ``P_pred[t + 1]`` is ``P_{t+1|t}``.
    A : ndarray, shape (n_sources, n_sources)

    Returns
    -------
    ndarray, shape (n_times, n_sources)
    """
    s = z.copy()
    for t in range(len(z) - 2, -1, -1):
        G = _smoother_gain(P_filt[t], P_pred[t + 1], A)
        # s_t = z_{t|t} + G_t (s_{t+1} - A z_{t|t})
        s[t] = z[t] + G @ (s[t + 1] - A @ z[t])
    return s


def smooth_state(x_filt, x_pred, P_filt, P_pred, A):
    """The textbook RTS smoother on the state (``"rts-state"``), eq. (4) of the paper's §2.3.

    ``x^s_T = x_{T|T}``;  ``x^s_t = x_{t|t} + G_t (x^s_{t+1} - x_{t+1|t})``.

    Parameters
    ----------
    x_filt, x_pred : ndarray, shape (n_times, n_sources)
    P_filt, P_pred : ndarray, shape (n_times, n_sources, n_sources)
    A : ndarray, shape (n_sources, n_sources)

    Returns
    -------
    ndarray, shape (n_times, n_sources)
    """
    xs = x_filt.copy()
    for t in range(len(x_filt) - 2, -1, -1):
        G = _smoother_gain(P_filt[t], P_pred[t + 1], A)
        # x^s_t = x_{t|t} + G_t (x^s_{t+1} - x_{t+1|t})
        xs[t] = x_filt[t] + G @ (xs[t + 1] - x_pred[t + 1])
    return xs


def run(L, Y, R, A, Q, P0, exponent, smoother):
    """Filter, optionally smooth, and package the result.

    Parameters
    ----------
    L : ndarray, shape (n_channels, n_sources)
    Y : ndarray, shape (n_channels, n_times)
    R : ndarray, shape (n_channels, n_channels)
    A, Q, P0 : ndarray, shape (n_sources, n_sources)
    exponent : float
    smoother : {None, "rts-standardized", "rts-state"}

    Returns
    -------
    Reconstruction
    """
    f = kalman_filter(L, Y, R, A, Q, P0, exponent)
    x, z = f["x_filt"], f["z"]
    if smoother == "rts-standardized":
        z = smooth_standardized(f["z"], f["P_filt"], f["P_pred"], A)
    elif smoother == "rts-state":
        x = smooth_state(f["x_filt"], f["x_pred"], f["P_filt"], f["P_pred"], A)
        # z^s_t = W_t^(alpha) P_{t|t-1}^{-1/2} x^s_t
        z = standardize(f["w"], np.einsum("tij,tj->ti", f["P_pred_inv_sqrt"], x), exponent)[1]
    return Reconstruction(
        z=z.T,
        x=x.T,
        z_filtered=f["z"].T,
        x_filtered=f["x_filt"].T,
        weights=f["weights"].T,
        log_likelihood=float(f["log_likelihood"]),
        exponent=exponent,
        smoother=smoother,
        method="dense",
    )
