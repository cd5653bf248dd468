"""The priors :func:`skf_ref.tune` searches: their ranges, checks, bounds and warnings.

A prior the data choose has a search range: the PM-SNR and the EP-SNR of the paper's random
walk in dB (docs/model.md §4), or the time constant of the stationary AR(1) prior in
milliseconds, searched in ``log(tau)``. Inside :func:`~skf_ref.method._tuning.tune` every
searched prior is a *level* in dB: the SNRs as they are, a time constant as
``10 log10(tau / 1 ms)``, so that one grid, one refinement and one bound tolerance
(``BOUND_TOL_DB``, 0.01 dB: 0.23 % of a time constant) serve both.

A searched prior chosen on an end of its range is reported: the criterion would have gone
further, so the range, not the data, made the choice. :func:`warn_at_bound` warns
(``UserWarning``), naming the parameter, the bound and a wider range to give.
"""

import math
import warnings
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._utils.checks import MAX_DB, InputError, check_db, check_real, describe
from .._utils.log import caller_stacklevel
from ._units import current_cause

__all__ = [
    "AUTO_RANGE_DB",
    "AUTO_TIME_CONSTANT_MS",
    "BOUND_TOL_DB",
    "TimeConstant",
    "at_bound",
    "check_one_evolution_prior",
    "check_time_constant",
    "search_range",
    "time_constant_levels",
    "warn_at_bound",
]

#: The SNRs searched for ``"auto"`` (dB): the span of the paper's finer map.
AUTO_RANGE_DB = (-20.0, 40.0)
#: The time constants searched for ``"auto"`` (ms), in log(tau): from a fraction of a sample
#: at the usual rates to a second, longer than an evoked response's components.
AUTO_TIME_CONSTANT_MS = (1.0, 1000.0)
#: A searched prior this close (dB; for a time constant, of ``10 log10 tau``) to an end of
#: its range is on that bound.
BOUND_TOL_DB = 0.01
_ENDS = ("lower", "upper")

#: A time constant as a route holds it: a number (ms), ``"auto"``, or a range (low, high).
TimeConstant = float | str | tuple[float, float]


def check_one_evolution_prior(ep_snr_db: Any, time_constant_ms: Any) -> None:
    """Refuse an EP-SNR and a time constant given together: each sets the evolution prior.

    Parameters
    ----------
    ep_snr_db, time_constant_ms : object
        As given; None means not given.

    Examples
    --------
    >>> check_one_evolution_prior(20.0, 15.0)
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: give ep_snr_db (the paper's random walk) or \
time_constant_ms (the stationary AR(1) prior), not both: got ep_snr_db=20.0 and \
time_constant_ms=15.0
    """
    if ep_snr_db is not None and time_constant_ms is not None:
        raise InputError(
            "give ep_snr_db (the paper's random walk) or time_constant_ms (the stationary "
            f"AR(1) prior), not both: got ep_snr_db={ep_snr_db!r} and "
            f"time_constant_ms={time_constant_ms!r}"
        )


def check_time_constant(value: Any, name: str = "time_constant_ms") -> TimeConstant:
    """A time constant: a number of milliseconds > 0, ``"auto"``, or a range ``(low, high)``.

    ``"auto"`` and a range are searched in ``log(tau)`` by the marginal likelihood
    (:func:`skf_ref.tune`; ``"auto"`` is ``AUTO_TIME_CONSTANT_MS``, 1 to 1000 ms).

    Parameters
    ----------
    value : float or "auto" or (float, float)
    name : str
        The parameter, for the messages.

    Returns
    -------
    float or "auto" or (float, float)

    Examples
    --------
    >>> check_time_constant(20), check_time_constant("auto"), check_time_constant([2, 200])
    (20.0, 'auto', (2.0, 200.0))
    >>> check_time_constant(0)
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: time_constant_ms must be > 0, got 0.0
    """
    return check_searched(name, value, "a number of milliseconds", "ms", _milliseconds)


def check_searched(
    name: str, value: Any, number: str, unit: str, check_number: Any
) -> float | str | tuple[float, float]:
    """A prior the routes take: a number, ``"auto"``, or a search range ``(low, high)``.

    The one check of both kinds (SNRs in dB, time constants in ms).

    Parameters
    ----------
    name : str
        The parameter, for the messages.
    value : float or "auto" or (float, float)
    number : str
        What a number is, for the messages (``"a number (dB)"``).
    unit : str
        The range's unit, for the messages (``"dB"``).
    check_number : callable
        ``check_number(name, value) -> float``: one number, checked.

    Returns
    -------
    float or "auto" or (float, float)

    Examples
    --------
    >>> check_searched("ep_snr_db", (0, 20), "a number (dB)", "dB", check_db)
    (0.0, 20.0)
    """
    if isinstance(value, str) and value == "auto":
        return value
    if isinstance(value, str) or np.ndim(value) > 1 or np.size(value) not in (1, 2):
        raise InputError(
            f"{name} must be {number}, 'auto' or a search range (low, high) in {unit}, got "
            f"{describe(value)}"
        )
    if np.ndim(value) == 0:
        return float(check_number(name, value))
    low, high = (float(check_number(f"{name}[{i}]", v)) for i, v in enumerate(value))
    if not low < high:
        raise InputError(
            f"{name} must be a range (low, high) with low < high, got ({low:g}, {high:g}); "
            "give one number to fix it"
        )
    return (low, high)


def _milliseconds(name: str, value: Any) -> float:
    """A time constant > 0 whose level ``10 log10 tau`` is inside +-MAX_DB."""
    value = check_real(name, value, positive=True)
    if abs(10 * math.log10(value)) > MAX_DB:
        raise InputError(f"{name} must be within 1e-30 .. 1e30 ms, got {value!r}")
    return value


def search_range(name: str, value: Any) -> tuple[float, float]:
    """A fixed SNR (one number), a search range (lo, hi), lo < hi, or "auto", in dB.

    Parameters
    ----------
    name : str
    value : float or (float, float) or "auto"

    Returns
    -------
    (float, float)
        ``lo == hi`` for a fixed SNR.
    """
    if isinstance(value, str) and value == "auto":
        return AUTO_RANGE_DB
    if np.ndim(value) == 0:
        return (check_db(name, value),) * 2
    if isinstance(value, str) or len(value) != 2:
        raise InputError(f"{name} must be a number or a range (lo, hi), got {describe(value)}")
    low, high = (check_db(f"{name}[{i}]", v) for i, v in enumerate(value))
    if not low < high:
        raise InputError(
            f"{name} must be a range (lo, hi) with lo < hi, got ({low:g}, {high:g}); give one "
            "number to fix it"
        )
    return low, high


def time_constant_levels(value: Any) -> tuple[float, float]:
    """A checked time constant (:func:`check_time_constant`) as levels ``10 log10 tau``.

    Parameters
    ----------
    value : float or "auto" or (float, float)

    Returns
    -------
    (float, float)
        ``lo == hi`` for a fixed time constant.

    Examples
    --------
    >>> time_constant_levels("auto"), time_constant_levels(10.0)
    ((0.0, 30.0), (10.0, 10.0))
    """
    value = AUTO_TIME_CONSTANT_MS if isinstance(value, str) else value
    low, high = (value, value) if np.ndim(value) == 0 else value
    return 10 * math.log10(low), 10 * math.log10(high)


def at_bound(
    names: tuple[str, str], best: NDArray[np.float64], ranges: list[tuple[float, float]]
) -> dict[str, str]:
    """Searched priors within BOUND_TOL_DB of an end of their range -> "lower" or "upper".

    Parameters
    ----------
    names : (str, str)
        The parameters of the two coordinates (``"pm_snr_db"``, then ``"ep_snr_db"`` or
        ``"time_constant_ms"``).
    best : ndarray, shape (2,)
        The chosen levels (dB).
    ranges : list of (float, float)
        Their ranges, in levels; ``lo == hi`` for a fixed prior.

    Returns
    -------
    dict
    """
    out = {}
    for name, value, (low, high) in zip(names, best, ranges, strict=True):
        if low < high:
            for end, bound in zip(_ENDS, (low, high), strict=True):
                if abs(value - bound) <= BOUND_TOL_DB:
                    out[name] = end
    return out


def warn_at_bound(
    at_bound: dict[str, str],
    names: tuple[str, str],
    best: NDArray[np.float64],
    ranges: list[tuple[float, float]],
    criterion: str,
) -> None:
    """One UserWarning per prior on a bound, pointing at the first caller outside skf_ref.

    Parameters
    ----------
    at_bound : dict
        :func:`at_bound`'s answer.
    names, best, ranges
        As for :func:`at_bound`.
    criterion : {"likelihood", "discrepancy"}
        What chose them (the message says why the bound was reached).
    """
    for name, end in at_bound.items():
        i = names.index(name)
        low, high = ranges[i]
        if criterion == "discrepancy" and name == "ep_snr_db":
            why = "the filtered residual meets its expected value only there or beyond"
        elif criterion == "discrepancy":
            why = "the likelihood along the discrepancy curve is largest there or beyond"
        else:
            why = "the marginal likelihood is largest there or beyond"
        further = "below" if end == "lower" else "above"
        if name == "time_constant_ms":  # levels to milliseconds; a decade wider
            low, high = 10 ** (low / 10), 10 ** (high / 10)
            value, unit = f"{10 ** (best[i] / 10):.3g}", " ms"
            wider = (low / 10, high) if end == "lower" else (low, high * 10)
        else:
            value, unit = f"{best[i]:.2f}", " dB"
            wider = (
                (max(low - 20, -MAX_DB), high) if end == "lower" else (low, min(high + 20, MAX_DB))
            )
        bound = (low, high)[_ENDS.index(end)]
        said = (
            f"tune: {name} = {value}{unit} lies on the {end} bound {bound:g}{unit} of its "
            f"search range ({low:g}, {high:g}): {why}"
        )
        units = current_cause()
        if units is not None:  # the units, not the range: widening it would not help
            warnings.warn(
                f"{said}; the likely cause is the units, not the range (widening it will not "
                f"help): {units}",
                UserWarning,
                stacklevel=caller_stacklevel(),
            )
            continue
        warnings.warn(
            f"{said}; widen {name} {further} {bound:g}{unit} "
            f"to let the data choose: {name}=({wider[0]:g}, {wider[1]:g}) in Python (tune, "
            f"apply_skf, make_skf_operator) or --{name.replace('_', '-')}="
            f"{wider[0]:g},{wider[1]:g} on the command line",
            UserWarning,
            stacklevel=caller_stacklevel(),
        )
