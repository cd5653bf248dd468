"""The linear-Gaussian state-space model the SKF runs on, checked once (docs/model.md §1).

::

    x_t = A x_{t-1} + q_t,   q_t ~ N(0, Q)
    y_t = L x_t + r_t,       r_t ~ N(0, R)
    x_0 ~ N(0, P_0)

Every path (``skf_ref.method._paths.dense``, ``skf_ref.method._paths.filterpy_skf``,
``skf_ref.method._paths.spectral``) takes a :class:`StateSpaceModel`. ``transition``, ``q`` and
``theta0`` keep the form the user gave: a scalar ``c`` means ``c I`` (the paper's isotropic model),
a matrix means itself.
"""

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

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

__all__ = ["StateSpaceModel", "missing_steps"]

_SMALLEST, _LARGEST = np.finfo(float).tiny, np.finfo(float).max


def missing_steps(Y: ArrayLike, name: str = "Y") -> NDArray[np.bool_]:
    """The missing steps of data ``Y``: its columns of NaN (docs/model.md §2).

    Every other column must be finite: a column NaN in some channels only, or any Inf, is
    refused, naming the column. At least one step must be observed.

    Parameters
    ----------
    Y : array_like, shape (n_channels, n_times)
    name : str
        What ``Y`` is, for the messages.

    Returns
    -------
    ndarray of bool, shape (n_times,)

    Examples
    --------
    >>> missing_steps([[1.0, np.nan, 2.0], [3.0, np.nan, 4.0]]).tolist()
    [False, True, False]
    >>> missing_steps([[1.0, np.nan], [3.0, 4.0]])
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: Y[:, 1] is NaN in 1 of its 2 channels: a step is \
either measured on every channel or missing (a column of NaN); ...
    """
    Y = np.asarray(Y, dtype=float)
    if np.isinf(Y).any():
        column = int(np.flatnonzero(np.isinf(Y).any(axis=0))[0])
        raise InputError(f"{name} contains Inf (first in column {column})")
    nan = np.isnan(Y)
    if not nan.any():
        return np.zeros(Y.shape[1], bool)
    missing = nan.all(axis=0)
    partial = np.flatnonzero(nan.any(axis=0) & ~missing)
    if partial.size:
        t = int(partial[0])
        raise InputError(
            f"{name}[:, {t}] is NaN in {np.count_nonzero(nan[:, t])} of its {len(Y)} channels: "
            "a step is either measured on every channel or missing (a column of NaN); "
            f"{partial.size} column(s) are partly NaN: drop the channels, or make the step "
            "missing"
        )
    if missing.all():
        raise InputError(f"every column of {name} is NaN: no step is observed")
    return missing


@dataclass(frozen=True, eq=False)
class StateSpaceModel:
    """A checked state-space model: lead field, noise covariance, transition and priors.

    Build it with :meth:`create`, which checks every parameter; the constructor itself
    trusts its arguments.

    Parameters
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

    L: NDArray[np.float64]
    R: NDArray[np.float64]
    transition: float | NDArray[np.float64]
    q: float | NDArray[np.float64]
    theta0: float | NDArray[np.float64]

    @classmethod
    def create(
        cls,
        L: ArrayLike,
        *,
        noise_std: float | None = None,
        noise_cov: ArrayLike | None = None,
        theta0: float | ArrayLike,
        q: float | ArrayLike,
        transition: float | ArrayLike = 1.0,
    ) -> "StateSpaceModel":
        """Check every parameter (names as in :func:`skf_ref.reconstruct`) and build the model.

        Parameters
        ----------
        L : array_like, shape (n_channels, n_sources)
            Lead field.
        noise_std : float, optional
            Noise standard deviation: ``R = noise_std**2 I``.
        noise_cov : array_like, shape (n_channels, n_channels), optional
            Noise covariance, symmetric positive definite. Give exactly one of the two.
        theta0 : float or array_like, shape (n_sources, n_sources)
            ``P_0``: a scalar means ``theta0 I``.
        q : float or array_like, shape (n_sources, n_sources)
            ``Q``: a scalar means ``q I``.
        transition : float or array_like, shape (n_sources, n_sources)
            ``A``: a scalar ``a`` means ``a I`` (default the random walk, 1).

        Returns
        -------
        StateSpaceModel
        """
        L = check_leadfield(L)
        m, n = L.shape
        if (noise_std is None) == (noise_cov is None):
            raise InputError("give exactly one of noise_std (a scalar) or noise_cov (a matrix)")
        if noise_cov is not None:
            R = check_spd("noise_cov", noise_cov, m)
        else:
            noise_std = check_real("noise_std", noise_std, positive=True)
            low, high = np.sqrt(_SMALLEST), np.sqrt(_LARGEST)
            if not low <= noise_std <= high:
                raise InputError(
                    f"noise_std must be within [{low:.3g}, {high:.3g}] (its square, the noise "
                    f"variance, must be a normal double), got {noise_std!r}; give the data in "
                    "other units"
                )
            R = noise_std**2 * np.eye(m)
        theta0 = check_scalar_or_spd("theta0", theta0, n)
        q = check_scalar_or_spd("q", q, n, allow_zero=True)
        transition = check_transition(transition, n)
        if np.ndim(q) == 0 and q == 0 and not np.any(transition):
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
    def n_channels(self) -> int:
        """Rows of the lead field (int)."""
        return self.L.shape[0]

    @property
    def n_sources(self) -> int:
        """Columns of the lead field, the state's components (int)."""
        return self.L.shape[1]

    @functools.cached_property
    def _smallest_noise_std(self) -> float:
        """The square root of ``R``'s smallest eigenvalue, once per model (epochs share it)."""
        return float(np.sqrt(np.linalg.eigvalsh(self.R)[0]))

    def check_data(self, Y: ArrayLike) -> NDArray[np.float64]:
        """``Y`` as a float array, finite and in range but for its missing steps.

        A column of NaN is a missing step (docs/model.md §2: predicted, not updated); a
        column NaN in some channels only, or any Inf, is refused. The squared size of the
        data in noise standard deviations (the log-likelihood's quadratic form) must fit in
        double precision. A ``Y`` whose rows match the lead field's columns rather than its
        rows is reported as a transposed ``L``.

        Parameters
        ----------
        Y : array_like, shape (n_channels, n_times)

        Returns
        -------
        ndarray, shape (n_channels, n_times)
        """
        rows = np.shape(Y)[0] if np.ndim(Y) == 2 else None
        if rows is not None and rows != self.n_channels and rows == self.n_sources:
            raise InputError(
                f"L must have shape (n_channels, n_sources) with Y's {rows} channels as its "
                f"rows, got L of shape {self.L.shape}: L looks transposed (give L.T); Y has "
                f"shape {np.shape(Y)}"
            )
        Y = check_array("Y", Y, (self.n_channels, "n_times"), finite=False)
        if Y.shape[1] < 1:
            raise InputError(f"Y must have at least one time step, got shape {Y.shape}")
        missing = missing_steps(Y)
        observed = Y[:, ~missing] if missing.any() else Y
        self._check_reference(observed)
        noise_std = self._smallest_noise_std
        size = np.max(np.abs(observed)) / noise_std
        if size > 0 and not np.log(size) * 2 + np.log(observed.size) < np.log(_LARGEST):
            raise InputError(
                f"Y is out of range for the noise: max|Y| = {np.max(np.abs(observed)):.3g} is "
                f"{size:.3g} noise standard deviations ({noise_std:.3g}), and the likelihood's "
                "squared residuals overflow; give Y and the noise in the same units"
            )
        return Y

    def _check_reference(self, Y: NDArray[np.float64]) -> None:
        """Refuse average-referenced data with a lead field that is not (docs/model.md §1).

        "Average referenced" to the precision each carries: float32 values (MNE's files)
        have a channel mean of float32's rounding, not double's
        (``skf_ref._utils.precision.average_referenced``).
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
    def _field_referenced(self) -> bool:
        """Whether every column of ``L`` has a channel mean of 0 to its precision."""
        return average_referenced(self.L, per_column=True)

    def matrix(self, name: str) -> NDArray[np.float64]:
        """``"transition"``, ``"q"`` or ``"theta0"`` as an (n_sources, n_sources) matrix.

        Parameters
        ----------
        name : {"transition", "q", "theta0"}
            The parameter.

        Returns
        -------
        ndarray, shape (n_sources, n_sources)
            The parameter's matrix (a scalar ``c`` as ``c I``).
        """
        value = getattr(self, name)
        return value * np.eye(self.n_sources) if np.ndim(value) == 0 else value

    def scalar(self, name: str) -> float | None:
        """``c`` if ``transition``, ``q`` or ``theta0`` is a scalar ``c`` or ``c I``, else None.

        Parameters
        ----------
        name : {"transition", "q", "theta0"}
            The parameter.

        Returns
        -------
        float or None
            The scalar, or None for a matrix other than ``c I``.
        """
        value = getattr(self, name)
        if np.ndim(value) == 0:
            return float(value)
        diagonal = np.diagonal(value)
        c = diagonal[0]
        isotropic = np.all(diagonal == c) and np.count_nonzero(value) == np.count_nonzero(diagonal)
        return float(c) if isotropic else None

    def isotropic_problem(self) -> str | None:
        """Why the model is not ``A = a I, Q = q I, P_0 = theta0 I``, or None if it is.

        The spectral path (``skf_ref.method._paths.spectral``) needs exactly that model.

        Returns
        -------
        str or None
        """
        for name in ("transition", "q", "theta0"):
            if self.scalar(name) is None:
                return f"{name} is not a scalar multiple of the identity"
        return None
