"""Which known mistakes explain their outputs, by the rule of :mod:`._distances`.

Every mistake of :mod:`skf_ref.conformance._mistakes` that applies to the case is computed
(once per case), and measured against their outputs output by output, in the measure
between two sets (:func:`~skf_ref.conformance._distances.distance`): the log-likelihood
over the sizes of its terms, so that one near zero does not dominate. A mistake is the
*likely cause* when it reproduces every output given within the tolerance their numbers
support; it is *shown as the nearest* only when it explains them (within
:data:`~skf_ref.conformance._distances.FACTOR` tolerances, or
:data:`~skf_ref.conformance._distances.NEARER` times nearer than the expected outputs, on
every output given). Otherwise nothing is suggested.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from typing import Any

import numpy as np

from .._utils.checks import InputError
from ._distances import distance, explains, reproduces
from ._mistakes import SUSPECTS

__all__ = ["diagnose", "distances"]


@lru_cache(maxsize=32)
def _mistaken(case: Any) -> tuple:
    """Each suspect that applies to the case, with its outputs (computed once per case)."""
    found = []
    for suspect in SUSPECTS:
        try:
            outputs = suspect.compute(case)
        except (InputError, np.linalg.LinAlgError):  # the mistake breaks this case outright
            continue
        if outputs is not None:
            found.append((suspect, outputs))
    return tuple(found)


def distances(
    given: Mapping[str, Any], other: Mapping[str, Any], scales: Mapping[str, float]
) -> dict[str, float]:
    """Per output given, its distance from ``other``'s (the log-likelihood over its terms).

    Parameters
    ----------
    given : mapping
        Their outputs, as they gave them (a transposed one is at an infinite distance).
    other : mapping
        The expected outputs, or a mistake's.
    scales : mapping
        Each output's own scale; only the log-likelihood's is used.

    Returns
    -------
    dict of str to float
    """
    floor = {"log_likelihood": scales["log_likelihood"]}
    return {k: distance(v, other[k], floor.get(k, 0.0)) for k, v in given.items()}


def diagnose(
    case: Any,
    given: Mapping[str, Any],
    to_expected: Mapping[str, float],
    scales: Mapping[str, float],
    tolerance: float,
) -> list[dict[str, Any]]:
    """Every known mistake that applies to the case, measured against their outputs.

    Parameters
    ----------
    case : Case
    given : mapping
        Their outputs (not the intermediates: the mistakes compute outputs).
    to_expected : mapping of str to float
        Per output given, its distance from the expected one (:func:`distances`).
    scales : mapping of str to float
    tolerance : float
        The tolerance their numbers support.

    Returns
    -------
    list of dict
        ``name``, ``description``, ``distance`` (the largest over the outputs given),
        ``matches`` (reproduces their outputs) and ``explains`` (the rule above).
    """
    found = []
    for suspect, outputs in _mistaken(case):
        to_suspect = distances(given, outputs, scales)
        summary = " ".join(suspect.description.split("\n\n")[0].replace("``", "").split())
        found.append(
            {
                "name": suspect.name,
                "description": summary,
                "distance": max(to_suspect.values()),
                "matches": reproduces(to_suspect, tolerance),
                "explains": explains(to_suspect, to_expected, tolerance),
            }
        )
    return found
