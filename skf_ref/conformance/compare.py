"""Compare another SKF's outputs with a conformance case, and name the likely mistake.

:func:`compare` takes a case (:mod:`skf_ref.conformance`) and the outputs of the
implementation under test ("theirs"): a ``.npz`` or ``.mat`` file holding any of the
output names, a ``.csv`` long table, a mapping of names to arrays, or a
:class:`~skf_ref.Reconstruction` (:mod:`skf_ref.conformance.their_outputs`). For each output
given it reports the largest relative difference, ``max|theirs - expected| / max|expected|``,
the first time step where it exceeds the tolerance, and a verdict. An output of shape
(n_times, n_sources) is compared as its transpose and reported as transposed; any other
shape is refused.

When an output disagrees:

- what the precision of their numbers says (:mod:`skf_ref.conformance.precision`): float32
  numbers, or a few printed digits, that agree to that precision are told so;
- every known mistake of :mod:`skf_ref.conformance.mistakes` that applies to the case is
  computed, and those that reproduce their numbers to the tolerance their precision
  supports are named. Otherwise the closest mistake is named only when it is closer to
  their numbers than the expected outputs are.
"""

from __future__ import annotations

import os
from functools import lru_cache
from typing import Any

import numpy as np

from .._utils.checks import InputError, check_path, check_real
from .case_files import read_case
from .cases import OUTPUTS, Case
from .mistakes import SUSPECTS
from .precision import Precision, precision
from .suite import check_pinned
from .their_outputs import checked, read_outputs

__all__ = ["Comparison", "compare", "read_outputs"]


def _steps(value, expected):
    """The relative difference at each time step (one value for the log-likelihood)."""
    value, expected = np.atleast_2d(value), np.atleast_2d(expected)
    scale = np.max(np.abs(expected)) or 1.0
    with np.errstate(invalid="ignore"):
        steps = np.max(np.abs(value - expected), axis=0) / scale
    return np.where(np.isfinite(steps), steps, np.inf)


def _distance(value, expected):
    if np.shape(value) != np.shape(expected):
        return np.inf
    return float(np.max(_steps(value, expected)))


def _row(name, value, expected, tolerance):
    transposed = np.ndim(value) == 2 and np.shape(value) != np.shape(expected)
    steps = _steps(value.T if transposed else value, expected)
    over = np.flatnonzero(steps > tolerance)
    return {
        "output": name,
        "shape": "scalar" if np.ndim(expected) == 0 else str(np.shape(value)),
        "layout": "transposed" if transposed else "as expected",
        "largest_difference": float(np.max(steps)),
        "first_step": int(over[0]) + 1 if over.size and np.ndim(expected) else None,
        "verdict": "agrees" if not over.size and not transposed else "disagrees",
    }


@lru_cache(maxsize=32)
def _mistaken(case):
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


def _diagnose(case, given, tolerance):
    """Every suspect that applies: its distance to their numbers and whether it matches."""
    found = []
    for suspect, outputs in _mistaken(case):
        distance = max(_distance(given[name], outputs[name]) for name in given)
        summary = " ".join(suspect.description.split("\n\n")[0].replace("``", "").split())
        found.append(
            {
                "name": suspect.name,
                "description": summary,
                "distance": distance,
                "matches": bool(distance <= tolerance),
            }
        )
    return found


def compare(
    case: Case | str | os.PathLike, theirs: Any, *, tolerance: float | None = None
) -> Comparison:
    """Compare another implementation's outputs with a conformance case.

    Parameters
    ----------
    case : Case or path-like
        A case, or its ``.npz`` / ``.mat`` file (``skf-ref conformance export``).
    theirs : path-like, mapping or Reconstruction
        Their outputs, any of ``z``, ``z_filtered``, ``x``, ``x_filtered``, ``weights``
        ((n_sources, n_times)) and ``log_likelihood``: a ``.npz``, ``.mat`` or long-table
        ``.csv`` file (:mod:`skf_ref.conformance.their_outputs`), a mapping, or a
        Reconstruction.
    tolerance : float, optional
        Largest relative difference that agrees; default the case's own (1e-6).

    Returns
    -------
    Comparison

    Raises
    ------
    skf_ref.InputError
        If their outputs are unusable: none of the output names, a wrong shape (the
        message names the output and the shape expected), complex numbers; or if the case
        file says it is one of the pinned suite's and is not its bytes (its sha256 is not the
        manifest's).

    Examples
    --------
    >>> from skf_ref.conformance import cases
    >>> case = cases()[0]
    >>> compare(case, case.reconstruct("filterpy")).agrees
    True
    >>> mistaken = {"z": case.reconstruct(exponent=0.25).z}  # w ** (-alpha / 2)
    >>> result = compare(case, mistaken)
    >>> result.agrees, result.diagnosis
    (False, ['exponent_on_square_root'])
    """
    if not isinstance(case, Case):
        path = check_path("case", case)
        case = read_case(path)
        check_pinned(path, case)
    if tolerance is None:
        tolerance = case.tolerance
    tolerance = check_real("tolerance", tolerance, positive=True)
    variables, source = read_outputs(theirs)
    given = {
        name: checked(name, variables[name], case.shape, source)
        for name in OUTPUTS
        if name in variables
    }
    if not given:
        raise InputError(
            f"{source} holds none of the outputs {', '.join(OUTPUTS)}; it holds "
            f"{sorted(variables)}"
        )
    rows = [_row(name, value, case.expected[name], tolerance) for name, value in given.items()]
    ignored = sorted(set(variables) - set(OUTPUTS))
    result = Comparison(case.name, source, tolerance, rows, [], ignored)
    if not result.agrees:
        # how far the expected outputs are from theirs, a transposed output counting as far
        result.difference = max(_distance(given[k], case.expected[k]) for k in given)
        supported = precision(given, max(row["largest_difference"] for row in rows), tolerance)
        result.precision = supported
        result.suspects = _diagnose(case, given, supported.tolerance)
    return result


class Comparison:
    """The outcome of :func:`compare`: per output, a verdict; when wrong, the likely mistake.

    Attributes
    ----------
    case : str
    source : str
        What their outputs came from (a file name).
    tolerance : float
    rows : list of dict
        One per output given: ``output``, ``shape``, ``layout`` (``"as expected"`` or
        ``"transposed"``), ``largest_difference``, ``first_step`` (counting from 1; None
        when within the tolerance or for the log-likelihood), ``verdict``.
    suspects : list of dict
        Each known mistake checked (none when everything agrees): ``name``,
        ``description``, ``distance`` (largest relative difference from their numbers),
        ``matches``.
    ignored : list of str
        Names in their file that are not outputs.
    difference : float or None
        When something disagrees, the largest relative difference between their numbers and
        the expected ones (infinite for a transposed output): what a suspect must beat to be
        called the closest.
    precision : skf_ref.conformance.precision.Precision or None
        When something disagrees, what the precision of their numbers says (its ``hint``),
        and the tolerance the suspects are matched at (their precision's, at least the
        comparison's).
    """

    def __init__(
        self,
        case: str,
        source: str,
        tolerance: float,
        rows: list[dict],
        suspects: list[dict],
        ignored: list[str],
    ) -> None:
        self.case, self.source, self.tolerance = case, source, tolerance
        self.rows, self.suspects, self.ignored = rows, suspects, ignored
        self.difference: float | None = None
        self.precision: Precision | None = None

    @property
    def agrees(self) -> bool:
        """bool : Whether every output given agrees."""
        return all(row["verdict"] == "agrees" for row in self.rows)

    @property
    def exit_status(self) -> int:
        """int : 0 when everything given agrees, 1 otherwise (``skf-ref compare``)."""
        return 0 if self.agrees else 1

    @property
    def diagnosis(self) -> list[str]:
        """list of str : The known mistakes that reproduce their numbers."""
        return [suspect["name"] for suspect in self.suspects if suspect["matches"]]

    @property
    def closest(self) -> str | None:
        """str or None : The suspect nearest their numbers, if nearer than the expected outputs."""
        nearest = min(self.suspects, key=lambda suspect: suspect["distance"], default=None)
        if nearest is None or not nearest["distance"] < self.difference:
            return None
        return nearest["name"]

    @property
    def hint(self) -> str | None:
        """str or None : What the precision of their numbers says, when something disagrees."""
        return None if self.precision is None else self.precision.hint

    def to_dict(self) -> dict[str, Any]:
        """dict : Everything, as plain Python values (for JSON)."""
        keys = ("case", "source", "tolerance", "rows", "suspects", "ignored", "difference")
        return {key: getattr(self, key) for key in keys} | {
            "agrees": self.agrees,
            "diagnosis": self.diagnosis,
            "closest": None if self.diagnosis else self.closest,
            "numbers": None if self.precision is None else self.precision.numbers,
            "hint": self.hint,
        }

    def to_frame(self) -> Any:
        """pandas.DataFrame : One row per output given, indexed by the output's name."""
        import pandas as pd

        return pd.DataFrame(self.rows).set_index("output")

    def __repr__(self) -> str:
        verdict = "agrees" if self.agrees else "disagrees"
        return f"<Comparison | case {self.case}, {len(self.rows)} outputs, {verdict}>"

    def __str__(self) -> str:
        return self.report()

    def report(self) -> str:
        """The comparison as text: a table of the outputs, a verdict and the likely cause.

        Returns
        -------
        str
        """
        lines = [
            f"case {self.case} against {self.source}; tolerance {self.tolerance:.0e} "
            "(largest |theirs - expected| / largest |expected|)",
            "",
            f"{'output':<15} {'shape':<9} {'difference':>10}  {'first step over':<16} verdict",
        ]
        for row in self.rows:
            step = "-" if row["first_step"] is None else str(row["first_step"])
            verdict = row["verdict"] + (" (transposed)" if row["layout"] == "transposed" else "")
            lines.append(
                f"{row['output']:<15} {row['shape']:<9} {row['largest_difference']:>10.1e}  "
                f"{step:<16} {verdict}"
            )
        lines.append("")
        lines += self._verdict()
        if self.ignored:
            lines.append(f"Not outputs, ignored: {', '.join(self.ignored)}.")
        return "\n".join(lines)

    def _verdict(self):
        wrong = [row["output"] for row in self.rows if row["verdict"] != "agrees"]
        if not wrong:
            return ["AGREES: every output given is within the tolerance."]
        transposed = [row["output"] for row in self.rows if row["layout"] == "transposed"]
        lines = [f"DISAGREES: {', '.join(wrong)}."]
        if transposed:
            lines.append(
                f"Transposed: {', '.join(transposed)} given as (n_times, n_sources); the "
                "differences above are those of the transpose."
            )
        if self.hint:
            lines.append(self.hint)
        matches = [suspect for suspect in self.suspects if suspect["matches"]]
        for suspect in matches:
            lines.append(
                f"Likely cause: {suspect['name']}, which reproduces these numbers to "
                f"{suspect['distance']:.0e}: {suspect['description']}"
            )
        if len(matches) > 1:
            lines.append("The outputs given cannot tell these apart; give all six.")
        if matches or (self.precision is not None and self.precision.explains):
            return lines
        checked_names = ", ".join(suspect["name"] for suspect in self.suspects)
        lines.append(f"No known mistake reproduces these numbers (checked: {checked_names}).")
        closest = self.closest
        if closest is not None:
            suspect = next(s for s in self.suspects if s["name"] == closest)
            lines.append(
                f"Closest: {closest}, off by {suspect['distance']:.1e} where the expected "
                f"outputs are off by {self.difference:.1e}: {suspect['description']}"
            )
        elif self.suspects:
            lines.append("None comes closer to them than the expected outputs.")
        return lines
