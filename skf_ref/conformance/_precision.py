"""What the precision of their numbers says, when they disagree by about the size of rounding.

Three things are recognized, from the numbers alone:

- every value given is a single-precision number (float32, eps 1.2e-7): an implementation
  in float32, or one that saved its outputs so;
- every value given has at most ``k`` significant decimal digits, 3 <= k <= 12: outputs
  printed to text with ``k`` digits (C++ streams print 6 by default);
- neither, but the differences are no larger than single-precision rounding leaves
  (:data:`~skf_ref.conformance.FLOAT32_TOLERANCE`).

:func:`precision` turns what it finds into one sentence of advice and the tolerance their
numbers support, at which :func:`skf_ref.compare` then looks for known mistakes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._cases import FLOAT32_TOLERANCE

__all__ = ["Precision", "precision"]

#: What correct float32 SKFs reach on the well-conditioned cases, by algorithm, in compare's
#: measure (validation/conformance_suite.md, "Single precision, by algorithm"); the float32
#: tolerance, 1e-4, is above all of them.
FLOAT32_REACH = (
    "correct float32 SKFs reach 3e-6 in covariance form with solves, 7e-6 in Joseph's "
    "form, 1.4e-5 with explicit inverses and 8e-5 in information form on well-conditioned "
    "cases"
)
#: Fewer printed digits than this are no implementation's output (zeros, ones).
_FEWEST_DIGITS = 3
#: More printed digits than this cannot explain a difference over 1e-11.
_MOST_DIGITS = 12


@dataclass(frozen=True)
class Precision:
    """The precision of their numbers, and what it means for the comparison.

    Attributes
    ----------
    numbers : str
        ``"float32"``, ``"<k> significant digits"`` or ``"float64"``.
    tolerance : float
        The tolerance their numbers support: at least the comparison's.
    hint : str or None
        One sentence for the report, or None.
    explains : bool
        Whether their precision explains every difference (then no mistake is looked for).
    """

    numbers: str
    tolerance: float
    hint: str | None
    explains: bool = False


def _values(given):
    """Every finite value given: of the arrays, or the log-likelihood if it is all there is.

    An implementation in float32 may well sum its log-likelihood in double precision.
    """
    arrays = [value for value in given.values() if np.ndim(value)] or list(given.values())
    values = np.concatenate([np.ravel(np.asarray(value, dtype=float)) for value in arrays])
    return values[np.isfinite(values)]


def _short(x):
    """``1e-05`` as ``1e-5``."""
    return f"{x:.0e}".replace("e-0", "e-").replace("e+0", "e+")


def _is_float32(values):
    with np.errstate(over="ignore"):
        return bool(np.all(values.astype(np.float32).astype(float) == values))


def _digits(values):
    """The fewest significant digits ``k`` that print every value exactly, or None."""
    for k in range(1, _MOST_DIGITS + 1):
        if all(float(f"{value:.{k}g}") == value for value in values):
            return k
    return None


def precision(given: dict[str, Any], difference: float, tolerance: float) -> Precision:
    """What their numbers' precision says about a difference over the tolerance.

    Parameters
    ----------
    given : dict
        Their outputs by name: arrays and the log-likelihood.
    difference : float
        The largest relative difference from the expected outputs, over those given.
    tolerance : float
        The comparison's tolerance.

    Returns
    -------
    Precision

    Examples
    --------
    >>> z = np.array([[0.1234567891, 2.5]])
    >>> precision({"z": z.astype(np.float32)}, 3e-6, 1e-6).numbers
    'float32'
    >>> printed = precision({"z": np.round(z, 6)}, 3e-6, 1e-6)
    >>> printed.numbers, printed.tolerance, printed.explains
    ('6 significant digits', 1e-05, True)
    >>> print(printed.hint)
    Your numbers carry 6 significant digits (as printed to text), and the differences (at
    most 3.0e-06) are the rounding of printing 6 digits: they agree to the precision given.
    Print 17 significant digits (%.17g) to compare at 1e-6, or use --tolerance 1e-5.
    """
    hint: str | None
    values = _values(given)
    digits = _digits(values)
    if digits is not None and digits >= _FEWEST_DIGITS:
        supported = 10.0 ** (1 - digits)
        numbers = f"{digits} significant digits"
        intro = f"Your numbers carry {numbers} (as printed to text), and the differences"
        explains = difference <= supported
        if explains:
            hint = (
                f"{intro} (at most {difference:.1e}) are the rounding of printing {digits} "
                f"digits: they agree to the precision given. Print 17 significant digits "
                f"(%.17g) to compare at {_short(tolerance)}, or use --tolerance "
                f"{_short(supported)}."
            )
        else:
            hint = (
                f"{intro} exceed what printing {digits} digits explains ({_short(supported)}). "
                "Print 17 significant digits (%.17g)."
            )
        return Precision(numbers, max(tolerance, supported), hint, explains)
    single = _short(FLOAT32_TOLERANCE)
    if _is_float32(values):
        intro = "Your numbers are single precision (float32: every value given is one)"
        explains = difference <= FLOAT32_TOLERANCE
        if explains:
            hint = (
                f"{intro}, and the differences (at most {difference:.1e}) are float32 "
                f"rounding ({FLOAT32_REACH}). It agrees to float32 precision: use "
                f"--tolerance {single}."
            )
        else:
            hint = (
                f"{intro}, and differ by more than float32 rounding leaves on a "
                f"well-conditioned case ({single}; {FLOAT32_REACH}): run in double precision "
                "to tell rounding from a mistake."
            )
        return Precision("float32", max(tolerance, FLOAT32_TOLERANCE), hint, explains)
    hint = None
    if difference <= FLOAT32_TOLERANCE:
        hint = (
            f"The differences (at most {difference:.1e}) have the size of single-precision "
            "rounding: if your implementation computes in float32, it agrees to float32 "
            f"precision: use --tolerance {single}. In double precision they stay below 1e-10."
        )
    return Precision("float64", tolerance, hint)
