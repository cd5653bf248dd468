"""The SKF as a thin subclass of filterpy's ``KalmanFilter``.

filterpy does the predict (§2.2 eq. 4), the update (§2.2 eq. 5) and the RTS smoother
(§2.3 eq. 4); this subclass only adds the standardization, §2.2 eqs. (6)-(7), after each
update, from the predicted covariance, gain and innovation covariance filterpy has just used.
filterpy's own ``alpha`` (fading memory) keeps its meaning; the standardization exponent is
``exponent``.
"""

from typing import Any

import numpy as np
from filterpy.kalman import KalmanFilter
from numpy.typing import ArrayLike, NDArray

from ..._utils.checks import check_int, check_real
from .._model import StateSpaceModel
from .._result import Reconstruction
from .._standardization import inverse_sqrt, raw_weights, restandardize, standardize
from .dense import result

__all__ = ["StandardizedKalmanFilter", "run"]


class StandardizedKalmanFilter(KalmanFilter):
    """The Kalman filter of filterpy, plus the SKF standardization after each update.

    Parameters
    ----------
    dim_x : int
        Number of state components (sources).
    dim_z : int
        Number of measurements (channels).
    exponent : float
        Standardization exponent alpha of §2.2 eq. (7); 0.5 is the original SKF.

    Attributes
    ----------
    weights : ndarray, shape (dim_x,)
        Diagonal of ``W_t^(alpha)`` after the last update.
    raw_weights : ndarray, shape (dim_x,)
        ``w_t = diag(P_{t|t-1}^{-1/2} K_t S_t K_t^T P_{t|t-1}^{-1/2})`` of the last update.
    x_standardized : ndarray, shape (dim_x,)
        Standardized estimate ``z_{t|t}`` of §2.2 eq. (6) after the last update.
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
    >>> bool(np.isclose(kf.x_standardized[0], 3.0 / np.sqrt(2.0**2 * 1.0 + 1.0), rtol=1e-15))
    True
    """

    def __init__(self, dim_x: int, dim_z: int, exponent: float = 0.5) -> None:
        super().__init__(check_int("dim_x", dim_x), check_int("dim_z", dim_z))
        self.exponent = check_real("exponent", exponent, nonnegative=True)
        self.weights = np.full(dim_x, np.nan)
        self.x_standardized = np.full(dim_x, np.nan)
        self.raw_weights = np.full(dim_x, np.nan)
        self.P_prior_inv_sqrt = np.full((dim_x, dim_x), np.nan)

    def update(
        self, z: ArrayLike | None, R: ArrayLike | None = None, H: ArrayLike | None = None
    ) -> None:
        """The update of filterpy (§2.2 eq. 5), then the standardization (§2.2 eqs. 6-7).

        With ``z=None`` (a missing measurement) filterpy skips the update; the weights and
        the standardized estimate are then undefined and set to NaN.

        Parameters
        ----------
        z : array_like, shape (dim_z,) or None
            The measurement, or None for a missing one.
        R, H : array_like, optional
            Measurement noise covariance and matrix for this step (default ``self.R``,
            ``self.H``), as filterpy's ``update``.
        """
        P_prior = self.P  # after predict(), self.P is P_{t|t-1}
        super().update(z, R=R, H=H)
        if z is None:
            self.weights = np.full(self.dim_x, np.nan)
            self.x_standardized = np.full(self.dim_x, np.nan)
            self.raw_weights = np.full(self.dim_x, np.nan)
            self.P_prior_inv_sqrt = np.full((self.dim_x, self.dim_x), np.nan)
            return
        self.P_prior_inv_sqrt = inverse_sqrt(P_prior)
        self.raw_weights = raw_weights(self.P_prior_inv_sqrt, self.K, self.S)
        self.weights, self.x_standardized = standardize(
            self.raw_weights, self.P_prior_inv_sqrt @ self.x.ravel(), self.exponent
        )


def run(
    model: StateSpaceModel, Y: NDArray[np.float64], exponent: float, smoother: str | None
) -> Reconstruction:
    """Run the filterpy subclass over the data, then filterpy's ``rts_smoother`` method.

    A missing step (a column of NaN) is filterpy's ``update(None)``: the prediction stands.

    Parameters
    ----------
    model : StateSpaceModel
    Y : ndarray, shape (n_channels, n_times)
    exponent : float
    smoother : {None, "rts-standardized", "rts-state"}
        ``"rts-standardized"`` only without missing steps (the caller checks).

    Returns
    -------
    Reconstruction
    """
    (m, n), T = model.L.shape, Y.shape[1]
    kf = StandardizedKalmanFilter(dim_x=n, dim_z=m, exponent=exponent)
    kf.x, kf.P, kf.F = np.zeros((n, 1)), model.matrix("theta0").copy(), model.matrix("transition")
    kf.Q, kf.H, kf.R = model.matrix("q"), model.L, model.R
    f: dict[str, Any] = {key: np.empty((T, n)) for key in ("x_filt", "z", "w", "weights")}
    P_filt, f["P_pred_inv_sqrt"] = np.empty((T, n, n)), np.empty((T, n, n))
    f["missing"] = np.isnan(Y[0])
    log_likelihood = 0.0
    for t in range(T):
        kf.predict()
        try:
            kf.update(None if f["missing"][t] else Y[:, t])
            log_likelihood += 0.0 if f["missing"][t] else kf.log_likelihood
        except (np.linalg.LinAlgError, ValueError) as err:  # filterpy's S^-1, scipy's logpdf
            raise np.linalg.LinAlgError(f"at step {t + 1}: filterpy's update: {err}") from err
        f["x_filt"][t], f["z"][t] = kf.x.ravel(), kf.x_standardized
        f["w"][t], f["weights"][t] = kf.raw_weights, kf.weights
        P_filt[t], f["P_pred_inv_sqrt"][t] = kf.P, kf.P_prior_inv_sqrt
    f["log_likelihood"] = log_likelihood
    # both smoothers by filterpy's rts_smoother method, given the P_{t|t}  (docs/model.md §3)
    x, z = f["x_filt"], f["z"]
    if smoother == "rts-standardized":
        z = kf.rts_smoother(f["z"], P_filt)[0]
    elif smoother == "rts-state":
        x = kf.rts_smoother(f["x_filt"], P_filt)[0]
        z = restandardize(f["w"], f["P_pred_inv_sqrt"], x, exponent)
    return result(f, x, z, model, exponent, smoother, "filterpy")
