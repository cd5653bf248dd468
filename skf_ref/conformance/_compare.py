"""Compare another SKF's outputs with a conformance case: where it first goes wrong, and why.

:func:`compare` takes a case (:mod:`skf_ref.conformance`) and the outputs of the
implementation under test ("theirs"): a ``.npz`` or ``.mat`` file holding any of the
output names, a ``.csv`` long table, a mapping of names to arrays, or a
:class:`~skf_ref.Reconstruction` (:mod:`skf_ref.conformance._their_outputs`), and, in a file
or a mapping, any of the intermediate quantities (``P_pred``, ``S``, ``K``, ...,
:mod:`skf_ref.conformance._intermediates`). For each variable given it reports the largest
difference at a step over the variable's own scale (``max|expected|``; for the
log-likelihood the sum of the sizes of its terms), the first time step where it exceeds the
tolerance, and a verdict. An output of shape (n_times, n_sources) is compared as its
transpose and reported as transposed; any other shape is refused.

When something disagrees:

- the *first divergence* (:mod:`skf_ref.conformance._divergence`): the first variable
  given, in the order the equations produce them, that leaves the tolerance, with its
  quantity, equation, step and row;
- what the precision of their numbers says (:mod:`skf_ref.conformance._precision`): float32
  numbers, or a few printed digits, that agree to that precision are told so;
- the known mistakes of :mod:`skf_ref.conformance._mistakes` that reproduce their outputs,
  or, failing that, the nearest one only if it explains them
  (:mod:`skf_ref.conformance._suspects`); otherwise none is suggested.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from .._utils.checks import InputError, check_path, check_real
from ._case_files import read_case
from ._cases import OUTPUTS, Case
from ._distances import FACTOR, NEARER, relative_steps
from ._divergence import Divergence, first_divergence
from ._expected import expected_variables
from ._intermediates import NAMES, checked_intermediate, variables
from ._precision import Precision, precision
from ._suite import check_pinned
from ._suspects import diagnose, distances
from ._their_outputs import checked, read_outputs

__all__ = ["Comparison", "compare", "read_outputs"]

#: The intermediates an implementation may give besides its outputs.
_INTERMEDIATES = tuple(name for name in NAMES if name not in OUTPUTS)


def _their_variables(case, theirs):
    """Their outputs and intermediates, checked; the names left out; the source's name."""
    found, source = read_outputs(theirs)
    outputs = {
        name: checked(name, found[name], case.shape, source) for name in OUTPUTS if name in found
    }
    if not outputs:
        raise InputError(
            f"{source} holds none of the outputs {', '.join(OUTPUTS)}; it holds {sorted(found)}"
        )
    expected, _ = expected_variables(case)
    defined = variables(case.inputs["smoother"])
    (n_channels, _), (n_sources, n_times) = case.inputs["L"].shape, case.shape
    intermediates = {
        name: checked_intermediate(name, found[name], n_channels, n_sources, n_times, source)
        for name in _INTERMEDIATES
        if name in found and name in defined and name in expected
    }
    return outputs, intermediates, sorted(set(found) - set(outputs) - set(intermediates)), source


def _row(name, value, expected, scale, tolerance, per_step):
    """One variable's line of the table; ``compared`` is its value as compared."""
    transposed = name in OUTPUTS and np.ndim(value) == 2 and np.shape(value) != np.shape(expected)
    compared = value.T if transposed else value
    steps, _ = relative_steps(compared, expected, scale, per_step)
    over = np.flatnonzero(steps > tolerance)
    layout = "transposed" if transposed else "as expected"
    if np.ndim(value) == 2 and np.ndim(expected) == 3:
        layout = "diagonal"
    row = {
        "output": name,
        "shape": "scalar" if np.ndim(value) == 0 else str(np.shape(value)),
        "layout": layout,
        "largest_difference": float(np.max(steps)),
        "first_step": int(over[0]) + 1 if over.size and per_step else None,
        "verdict": "agrees" if not over.size and not transposed else "disagrees",
    }
    return row, compared


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
        ``.csv`` file (:mod:`skf_ref.conformance._their_outputs`), a mapping, or a
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
    outputs, intermediates, ignored, source = _their_variables(case, theirs)
    expected, scales = expected_variables(case)
    defined = variables(case.inputs["smoother"])
    rows, compared = [], {}
    for name, value in (outputs | intermediates).items():
        per_step = defined[name].stage not in ("once", "end")
        row, compared[name] = _row(name, value, expected[name], scales[name], tolerance, per_step)
        rows.append(row)
    result = Comparison(case.name, source, tolerance, rows, [], ignored)
    result.difference = max(row["largest_difference"] for row in rows)
    if not result.agrees:
        largest = max(row["largest_difference"] for row in rows if row["output"] in outputs)
        supported = precision(outputs, largest, tolerance)
        result.precision = supported
        result.divergence = first_divergence(
            compared, expected, scales, case.inputs["smoother"], case.shape[1],
            supported.tolerance,
        )  # fmt: skip
        to_expected = distances(outputs, expected, scales)
        result.suspects = diagnose(case, outputs, to_expected, scales, supported.tolerance)
    return result


class Comparison:
    """The outcome of :func:`compare`: per variable, a verdict; when wrong, where and why.

    Attributes
    ----------
    case : str
    source : str
        What their outputs came from (a file name).
    tolerance : float
    rows : list of dict
        One per output or intermediate given: ``output``, ``shape``, ``layout`` (``"as
        expected"``, ``"transposed"``, or ``"diagonal"`` for a covariance given by its
        diagonal), ``largest_difference`` (at a step, over the variable's own scale),
        ``first_step`` (counting from 1; None when within the tolerance or for what has no
        step), ``verdict``.
    suspects : list of dict
        Each known mistake checked (none when everything agrees): ``name``,
        ``description``, ``distance`` (the largest over the outputs given, in the measure
        between two sets), ``matches`` (reproduces their outputs), ``explains``.
    ignored : list of str
        Names in their file that are neither outputs nor intermediates of this case.
    difference : float
        The largest of the rows' differences: 0 when their numbers equal the expected ones,
        infinite only when some are not finite.
    precision : skf_ref.conformance._precision.Precision or None
        When something disagrees, what the precision of their numbers says (its ``hint``),
        and the tolerance the first divergence and the suspects are judged at (their
        precision's, at least the comparison's).
    divergence : Divergence or None
        When something disagrees beyond what their precision explains, the first variable
        given, in the order the equations produce them, that leaves the tolerance.
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
        self.difference = 0.0
        self.precision: Precision | None = None
        self.divergence: Divergence | None = None

    @property
    def agrees(self) -> bool:
        """bool : Whether every variable given agrees."""
        return all(row["verdict"] == "agrees" for row in self.rows)

    @property
    def exit_status(self) -> int:
        """int : 0 when everything given agrees, 1 otherwise (``skf-ref compare``)."""
        return 0 if self.agrees else 1

    @property
    def diagnosis(self) -> list[str]:
        """list of str : The known mistakes that reproduce their outputs."""
        return [suspect["name"] for suspect in self.suspects if suspect["matches"]]

    @property
    def closest(self) -> str | None:
        """str or None : The nearest known mistake that explains their outputs, if any."""
        explaining = [suspect for suspect in self.suspects if suspect["explains"]]
        nearest = min(explaining, key=lambda suspect: suspect["distance"], default=None)
        return None if nearest is None else nearest["name"]

    @property
    def first_divergence(self) -> dict[str, Any] | None:
        """Where their numbers first leave the tolerance, as plain values (for JSON).

        Returns
        -------
        dict or None
            ``quantity``, ``equation``, ``step`` and ``source`` (counting from 1), ``output``,
            ``difference`` and ``not_given`` of :attr:`divergence`; None when nothing
            diverges.
        """
        return None if self.divergence is None else self.divergence.to_dict()

    @property
    def hint(self) -> str | None:
        """str or None : What the precision of their numbers says, when something disagrees."""
        return None if self.precision is None else self.precision.hint

    def to_dict(self) -> dict[str, Any]:
        """dict : Everything, as plain Python values (for JSON)."""
        keys = ("case", "source", "tolerance", "rows", "suspects", "ignored", "difference")
        return {key: getattr(self, key) for key in keys} | {
            "agrees": self.agrees,
            "first_divergence": self.first_divergence,
            "diagnosis": self.diagnosis,
            "closest": None if self.diagnosis else self.closest,
            "numbers": None if self.precision is None else self.precision.numbers,
            "hint": self.hint,
        }

    def to_frame(self) -> Any:
        """pandas.DataFrame : One row per variable given, indexed by its name."""
        import pandas as pd

        return pd.DataFrame(self.rows).set_index("output")

    def __repr__(self) -> str:
        verdict = "agrees" if self.agrees else "disagrees"
        return f"<Comparison | case {self.case}, {len(self.rows)} variables, {verdict}>"

    def __str__(self) -> str:
        return self.report()

    def report(self) -> str:
        """The comparison as text: a table, a verdict, where it first goes wrong and why.

        Returns
        -------
        str
        """
        lines = [
            f"case {self.case} against {self.source}; tolerance {self.tolerance:.0e} "
            "(largest |theirs - expected| at a step / the variable's own scale)",
            "",
            f"{'output':<15} {'shape':<13} {'difference':>10}  {'first step over':<16} verdict",
        ]
        for row in self.rows:
            step = "-" if row["first_step"] is None else str(row["first_step"])
            verdict = row["verdict"] + (" (transposed)" if row["layout"] == "transposed" else "")
            verdict += " (diagonal)" if row["layout"] == "diagonal" else ""
            lines.append(
                f"{row['output']:<15} {row['shape']:<13} {row['largest_difference']:>10.1e}  "
                f"{step:<16} {verdict}"
            )
        lines.append("")
        lines += self._verdict()
        if self.ignored:
            lines.append(f"Not outputs or intermediates of this case, ignored: "
                         f"{', '.join(self.ignored)}.")  # fmt: skip
        return "\n".join(lines)

    def _verdict(self):
        wrong = [row["output"] for row in self.rows if row["verdict"] != "agrees"]
        if not wrong:
            return ["AGREES: everything given is within the tolerance."]
        transposed = [row["output"] for row in self.rows if row["layout"] == "transposed"]
        lines = [f"DISAGREES: {', '.join(wrong)}."]
        if transposed:
            lines.append(
                f"Transposed: {', '.join(transposed)} given as (n_times, n_sources); the "
                "differences above are those of the transpose."
            )
        if self.hint:
            lines.append(self.hint)
        if self.divergence is not None:
            lines += self.divergence.report()
        return lines + self._suspects()

    def _suspects(self):
        matches = [suspect for suspect in self.suspects if suspect["matches"]]
        lines = [
            f"Likely cause: {suspect['name']}, which reproduces these outputs to "
            f"{suspect['distance']:.0e}: {suspect['description']}"
            for suspect in matches
        ]
        if len(matches) > 1:
            lines.append("The outputs given cannot tell these apart; give all six.")
        if matches or (self.precision is not None and self.precision.explains):
            return lines
        checked_names = ", ".join(suspect["name"] for suspect in self.suspects)
        closest = self.closest
        if closest is None:
            return [
                "No known mistake reproduces or explains these outputs (checked: "
                f"{checked_names}): none is suggested."
            ]
        suspect = next(s for s in self.suspects if s["name"] == closest)
        return [
            f"Nearest known mistake: {closest}, off by {suspect['distance']:.1e}, which "
            f"explains these outputs (on every output given, within {FACTOR:g} tolerances or "
            f"{NEARER:g} times nearer than the expected outputs): {suspect['description']}"
        ]
