"""Compare another SKF's outputs with a conformance case, and name the likely mistake.

:func:`compare` takes a case (:mod:`skf_ref.conformance`) and the outputs of the
implementation under test ("theirs"): a ``.npz`` or ``.mat`` file holding any of the
output names, a ``.csv`` long table (below), a mapping of names to arrays, or a
:class:`~skf_ref.Reconstruction`. For each output given it reports the largest relative
difference, ``max|theirs - expected| / max|expected|``, the first time step where it
exceeds the tolerance, and a verdict. When an output disagrees, every known mistake of
:mod:`skf_ref.conformance.mistakes` that applies to the case is computed, and those that reproduce
their numbers to the tolerance are named.

The CSV layout is a long table, one value a line, with the header
``output,source,step,value``; ``source`` and ``step`` count from 1 (row and column of the
(n_sources, n_times) array) and are empty for ``log_likelihood``::

    output,source,step,value
    z,1,1,0.1728
    z,2,1,0.7405
    log_likelihood,,,-14.1373

Every (source, step) of an output it holds must appear exactly once.
"""

import numpy as np

from .._utils.checks import InputError, check_real, describe
from .case_files import read_case
from .cases import OUTPUTS, Case
from .mistakes import SUSPECTS

__all__ = ["Comparison", "compare", "read_outputs"]

_ARRAYS = OUTPUTS[:-1]
_CSV_HEADER = ["output", "source", "step", "value"]


def _read_csv(path):
    """The arrays of a long-table CSV (see the module docstring), by output name."""
    import csv

    with open(path, newline="", encoding="utf-8") as stream:
        lines = list(csv.reader(stream))
    if not lines or [cell.strip().lower() for cell in lines[0]] != _CSV_HEADER:
        got = ",".join(lines[0]) if lines else "an empty file"
        raise InputError(f"{path}: the first line must be output,source,step,value, got {got}")
    cells = {}
    for number, line in enumerate(lines[1:], start=2):
        if not any(cell.strip() for cell in line):
            continue
        if len(line) != 4:
            raise InputError(f"{path}, line {number}: expected 4 fields, got {len(line)}")
        name, source, step, text = (cell.strip() for cell in line)
        try:
            value = float(text)
            index = () if name == "log_likelihood" else (int(source), int(step))
        except ValueError:
            raise InputError(
                f"{path}, line {number}: expected an output name, two indices counting from 1 "
                f"(empty for log_likelihood) and a number, got {','.join(line)}"
            ) from None
        if min(index, default=1) < 1 or (index == () and (source or step)):
            raise InputError(f"{path}, line {number}: source and step count from 1, got {line}")
        if index in cells.setdefault(name, {}):
            raise InputError(f"{path}, line {number}: {name} {index} appears twice")
        cells[name][index] = value
    return {name: _assemble(path, name, entries) for name, entries in cells.items()}


def _assemble(path, name, entries):
    if () in entries:
        return entries[()]
    n, T = (max(index[k] for index in entries) for k in (0, 1))
    if len(entries) != n * T:
        raise InputError(
            f"{path}: {name} has {len(entries)} values for sources 1..{n} and steps 1..{T}: "
            "every (source, step) must appear once"
        )
    array = np.empty((n, T))
    for (s, t), value in entries.items():
        array[s - 1, t - 1] = value
    return array


def read_outputs(theirs):
    """Everything ``theirs`` holds, by name, and how to name it in messages.

    Parameters
    ----------
    theirs : path-like, mapping or Reconstruction
        A ``.npz``, ``.mat`` (v5 or v7.3) or long-table ``.csv`` file, a mapping of names
        to values, or an object with the outputs as attributes.

    Returns
    -------
    variables : dict
    source : str
    """
    from collections.abc import Mapping
    from pathlib import Path

    if isinstance(theirs, Mapping):
        return dict(theirs), "their outputs"
    if all(hasattr(theirs, name) for name in OUTPUTS):
        return {name: getattr(theirs, name) for name in OUTPUTS}, repr(theirs)
    if not isinstance(theirs, str | Path):
        raise InputError(
            f"theirs must be a file, a mapping or a Reconstruction, got {describe(theirs)}"
        )
    from ..io.files import read_variables

    path = Path(theirs)
    if path.suffix == ".csv":
        if not path.is_file():
            raise InputError(f"{path}: no such file")
        return _read_csv(path), str(path)
    if path.suffix not in (".npz", ".mat"):
        raise InputError(f"{path}: give their outputs as .npz, .mat or .csv")
    variables = read_variables(path)
    return {k: v for k, v in variables.items() if not k.startswith("__")}, str(path)


def _checked(name, value, shape, source):
    """``value`` as a float, or an array of ``shape`` or its transpose; else an error."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{source}: {name} must be numbers, got {describe(value)}") from None
    if name == "log_likelihood":
        if array.size != 1:
            raise InputError(f"{source}: log_likelihood must be one number, got {array.shape}")
        return float(array.reshape(-1)[0])
    if array.shape not in (shape, shape[::-1]):
        raise InputError(
            f"{source}: {name} must have shape {shape} (n_sources, n_times), got {array.shape}"
        )
    return array


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


def _diagnose(case, given, tolerance):
    """Every suspect that applies: its distance to their numbers and whether it matches."""
    found = []
    for suspect in SUSPECTS:
        try:
            outputs = suspect.compute(case)
        except (InputError, np.linalg.LinAlgError):  # the mistake breaks this case outright
            continue
        if outputs is None:
            continue
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


def compare(case, theirs, *, tolerance=None):
    """Compare another implementation's outputs with a conformance case.

    Parameters
    ----------
    case : Case or path-like
        A case, or its ``.npz`` / ``.mat`` file (``skf-ref conformance export``).
    theirs : path-like, mapping or Reconstruction
        Their outputs, any of ``z``, ``z_filtered``, ``x``, ``x_filtered``, ``weights``
        ((n_sources, n_times)) and ``log_likelihood``: a ``.npz``, ``.mat`` or long-table
        ``.csv`` file (see the module docstring), a mapping, or a Reconstruction.
    tolerance : float, optional
        Largest relative difference that agrees; default the case's own (1e-6).

    Returns
    -------
    Comparison

    Raises
    ------
    skf_ref.InputError
        If their outputs are unusable: none of the output names, or a wrong shape (the
        message names the output and the shape expected).

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
    case = case if isinstance(case, Case) else read_case(case)
    if tolerance is None:
        tolerance = case.tolerance
    tolerance = check_real("tolerance", tolerance, positive=True)
    variables, source = read_outputs(theirs)
    given = {
        name: _checked(name, variables[name], case.shape, source)
        for name in OUTPUTS
        if name in variables
    }
    if not given:
        raise InputError(
            f"{source} holds none of the outputs {', '.join(OUTPUTS)}; it holds "
            f"{sorted(variables)}"
        )
    rows = [_row(name, value, case.expected[name], tolerance) for name, value in given.items()]
    agrees = all(row["verdict"] == "agrees" for row in rows)
    suspects = [] if agrees else _diagnose(case, given, tolerance)
    ignored = sorted(set(variables) - set(OUTPUTS))
    return Comparison(case.name, source, tolerance, rows, suspects, ignored)


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
    """

    def __init__(self, case, source, tolerance, rows, suspects, ignored):
        self.case, self.source, self.tolerance = case, source, tolerance
        self.rows, self.suspects, self.ignored = rows, suspects, ignored

    @property
    def agrees(self):
        """bool : Whether every output given agrees."""
        return all(row["verdict"] == "agrees" for row in self.rows)

    @property
    def exit_status(self):
        """int : 0 when everything given agrees, 1 otherwise (``skf-ref compare``)."""
        return 0 if self.agrees else 1

    @property
    def diagnosis(self):
        """list of str : The known mistakes that reproduce their numbers."""
        return [suspect["name"] for suspect in self.suspects if suspect["matches"]]

    def to_dict(self):
        """dict : Everything, as plain Python values (for JSON)."""
        keys = ("case", "source", "tolerance", "rows", "suspects", "ignored")
        return {key: getattr(self, key) for key in keys} | {
            "agrees": self.agrees,
            "diagnosis": self.diagnosis,
        }

    def to_frame(self):
        """pandas.DataFrame : One row per output given, indexed by the output's name."""
        import pandas as pd

        return pd.DataFrame(self.rows).set_index("output")

    def __repr__(self):
        verdict = "agrees" if self.agrees else "disagrees"
        return f"<Comparison | case {self.case}, {len(self.rows)} outputs, {verdict}>"

    def __str__(self):
        return self.report()

    def report(self):
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
        lines = [f"DISAGREES: {', '.join(wrong)}."]
        matches = [suspect for suspect in self.suspects if suspect["matches"]]
        for suspect in matches:
            lines.append(
                f"Likely cause: {suspect['name']}, which reproduces these numbers to "
                f"{suspect['distance']:.0e}: {suspect['description']}"
            )
        if len(matches) > 1:
            lines.append("The outputs given cannot tell these apart; give all six.")
        if not matches:
            closest = min(self.suspects, key=lambda suspect: suspect["distance"], default=None)
            lines.append("No known mistake reproduces these numbers.")
            if closest is not None:
                lines.append(
                    f"Closest: {closest['name']}, off by {closest['distance']:.1e}. Checked: "
                    f"{', '.join(suspect['name'] for suspect in self.suspects)}."
                )
        return lines
