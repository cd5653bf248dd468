"""Input checks shared by every public entry point.

Each check names the parameter, what was expected and what was received, and raises
``ValueError`` (wrong value or shape) or ``TypeError`` (wrong kind of object). Nothing is
transposed or reshaped silently.
"""

import numbers

import numpy as np
from scipy import linalg

__all__: list[str] = []


def check_choice(name, value, allowed):
    """Return ``value`` if it is one of ``allowed``, else raise naming all of them."""
    if value not in allowed:
        raise ValueError(f"{name} must be one of {list(allowed)!r}, got {value!r}")
    return value


def check_real(name, value, *, positive=False, nonnegative=False):
    """A finite real scalar (``bool`` excluded), optionally > 0 or >= 0."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    value = float(value)
    if not np.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if positive and value <= 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    if nonnegative and value < 0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return value


def check_int(name, value, *, minimum=1):
    """An integer (``bool`` excluded) of at least ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value!r}")
    return int(value)


def check_array(name, value, shape):
    """A finite float array of exactly ``shape``.

    Entries of ``shape`` that are ``None`` or a name (``"n_times"``) match any length; the
    error message shows the names.
    """
    if np.iscomplexobj(value):
        raise TypeError(f"{name} must be real, got a complex array")
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise TypeError(f"{name} must be a numeric array, got {type(value).__name__}") from err
    names = ["any" if s is None else str(s) for s in shape]
    wanted = f"({names[0]},)" if len(names) == 1 else f"({', '.join(names)})"
    if array.ndim != len(shape) or any(
        isinstance(s, int) and s != got for s, got in zip(shape, array.shape, strict=False)
    ):
        raise ValueError(f"{name} must have shape {wanted}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} contains NaN or Inf")
    return array


def check_leadfield(L):
    """Lead field (n_channels, n_sources), finite, with no all-zero column."""
    L = check_array("L", L, (None, None))
    zero = np.flatnonzero(~np.any(L, axis=0))
    if zero.size:
        raise ValueError(
            f"L has zero sensitivity (an all-zero column) at column {zero[0]}"
            + (f" and {zero.size - 1} more" if zero.size > 1 else "")
            + "; the standardization weights are undefined there: remove the column"
        )
    return L


def check_spd(name, value, n):
    """A symmetric positive definite (n, n) matrix; returns it symmetrized."""
    matrix = check_array(name, value, (n, n))
    scale = np.max(np.abs(matrix))
    if not np.allclose(matrix, matrix.T, rtol=0, atol=1e-12 * scale):
        raise ValueError(f"{name} must be symmetric")
    try:
        linalg.cholesky(matrix, lower=True)
    except linalg.LinAlgError as err:
        raise ValueError(
            f"{name} must be positive definite (its Cholesky factorization failed)"
        ) from err
    return (matrix + matrix.T) / 2


def check_scalar_or_spd(name, value, n, *, allow_zero=False):
    """An isotropic variance (positive scalar, meaning value * I) or an SPD (n, n) matrix."""
    if np.ndim(value) == 0:
        if allow_zero:
            return check_real(name, value, nonnegative=True)
        return check_real(name, value, positive=True)
    return check_spd(name, value, n)


def check_transition(value, n):
    """Transition: a scalar a (A = a I) or a finite (n, n) matrix."""
    if np.ndim(value) == 0:
        return check_real("transition", value)
    return check_array("transition", value, (n, n))
