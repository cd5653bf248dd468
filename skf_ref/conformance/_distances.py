"""How far their numbers are from another set, per output, and when a known mistake explains them.

Two measures, for two questions:

- **Against the expected outputs** (:func:`relative_steps`): the verdict of each output and
  the first divergence. A quantity is measured against its own expected scale:
  ``max|expected|`` over the whole array, and for the log-likelihood the sum of the sizes of
  its terms (:func:`~skf_ref.conformance._intermediates.log_likelihood_scale`), so that a
  log-likelihood near zero, whose terms cancel, does not make every difference look large.
- **Between two sets** (:func:`distance`): how far their numbers are from a known mistake's,
  and, in the same measure, from the expected ones: ``max|a - b|`` over the larger of
  ``max|a|`` and ``max|b|`` (for the log-likelihood, over the larger of those and its terms'
  sizes). Two sets that are both small next to the expected outputs are not close for that:
  they are as far apart as they are from each other.

**When a known mistake is named** (:func:`explains`). Let ``tol`` be the tolerance their
numbers support (the comparison's, or more for float32 numbers or printed digits),
``D_k`` the distance of their output ``k`` from the expected one and ``d_k`` its distance
from the mistake's. The mistake

- *reproduces* their outputs when ``d_k <= tol`` for every output given;
- *explains* them when, for every output given, ``d_k <= max(FACTOR tol, D_k / NEARER)``:
  within ``FACTOR`` times the tolerance, or ``NEARER`` times nearer to theirs than the
  expected output is. On an output that agrees (``D_k <= tol``) this asks for
  ``d_k <= FACTOR tol``: a mistake that would change an output they got right explains
  nothing. Numbers that are not finite are explained by no mistake.

Otherwise it is not named, however near it comes. The rule and its two factors were fixed
before the evaluation that judges them (validation/conformance_mistakes.md, which also
records the one amendment: the measure between two sets).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "FACTOR",
    "NEARER",
    "distance",
    "explains",
    "relative_steps",
    "reproduces",
]

#: A mistake within this many tolerances of their numbers, on every output, explains them.
FACTOR = 10.0
#: Or, on every output that differs, this many times nearer to theirs than the expected one.
NEARER = 100.0


def _compared(value: Any, reference: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``value`` and ``reference`` of one shape: a covariance given by its diagonal is
    compared with the reference's diagonal."""
    value, reference = np.asarray(value, dtype=float), np.asarray(reference, dtype=float)
    if value.ndim == 2 and reference.ndim == 3:
        reference = np.diagonal(reference, axis1=0, axis2=1).T  # (n, n, T) -> (n, T)
    return value, reference


def relative_steps(
    value: Any, reference: Any, scale: float, per_step: bool = True
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """The largest difference at each step over ``scale``, and the row where it is.

    Parameters
    ----------
    value, reference : float or ndarray
        One shape, time on the last axis (``per_step``); or a covariance (..., n, T) given
        by its diagonal (n, T).
    scale : float
        The quantity's own scale (positive).
    per_step : bool
        False for what has no time axis (the priors, the log-likelihood): one value.

    Returns
    -------
    steps : ndarray, shape (n_times,) or (1,)
        Infinite where their value is not finite.
    rows : ndarray of int, same shape
        The row (counting from 0) of the largest difference at each step.

    Examples
    --------
    >>> steps, rows = relative_steps([[1.0, 2.0], [3.0, 4.5]], [[1.0, 2.0], [3.0, 4.0]], 4.0)
    >>> steps.tolist(), rows.tolist()
    ([0.0, 0.125], [0, 1])
    """
    value, reference = _compared(value, reference)
    with np.errstate(invalid="ignore"):
        gap = np.abs(value - reference)
    gap = np.where(np.isfinite(gap), gap, np.inf)
    if not per_step or gap.ndim < 2:
        where = np.unravel_index(np.argmax(gap), gap.shape)  # () for a number
        return np.array([np.max(gap) / scale]), np.array([where[0] if where else 0])
    by_row = gap.reshape(gap.shape[0], -1, gap.shape[-1]).max(axis=1)  # (rows, T)
    return by_row.max(axis=0) / scale, np.argmax(by_row, axis=0)


def distance(value: Any, reference: Any, floor: float = 0.0) -> float:
    """``max|value - reference|`` over the larger of their sizes (and ``floor``).

    Symmetric; 0 for equal sets, at most 2 for sets of one sign; infinite for another shape
    or numbers that are not finite. ``floor`` is the log-likelihood's own scale.

    Examples
    --------
    >>> distance([1.0, 2.0], [1.0, 2.5])
    0.2
    >>> distance([1e-6, 0.0], [0.0, 1e-6])  # both small, yet as far apart as can be
    1.0
    >>> distance(-0.25, -0.5, floor=100.0)  # a log-likelihood near zero, its terms near 100
    0.0025
    >>> distance([1.0, 2.0], [[1.0, 2.0]])
    inf
    """
    value, reference = _compared(value, reference)
    if value.shape != reference.shape or not np.isfinite([*value.flat, *reference.flat]).all():
        return float("inf")
    size = max(floor, float(np.max(np.abs(value))), float(np.max(np.abs(reference))))
    return float(np.max(np.abs(value - reference)) / (size or 1.0))


def reproduces(to_suspect: Mapping[str, float], tolerance: float) -> bool:
    """Whether a mistake is within the tolerance of their numbers on every output given.

    Examples
    --------
    >>> reproduces({"z": 1e-9, "x": 2e-7}, 1e-6), reproduces({"z": 1e-9, "x": 2e-6}, 1e-6)
    (True, False)
    """
    return all(d <= tolerance for d in to_suspect.values())


def explains(
    to_suspect: Mapping[str, float], to_expected: Mapping[str, float], tolerance: float
) -> bool:
    """Whether a mistake explains their numbers (the module's rule).

    Parameters
    ----------
    to_suspect : mapping of str to float
        Per output given, the distance of their numbers from the mistake's.
    to_expected : mapping of str to float
        The same outputs' distances from the expected ones.
    tolerance : float
        The tolerance their numbers support.

    Returns
    -------
    bool

    Examples
    --------
    A mistake a thousand times nearer than the expected outputs on the output that
    differs, and within the tolerance on the one that agrees, explains them; one that would
    change the agreeing output does not:

    >>> explains({"z": 1e-5, "x": 1e-9}, {"z": 1e-2, "x": 1e-9}, 1e-6)
    True
    >>> explains({"z": 1e-5, "x": 1e-3}, {"z": 1e-2, "x": 1e-9}, 1e-6)
    False
    """
    return all(
        np.isfinite(d) and d <= max(FACTOR * tolerance, to_expected[name] / NEARER)
        for name, d in to_suspect.items()
    )
