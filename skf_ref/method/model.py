"""The linear-Gaussian state-space model the SKF runs on, checked once (docs/model.md §1).

::

    x_t = A x_{t-1} + q_t,   q_t ~ N(0, Q)
    y_t = L x_t + r_t,       r_t ~ N(0, R)
    x_0 ~ N(0, P_0)

Every path (:mod:`skf_ref.method.paths.dense`, :mod:`skf_ref.method.paths.filterpy_skf`,
:mod:`skf_ref.method.paths.spectral`) takes a :class:`StateSpaceModel`. ``transition``, ``q`` and
``theta0`` keep the form the user gave: a scalar ``c`` means ``c I`` (the paper's isotropic model),
a matrix means itself.
"""

import functools
from dataclasses import dataclass

import numpy as np

from .._utils.checks import (
    InputError,
    check_array,
    check_leadfield,
    check_real,
    check_scalar_or_spd,
    check_spd,
    check_transition,
)
from .._utils.precision import average_referenced

__all__ = ["StateSpaceModel"]

_SMALLEST, _LARGEST = np.finfo(float).tiny, np.finfo(float).max


@dataclass(frozen=True, eq=False)
class StateSpaceModel:
    """A checked state-space model: lead field, noise covariance, transition and priors.

    Build it with :meth:`create`, which checks every parameter; the constructor itself
    trusts its arguments.

    Attributes
    ----------
    L : ndarray, shape (n_channels, n_sources)
        Lead field.
    R : ndarray, shape (n_channels, n_channels)
        Noise covariance, symmetric positive definite.
    transition : float or ndarray, shape (n_sources, n_sources)
        ``A``: a scalar ``a`` means ``a I``.
    q : float or ndarray, shape (n_sources, n_sources)
        ``Q``: a scalar means ``q I`` (``q >= 0``).
    theta0 : float or ndarray, shape (n_sources, n_sources)
        ``P_0``: a scalar means ``theta0 I`` (``theta0 > 0``).

    Examples
    --------
    >>> model = StateSpaceModel.create(np.eye(2, 3) + 1, noise_std=0.1, theta0=1.0, q=0.1)
    >>> model.n_channels, model.n_sources, model.isotropic_problem()
    (2, 3, None)
    >>> model.matrix("q")
    array([[0.1, 0. , 0. ],
           [0. , 0.1, 0. ],
           [0. , 0. , 0.1]])
    """

    L: np.ndarray
    R: np.ndarray
    transition: object
    q: object
    theta0: object

    @classmethod
    def create(cls, L, *, noise_std=None, noise_cov=None, theta0, q, transition=1.0):
        """Check every parameter (names as in :func:`skf_ref.reconstruct`) and build the model.

        Returns
        -------
        StateSpaceModel
        """
        L = check_leadfield(L)
        m, n = L.shape
        if (noise_std is None) == (noise_cov is None):
            raise InputError("give exactly one of noise_std (a scalar) or noise_cov (a matrix)")
        if noise_std is not None:
            noise_std = check_real("noise_std", noise_std, positive=True)
            low, high = np.sqrt(_SMALLEST), np.sqrt(_LARGEST)
            if not low <= noise_std <= high:
                raise InputError(
                    f"noise_std must be within [{low:.3g}, {high:.3g}] (its square, the noise "
                    f"variance, must be a normal double), got {noise_std!r}; give the data in "
                    "other units"
                )
            R = noise_std**2 * np.eye(m)
        else:
            R = check_spd("noise_cov", noise_cov, m)
        theta0 = check_scalar_or_spd("theta0", theta0, n)
        q = check_scalar_or_spd("q", q, n, allow_zero=True)
        transition = check_transition(transition, n)
        if np.ndim(q) == 0 and q == 0 and np.ndim(transition) == 0 and transition == 0:
            raise InputError("q must be > 0 when transition is 0: P_t|t-1 would be 0")
        with np.errstate(over="ignore"):
            predicted = np.float64(np.max(np.abs(transition))) ** 2 * np.max(theta0) + np.max(q)
        if not predicted <= _LARGEST:
            raise InputError(
                "transition, theta0 and q are out of range: the first predicted covariance "
                "A P_0 A^T + Q overflows"
            )
        return cls(L=L, R=R, transition=transition, q=q, theta0=theta0)

    @property
    def n_channels(self):
        """int : Rows of the lead field."""
        return self.L.shape[0]

    @property
    def n_sources(self):
        """int : Columns of the lead field (state components)."""
        return self.L.shape[1]

    def check_data(self, Y):
        """``Y`` as a float array of shape (n_channels, n_times), finite and in range.

        Its squared size in noise standard deviations (the log-likelihood's quadratic form)
        must fit in double precision.

        Returns
        -------
        ndarray, shape (n_channels, n_times)
        """
        Y = check_array("Y", Y, (self.n_channels, "n_times"))
        if Y.shape[1] < 1:
            raise InputError(f"Y must have at least one time step, got shape {Y.shape}")
        self._check_reference(Y)
        noise_std = np.sqrt(np.linalg.eigvalsh(self.R)[0])
        size = np.max(np.abs(Y)) / noise_std
        if size > 0 and not np.log(size) * 2 + np.log(Y.size) < np.log(_LARGEST):
            raise InputError(
                f"Y is out of range for the noise: max|Y| = {np.max(np.abs(Y)):.3g} is "
                f"{size:.3g} noise standard deviations ({noise_std:.3g}), and the likelihood's "
                "squared residuals overflow; give Y and the noise in the same units"
            )
        return Y

    def _check_reference(self, Y):
        """Refuse average-referenced data with a lead field that is not (docs/model.md §1).

        "Average referenced" to the precision each carries: float32 values (MNE's files)
        have a channel mean of float32's rounding, not double's
        (:func:`skf_ref._utils.precision.average_referenced`).
        """
        if self.n_channels < 3 or not np.any(Y):
            return
        if not average_referenced(Y):
            return  # the data are not average referenced: any lead field goes
        if not self._field_referenced:
            raise InputError(
                "Y is average referenced (its channel mean is 0 at every time) but L is not: "
                "the model needs the same reference in both; average-reference L (subtract "
                "each column's mean over the channels)"
            )

    @functools.cached_property
    def _field_referenced(self):
        """Whether every column of ``L`` has a channel mean of 0 to its precision."""
        return average_referenced(self.L, per_column=True)

    def matrix(self, name):
        """``"transition"``, ``"q"`` or ``"theta0"`` as an (n_sources, n_sources) matrix."""
        value = getattr(self, name)
        return value * np.eye(self.n_sources) if np.ndim(value) == 0 else value

    def scalar(self, name):
        """``c`` if ``transition``, ``q`` or ``theta0`` is a scalar ``c`` or ``c I``, else None."""
        value = getattr(self, name)
        if np.ndim(value) == 0:
            return float(value)
        diagonal = np.diagonal(value)
        c = diagonal[0]
        isotropic = np.all(diagonal == c) and np.count_nonzero(value) == np.count_nonzero(diagonal)
        return float(c) if isotropic else None

    def isotropic_problem(self):
        """Why the model is not ``A = a I, Q = q I, P_0 = theta0 I``, or None if it is.

        The spectral path (:mod:`skf_ref.method.paths.spectral`) needs exactly that model.

        Returns
        -------
        str or None
        """
        for name in ("transition", "q", "theta0"):
            if self.scalar(name) is None:
                return f"{name} is not a scalar multiple of the identity"
        return None
