"""The SKF as a thin subclass of filterpy's ``KalmanFilter``.

filterpy does the predict (4), the update (5) and the RTS smoother; this subclass only adds
the standardization (6)-(7) after each update, from the predicted covariance, gain and
innovation covariance filterpy has just used. filterpy's own ``alpha`` (fading memory)
keeps its meaning; the standardization exponent is ``exponent``.
"""

import numpy as np
from filterpy.kalman import KalmanFilter

from ._standardize import inverse_sqrt, standardize
from ._validation import check_real
from .result import Reconstruction

__all__ = ["StandardizedKalmanFilter", "run"]


class StandardizedKalmanFilter(KalmanFilter):
    """filterpy's Kalman filter plus the SKF standardization after each update.

    Parameters
    ----------
    dim_x : int
        Number of state components (sources).
    dim_z : int
        Number of measurements (channels).
    exponent : float
        Standardization exponent alpha of eq. (7); 0.5 is the original SKF.

    Attributes
    ----------
    weights : ndarray, shape (dim_x,)
        Diagonal of ``W_t^(alpha)`` after the last update.
    raw_weights : ndarray, shape (dim_x,)
        ``w_t = diag(P_{t|t-1}^{-1/2} K_t S_t K_t^T P_{t|t-1}^{-1/2})`` of the last update.
    x_std : ndarray, shape (dim_x,)
        Standardized estimate ``z_{t|t}`` (6) after the last update.
    P_prior_inv_sqrt : ndarray, shape (dim_x, dim_x)
        ``P_{t|t-1}^{-1/2}`` used by the last update.

    Examples
    --------
    With one source and one sensor the standardized estimate is the measurement over the
    prior-predicted standard deviation of the data, sign kept:

    >>> kf = StandardizedKalmanFilter(dim_x=1, dim_z=1, exponent=0.5)
    >>> kf.H[:] = 2.0
    >>> kf.P[:], kf.Q[:], kf.R[:] = 1.0, 0.0, 1.0
    >>> kf.predict()
    >>> kf.update(np.array([3.0]))
    >>> bool(np.isclose(kf.x_std[0], 3.0 / np.sqrt(2.0**2 * 1.0 + 1.0), rtol=1e-15))
    True
    """

    def __init__(self, dim_x, dim_z, exponent=0.5):
        super().__init__(dim_x, dim_z)
        self.exponent = check_real("exponent", exponent, nonnegative=True)
        self.weights = np.full(dim_x, np.nan)
        self.x_std = np.full(dim_x, np.nan)
        self.raw_weights = np.full(dim_x, np.nan)
        self.P_prior_inv_sqrt = np.full((dim_x, dim_x), np.nan)

    def update(self, z, R=None, H=None):
        """filterpy's update (5), then the standardization (6)-(7).

        With ``z=None`` (a missing measurement) filterpy skips the update; the weights and
        the standardized estimate are then undefined and set to NaN.
        """
        P_prior = self.P  # after predict(), self.P is P_{t|t-1}
        super().update(z, R=R, H=H)
        if z is None:
            self.weights = np.full(self.dim_x, np.nan)
            self.x_std = np.full(self.dim_x, np.nan)
            self.raw_weights = np.full(self.dim_x, np.nan)
            return
        self.P_prior_inv_sqrt = inverse_sqrt(P_prior)
        # w_t = diag(P_{t|t-1}^{-1/2} K_t S_t K_t^T P_{t|t-1}^{-1/2})        (7)
        M = self.P_prior_inv_sqrt @ self.K
        w = np.einsum("ij,jk,ik->i", M, self.S, M)
        self.weights, self.x_std = standardize(
            w, self.P_prior_inv_sqrt @ self.x.ravel(), self.exponent
        )
        self.raw_weights = w


def run(L, Y, R, A, Q, P0, exponent, smoother):
    """Run the filterpy subclass over the data, then filterpy's ``rts_smoother`` method.

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
    (m, n), T = L.shape, Y.shape[1]
    kf = StandardizedKalmanFilter(dim_x=n, dim_z=m, exponent=exponent)
    kf.x, kf.P, kf.F, kf.Q, kf.H, kf.R = np.zeros((n, 1)), P0.copy(), A, Q, L, R
    xs, zs, ws, raw = (np.empty((T, n)) for _ in range(4))
    Ps, inv_sqrts = np.empty((T, n, n)), np.empty((T, n, n))
    log_likelihood = 0.0
    for t in range(T):
        kf.predict()
        kf.update(Y[:, t])
        xs[t], zs[t], ws[t], raw[t] = kf.x.ravel(), kf.x_std, kf.weights, kf.raw_weights
        Ps[t], inv_sqrts[t] = kf.P, kf.P_prior_inv_sqrt
        log_likelihood += kf.log_likelihood
    x, z = xs, zs
    if smoother == "rts-standardized":
        # The paper's smoother: filterpy's RTS over the z sequence with the P_{t|t}.
        z = kf.rts_smoother(zs, Ps)[0]
    elif smoother == "rts-state":
        x = kf.rts_smoother(xs, Ps)[0]
        # z^s_t = W_t^(alpha) P_{t|t-1}^{-1/2} x^s_t
        z = standardize(raw, np.einsum("tij,tj->ti", inv_sqrts, x), exponent)[1]
    return Reconstruction(
        z=z.T,
        x=x.T,
        z_filtered=zs.T,
        x_filtered=xs.T,
        weights=ws.T,
        log_likelihood=float(log_likelihood),
        exponent=exponent,
        smoother=smoother,
        method="filterpy",
    )
