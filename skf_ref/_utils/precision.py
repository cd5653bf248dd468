"""The precision numbers carry, and the tolerances that follow it.

MNE-Python stores evokeds, epochs and forwards in single precision and reads them into
double: their values carry float32's rounding (eps 1.2e-7) in a float64 array. What was
rounded to float32 stays exactly representable in float32, so the precision is read off the
values themselves, whatever the array's dtype now.
"""

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["average_referenced", "precision", "zero_tolerance"]


def precision(values: ArrayLike) -> float:
    """Machine epsilon of the precision ``values`` carry.

    Parameters
    ----------
    values : array_like
        Floats of any dtype.

    Returns
    -------
    float
        float32's epsilon (1.2e-7) for float32 (or narrower) arrays and for float64 arrays
        whose every value float32 represents exactly; float64's (2.2e-16) otherwise.

    Examples
    --------
    >>> precision(np.float32([0.1, 0.2])), precision([0.1, 0.2])
    (1.1920928955078125e-07, 2.220446049250313e-16)
    >>> precision(np.float32([0.1, 0.2]).astype(float))  # read from a FIF file, say
    1.1920928955078125e-07
    """
    values = np.asarray(values)
    if values.dtype.kind == "f" and values.dtype.itemsize <= 4:
        return float(np.finfo(np.float32).eps)
    with np.errstate(over="ignore", invalid="ignore"):
        single = np.array_equal(values, values.astype(np.float32))
    return float(np.finfo(np.float32 if single else np.float64).eps)


def zero_tolerance(values: ArrayLike) -> float:
    """How small, relative to the values' size, a result that is 0 up to rounding can be.

    ``sqrt(eps)`` of :func:`precision`: half the digits. Rounding in the values' precision
    (a mean taken in float32, a filter or a resampling applied after it, storage in a FIF
    file) stays orders of magnitude below it; anything that is not 0 by construction (a
    reference other than the average, an unreferenced lead field, an asymmetric matrix) is
    of the order of the values themselves.

    Returns
    -------
    float
        1.5e-8 for double precision, 3.5e-4 for single precision.
    """
    return float(np.sqrt(precision(values)))


def average_referenced(values: ArrayLike, per_column: bool = False) -> bool:
    """Whether the mean over the rows (channels) is 0 to the values' precision.

    Parameters
    ----------
    values : ndarray, shape (n_channels, n_columns)
    per_column : bool
        Compare each column's mean with that column's largest value (a lead field: its
        columns are sources of very different strength); else with the largest value of
        all (data: a time when every channel is near 0 has rounding of the others' size).

    Returns
    -------
    bool
        True for an all-zero array.

    Examples
    --------
    >>> Y = np.random.default_rng(0).standard_normal((4, 3))
    >>> average_referenced(Y), average_referenced(Y - Y.mean(axis=0))
    (False, True)
    """
    values = np.asarray(values)
    means = np.abs(values.mean(axis=0, dtype=float))
    sizes = np.abs(values).max(axis=0) if per_column else np.abs(values).max()
    return bool(np.all(means <= zero_tolerance(values) * sizes))
