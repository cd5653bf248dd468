"""Their outputs, from a file or an object: what :func:`skf_ref.compare` compares.

A ``.npz`` or ``.mat`` (v5 or v7.3) file holding any of the output names, a ``.csv`` long
table, a mapping of names to arrays, or a :class:`~skf_ref.Reconstruction`. The CSV layout is
a long table, one value a line, with the header ``output,source,step,value``; ``source`` and
``step`` count from 1 (row and column of the (n_sources, n_times) array) and are empty for
``log_likelihood``::

    output,source,step,value
    z,1,1,0.1728
    z,2,1,0.7405
    log_likelihood,,,-14.1373

Every (source, step) of an output it holds must appear exactly once. A UTF-8 byte order
mark at the start of the file is allowed.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._utils.checks import InputError, describe
from ._cases import OUTPUTS
from ._intermediates import NAMES

__all__ = ["checked", "read_outputs"]

_CSV_HEADER = ["output", "source", "step", "value"]


def _read_csv(path):
    """The arrays of a long-table CSV (see the module docstring), by output name."""
    # utf-8-sig: a byte order mark, which Excel and Windows editors write, is no header cell
    try:
        with open(path, newline="", encoding="utf-8-sig") as stream:
            lines = list(csv.reader(stream))
    except UnicodeDecodeError as err:
        raise InputError(
            f"{path}: not UTF-8 text (byte {err.start}); save the table as UTF-8 (or ASCII)"
        ) from None
    if not lines or [cell.strip().lower() for cell in lines[0]] != _CSV_HEADER:
        got = ",".join(lines[0]) if lines else "an empty file"
        raise InputError(f"{path}: the first line must be output,source,step,value, got {got}")
    cells: dict[str, dict[tuple, float]] = {}
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


def read_outputs(theirs: Any) -> tuple[dict[str, Any], str]:
    """Everything ``theirs`` holds, by name, and how to name it in messages.

    Parameters
    ----------
    theirs : path-like, mapping or Reconstruction
        A ``.npz``, ``.mat`` (v5 or v7.3) or long-table ``.csv`` file, a mapping of names
        to values, or an object with the outputs as attributes.

    Returns
    -------
    variables : dict
        Every name ``theirs`` holds; from a ``.npz`` or ``.mat`` file, only the values of
        the outputs and the intermediates are read (the other names map to None).
    source : str
    """
    if isinstance(theirs, Mapping):
        return dict(theirs), "their outputs"
    if all(hasattr(theirs, name) for name in OUTPUTS):
        return {name: getattr(theirs, name) for name in OUTPUTS}, repr(theirs)
    if not isinstance(theirs, str | Path):
        raise InputError(
            f"theirs must be a file, a mapping or a Reconstruction, got {describe(theirs)}"
        )
    from ..io._variables import read_variables

    path = Path(theirs)
    if path.suffix == ".csv":
        from ..io._variables import existing_file

        return _read_csv(existing_file(path)), str(path)
    if path.suffix not in (".npz", ".mat"):
        raise InputError(f"{path}: give their outputs as .npz, .mat or .csv")
    variables = read_variables(path)  # lazy: only what compare takes is read, the rest named
    wanted = (*OUTPUTS, *NAMES)
    return {k: variables[k] if k in wanted else None for k in variables}, str(path)


def checked(name: str, value: Any, shape: tuple[int, int], source: str) -> float | np.ndarray:
    """``value`` as a float, or an array of ``shape`` or its transpose; else an error.

    Parameters
    ----------
    name : str
        An output name.
    value : object
    shape : tuple
        (n_sources, n_times).
    source : str
        Their file, for messages.

    Returns
    -------
    float or ndarray
        An array of ``shape``, or of its transpose (``compare`` reports it as transposed).

    Raises
    ------
    skf_ref.InputError
        Not numbers (text, complex numbers with an imaginary part), or another shape:
        names the output and the shape expected.
    """
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):  # ragged nested sequences
        array = np.asarray(None)
    if array.dtype.kind == "c":
        imaginary = float(np.max(np.abs(array.imag), initial=0.0))
        if imaginary > 0:
            raise InputError(
                f"{source}: {name} is complex (largest imaginary part {imaginary:.3g}, largest "
                f"real part {float(np.max(np.abs(array.real), initial=0.0)):.3g}): an SKF's "
                "outputs are real; give them as real numbers"
            )
        array = array.real
    if array.dtype.kind not in "fiu":
        raise InputError(f"{source}: {name} must be numbers, got {describe(value)}")
    array = array.astype(float)
    if name == "log_likelihood":
        if array.size != 1:
            raise InputError(f"{source}: log_likelihood must be one number, got {array.shape}")
        return float(array.reshape(-1)[0])
    if array.shape not in (shape, shape[::-1]):
        raise InputError(
            f"{source}: {name} must have shape {shape} (n_sources, n_times), got {array.shape}"
        )
    return array
