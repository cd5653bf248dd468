"""The result type every computational path returns."""

__all__ = ["Reconstruction"]


class Reconstruction:
    """A standardized Kalman filter reconstruction.

    All source-space arrays have shape (n_sources, n_times), MNE's layout. A path may hand
    any of them over as a zero-argument function instead of an array: it is then computed on
    first access and kept (the spectral path does this, so that asking for ``z`` at 150 000
    sources does not also materialize four other arrays of the same size).

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

    _ARRAYS = ("z", "x", "z_filtered", "x_filtered", "weights")

    def __init__(
        self, *, z, x, z_filtered, x_filtered, weights, log_likelihood, exponent, smoother, method
    ):
        self._arrays = dict(
            z=z, x=x, z_filtered=z_filtered, x_filtered=x_filtered, weights=weights
        )
        self.log_likelihood = log_likelihood
        self.exponent = exponent
        self.smoother = smoother
        self.method = method

    def _array(self, name):
        value = self._arrays[name]
        if callable(value):
            value = self._arrays[name] = value()
        return value

    z = property(lambda self: self._array("z"), doc="Standardized (smoothed) estimate.")
    x = property(lambda self: self._array("x"), doc="Unstandardized (smoothed) means.")
    z_filtered = property(lambda self: self._array("z_filtered"), doc="Filtered z_{t|t}.")
    x_filtered = property(lambda self: self._array("x_filtered"), doc="Filtered x_{t|t}.")
    weights = property(lambda self: self._array("weights"), doc="Diagonal of W_t^(alpha).")

    def __repr__(self):
        return (
            f"<Reconstruction | {self.n_sources} sources x {self.n_times} steps, "
            f"method={self.method!r}, exponent={self.exponent}, smoother={self.smoother!r}>"
        )

    @property
    def shape(self):
        """(n_sources, n_times), read off an array already computed where there is one."""
        ready = [a for a in self._arrays.values() if not callable(a)]
        return (ready[0] if ready else self.z).shape

    @property
    def n_sources(self):
        """Number of state components (columns of the lead field)."""
        return self.shape[0]

    @property
    def n_times(self):
        """Number of time steps."""
        return self.shape[1]

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
        >>> import numpy as np
        >>> z = np.array([[3.0], [4.0], [0.0], [1.0], [0.0], [0.0]])
        >>> r = Reconstruction(z=z, x=z, z_filtered=z, x_filtered=z, weights=z,
        ...                    log_likelihood=0.0, exponent=0.5, smoother=None, method="dense")
        >>> r.amplitude(3).ravel().tolist()
        [5.0, 1.0]
        """
        if components not in (1, 2, 3) or self.n_sources % components:
            raise ValueError(
                f"components must be 1, 2 or 3 and divide n_sources={self.n_sources}, "
                f"got {components!r}"
            )
        from .metrics import amplitude_from_components

        return amplitude_from_components(self.z_filtered if filtered else self.z, components)
