"""The result type every computational path returns."""

from dataclasses import dataclass

import numpy as np

__all__ = ["Reconstruction"]


@dataclass(frozen=True, eq=False)
class Reconstruction:
    """A standardized Kalman filter reconstruction.

    All source-space arrays have shape (n_sources, n_times), MNE's layout.

    Attributes
    ----------
    z : ndarray, shape (n_sources, n_times)
        Standardized estimate; smoothed when a smoother was asked, else ``z_filtered``.
    x : ndarray, shape (n_sources, n_times)
        Unstandardized means: the smoothed state ``x^s_t`` for ``"rts-state"``, the
        filtered means ``x_{t|t}`` otherwise.
    z_filtered : ndarray, shape (n_sources, n_times)
        ``z_{t|t}`` of eq. (6).
    x_filtered : ndarray, shape (n_sources, n_times)
        ``x_{t|t}`` of eq. (5).
    weights : ndarray, shape (n_sources, n_times)
        Diagonal of ``W_t^(alpha)`` (7) at each step.
    log_likelihood : float
        Innovation log-likelihood ``sum_t log N(y_t - L x_{t|t-1}; 0, S_t)``.
    exponent : float
        The standardization exponent alpha.
    smoother : str or None
        ``None``, ``"rts-standardized"`` or ``"rts-state"``.
    method : str
        The path that computed it: ``"filterpy"``, ``"dense"`` or ``"spectral"``.
    """

    z: np.ndarray
    x: np.ndarray
    z_filtered: np.ndarray
    x_filtered: np.ndarray
    weights: np.ndarray
    log_likelihood: float
    exponent: float
    smoother: str | None
    method: str

    @property
    def n_sources(self):
        """Number of state components (columns of the lead field)."""
        return self.z.shape[0]

    @property
    def n_times(self):
        """Number of time steps."""
        return self.z.shape[1]

    def amplitude(self, components=1, *, filtered=False):
        """Per-position amplitude: the Euclidean norm of each position's components of z.

        Parameters
        ----------
        components : int
            Columns per position: 3 for free orientation (MNE's x, y, z order), 1 for fixed.
        filtered : bool
            Use ``z_filtered`` instead of ``z``.

        Returns
        -------
        ndarray, shape (n_sources // components, n_times)

        Examples
        --------
        >>> z = np.array([[3.0], [4.0], [0.0], [1.0], [0.0], [0.0]])
        >>> r = Reconstruction(z, z, z, z, z, 0.0, 0.5, None, "dense")
        >>> r.amplitude(3).ravel().tolist()
        [5.0, 1.0]
        """
        if components not in (1, 2, 3) or self.n_sources % components:
            raise ValueError(
                f"components must be 1, 2 or 3 and divide n_sources={self.n_sources}, "
                f"got {components!r}"
            )
        z = self.z_filtered if filtered else self.z
        return np.linalg.norm(z.reshape(-1, components, self.n_times), axis=1)
