"""The SKF as a thin subclass of filterpy's ``KalmanFilter``.

filterpy does the predict (§2.2 eq. 4), the update (§2.2 eq. 5) and the RTS smoother
(§2.3 eq. 4); this subclass only adds the standardization, §2.2 eqs. (6)-(7), after each
update, from the predicted covariance, gain and innovation covariance filterpy has just used
(per column, or per source position: docs/model.md §2). The smoother standardized by its own
variance takes the smoothed covariances filterpy's ``rts_smoother`` returns and the prior
covariances from filterpy's ``predict`` (docs/model.md §3). filterpy's own ``alpha`` (fading
memory) keeps its meaning; the standardization exponent is ``exponent``.
"""

from typing import Any

import numpy as np
from filterpy.kalman import KalmanFilter
from filterpy.kalman import predict as filterpy_predict
from numpy.typing import ArrayLike, NDArray

from ..._utils.checks import check_int
from .._model import StateSpaceModel
from .._powers import block_power
from .._result import Reconstruction, stored_result
from .._settings import Settings, check_settings
from .._standardization import (
    apply_blocks,
    block_diagonal,
    diagonal_blocks,
    inverse_sqrt,
    restandardize_blocks,
    standardize_smoothed,
)

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
    standardize : {"column", "position"}
        Each state component standardized on its own (the paper's), or each source
        position's ``n_orient`` components as a whole (docs/model.md §2).
    n_orient : {1, 3}
        Components per source position (MNE's order); with ``"column"`` it is not used.

    Attributes
    ----------
    weights : ndarray, shape (dim_x,)
        Diagonal of ``W_t^(alpha)`` after the last update.
    weight_blocks : ndarray, shape (dim_x // k, k, k)
        The blocks of ``W_t^(alpha)`` (``k = n_orient`` per position, 1 per column).
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

    def __init__(
        self,
        dim_x: int,
        dim_z: int,
        exponent: float = 0.5,
        standardize: str = "column",
        n_orient: int = 1,
    ) -> None:
        super().__init__(check_int("dim_x", dim_x), check_int("dim_z", dim_z))
        self._set(check_settings(exponent, None, "filterpy", standardize, n_orient, self.dim_x))

    @classmethod
    def _checked(cls, dim_x: int, dim_z: int, settings: Settings) -> "StandardizedKalmanFilter":
        """The filter of settings already checked (:func:`run`'s), not checked again."""
        kf = cls.__new__(cls)
        KalmanFilter.__init__(kf, dim_x, dim_z)
        kf._set(settings)
        return kf

    def _set(self, settings: Settings) -> None:
        self.exponent, self.standardize = settings.exponent, settings.standardize
        self.n_orient, self._block = settings.n_orient or 1, settings.block
        self.weights = np.full(self.dim_x, np.nan)
        self.weight_blocks = np.full((self.dim_x // self._block, self._block, self._block), np.nan)
        self.x_standardized = np.full(self.dim_x, np.nan)
        self.raw_weights = np.full(self.dim_x, np.nan)
        self.P_prior_inv_sqrt = np.full((self.dim_x, self.dim_x), np.nan)

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
        super().update(z, R=R, H=H)
        if z is None:
            self.weights = np.full(self.dim_x, np.nan)
            self.weight_blocks = np.full_like(self.weight_blocks, np.nan)
            self.x_standardized = np.full(self.dim_x, np.nan)
            self.raw_weights = np.full(self.dim_x, np.nan)
            self.P_prior_inv_sqrt = np.full((self.dim_x, self.dim_x), np.nan)
            return
        # w_t = diag(Psi_t), Psi_t = P^{-1/2} K_t S_t K_t^T P^{-1/2}, with filterpy's
        # P_prior = P_{t|t-1} (set by predict), K and S                 §2.2 eq. (7)
        self.P_prior_inv_sqrt = inverse_sqrt(self.P_prior)
        M = self.P_prior_inv_sqrt @ self.K
        Psi = M @ self.S @ M.T
        self.raw_weights = np.diag(Psi).copy()
        whitened = self.P_prior_inv_sqrt @ self.x.ravel()
        if self._block == 1:
            with np.errstate(over="ignore", divide="ignore"):  # the result refuses inf
                # W_t^(alpha) = Diag(w_t)^(-alpha)                     §2.2 eq. (7)
                self.weights = self.raw_weights**-self.exponent
                # z_{t|t} = W_t^(alpha) P_{t|t-1}^{-1/2} x_{t|t}         §2.2 eq. (6)
                self.x_standardized = self.weights * whitened
            self.weight_blocks = self.weights[:, None, None]
        else:  # per position: W_t^(alpha) = blockdiag_i B_t(i)^(-alpha)  docs/model.md §2
            self.weight_blocks = block_power(diagonal_blocks(Psi, self._block), self.exponent)
            self.weights = block_diagonal(self.weight_blocks)
            self.x_standardized = apply_blocks(self.weight_blocks, whitened)


def run(model: StateSpaceModel, Y: NDArray[np.float64], settings: Settings) -> Reconstruction:
    """Run the filterpy subclass over the data, then filterpy's ``rts_smoother`` method.

    A missing step (a column of NaN) is filterpy's ``update(None)``: the prediction stands.

    Parameters
    ----------
    model : StateSpaceModel
    Y : ndarray, shape (n_channels, n_times)
    settings : Settings
        Checked by the caller (``"rts-standardized"`` only without missing steps).

    Returns
    -------
    Reconstruction
    """
    (m, n), T = model.L.shape, Y.shape[1]
    kf = StandardizedKalmanFilter._checked(n, m, settings)
    exponent, smoother = settings.exponent, settings.smoother
    kf.x, kf.P, kf.F = np.zeros((n, 1)), model.matrix("theta0").copy(), model.matrix("transition")
    kf.Q, kf.H, kf.R = model.matrix("q"), model.L, model.R
    f: dict[str, Any] = {key: np.empty((T, n)) for key in ("x_filt", "z", "w", "weights")}
    P_filt, f["P_pred_inv_sqrt"] = np.empty((T, n, n)), np.empty((T, n, n))
    f["W"] = np.empty((T, *kf.weight_blocks.shape))
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
        f["w"][t], f["weights"][t], f["W"][t] = kf.raw_weights, kf.weights, kf.weight_blocks
        P_filt[t], f["P_pred_inv_sqrt"][t] = kf.P, kf.P_prior_inv_sqrt
    f["log_likelihood"] = log_likelihood
    # every smoother by filterpy's rts_smoother method, given the P_{t|t}  (docs/model.md §3)
    x, z = f["x_filt"], f["z"]
    if smoother == "rts-standardized":
        z = kf.rts_smoother(f["z"], P_filt)[0]
    elif smoother == "rts-state":
        x = kf.rts_smoother(f["x_filt"], P_filt)[0]
        z = restandardize_blocks(f["W"], f["P_pred_inv_sqrt"], x)
    elif smoother == "rts-smoothed-weights":
        x, P_smoothed, _, _ = kf.rts_smoother(f["x_filt"], P_filt)
        Sigma = _prior_covariances(model.matrix("theta0"), kf.F, kf.Q, T)
        z = standardize_smoothed(x, P_smoothed, Sigma, exponent, kf.weight_blocks.shape[-1])
        z[f["missing"]] = np.nan  # no estimate at a missing step, as on every smoother
    return stored_result(f, x, z, model, settings, "filterpy")


def _prior_covariances(
    P0: NDArray[np.float64], F: NDArray[np.float64], Q: NDArray[np.float64], n_times: int
) -> NDArray[np.float64]:
    """``Sigma_t``, t = 1 .. T, by filterpy's ``predict`` from ``Sigma_0 = P_0``: the
    covariance of ``x_t`` before any data (docs/model.md §3)."""
    Sigma = np.empty((n_times, *P0.shape))
    previous = P0
    for t in range(n_times):
        _, previous = filterpy_predict(np.zeros(len(P0)), previous, F=F, Q=Q)
        Sigma[t] = previous
    return Sigma
