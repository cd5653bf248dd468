"""EEG data in CSV files, in whatever layout people write them, or a clear refusal.

Channels are rows and times are columns (the package's shapes, docs/model.md §1); a first
column of channel names (or row labels) and a first row of times in seconds are optional.
Cells are separated by commas, semicolons, tabs or spaces (``np.savetxt``'s default), as
the first lines show; with semicolons or tabs a decimal comma (``1,5``) is read too. Lines
starting with ``#`` (``np.savetxt``'s header) and empty lines are skipped, and a UTF-8
byte-order mark (Excel's "CSV UTF-8") is read past.

The layout is read off the content, on evidence, never on a guess:

- **a first column of labels**: text (channel names), or numbers under an empty or
  labelled corner cell (``DataFrame.to_csv`` writes an empty one), or the integers
  0, 1, ..., n - 1 or 1, 2, ..., n down at least three rows (pandas' default index,
  channels numbered): row numbers are no sample. Such numbers on fewer rows, or written
  with a decimal point, could be either and are refused;
- **a first row of times**: under an empty or labelled corner cell (``""``, ``time``,
  ``times``, ``t``, ``channel`` ...), increasing; or, in a table of numbers only, numbers
  that increase by equal steps to the precision they are printed with (times rounded to
  the millisecond at 600.615 Hz step by 1 or 2 ms, and are times), or by ``1 / sfreq``
  when the sampling rate is given. A first row that increases steadily but not by equal
  steps (a drifting channel, or times with jitter) could be either and is refused, as is
  a row of sample-time-like numbers named like a channel. The integers 0, 1, ..., T - 1
  over the columns (pandas' default column labels) are column numbers, not times.

A refusal says what could not be told and how to say it (name the rows, label the times
row ``time``, give ``sfreq``, or save the arrays to ``.npz``); a channel named twice is
refused. Nothing is transposed or dropped silently.

==========================================================  =============  =========
written by                                                  channel names  times
==========================================================  =============  =========
``DataFrame(Y, index=names, columns=times).to_csv(path)``   first column   first row
``np.savetxt(path, Y)`` (spaces), ``delimiter=","``         none           none
``...to_csv(path, index=False)``                            none           first row
``...to_csv(path, header=False)``                           first column   none
``DataFrame(Y).to_csv(path)`` (default labels)              none           none
``...to_csv(path, sep=";", decimal=",")`` (Excel, Europe)   first column   first row
==========================================================  =============  =========
"""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import numpy as np

from .._utils.checks import InputError, check_array, check_names, check_real

__all__ = ["read_csv"]

_CSV_LAYOUT = (
    "expected channels in rows and times in columns: numbers only (np.savetxt), or with "
    "channel names in the first column and/or times in seconds in the first row, e.g. "
    "',-0.1,-0.099,...' then 'Fp1,1.2e-06,...' (DataFrame(Y, index=names, columns=times)"
    ".to_csv())"
)
_SAY_WHICH = (
    "say which: name the channels in the first column and put 'time' (or nothing) in the "
    "first cell of a row of times, give the sampling rate (read_data(..., sfreq=...)), or "
    "save the arrays to .npz (Y, times, ch_names)"
)
#: Corner cells that label a header row (compared without case and quotes).
HEADER_WORDS = frozenset(
    ("", "time", "times", "t", "time (s)", "times (s)", "time [s]", "time_s", "seconds")
    + ("channel", "channels", "ch_name", "ch_names", "name", "names", "label", "labels")
    + ("sensor", "sensors", "electrode", "electrodes", "index", "unnamed: 0")
)
_DELIMITERS = ("\t", ";", ",", " ", None)  # None: runs of whitespace (fixed-width columns)
_INTEGER = re.compile(r"^[+-]?\d+$")
_NUMBER = re.compile(r"^[+-]?(\d*)(?:\.(\d*))?(?:[eE]([+-]?\d+))?$")
_DECIMAL_COMMA = re.compile(r"^[+-]?\d*,\d+(?:[eE][+-]?\d+)?$")
_COMMA = str.maketrans(",", ".")
#: Relative rounding of the times themselves (float32 times are common): beyond the
#: precision printed, a row of times may stray from equal steps by this much of its size.
_TIMES_RTOL = 1e-7
_STEADY = 0.5  # steps within 50 % of their median: a steady rise that could be times
_GOLDEN_STEPS = 100  # the search interval shrinks to 0.618**100 ~ 1e-21 of the step range


def _split(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return line.split()
    return [cell.strip() for cell in next(csv.reader([line], delimiter=delimiter))]


def _fields(line: str, delimiter: str | None) -> int:
    """How many cells ``line`` has (fast where no cell is quoted)."""
    if delimiter is None:
        return len(line.split())
    if '"' not in line:
        return line.count(delimiter) + 1
    return len(_split(line, delimiter))


def _delimiter(lines: list[str]) -> str | None:
    """The first of tab, semicolon, comma and space that cuts the first lines into cells
    (runs of spaces when single spaces cut them unevenly); None also for one column."""
    for delimiter in _DELIMITERS[:-1]:
        if any(_fields(line, delimiter) > 1 for line in lines):
            if delimiter == " " and any(
                "  " in line or line != line.strip() for line in lines[1:] or lines
            ):
                return None  # fixed-width columns: runs of spaces
            return delimiter
    return None


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _unit(text: str) -> float:
    """The rounding unit of a number as printed: 0.001 for ``0.002``, 1e-6 for ``1.665e-03``."""
    match = _NUMBER.match(text.strip())
    if match is None:
        return 0.0
    decimals, exponent = len(match.group(2) or ""), int(match.group(3) or 0)
    return 10.0 ** (exponent - decimals)


def _consecutive(texts: list[str]) -> bool:
    """Integers 0, 1, ..., n - 1 or 1, 2, ..., n, written as integers: labels, not samples."""
    if not texts or not all(_INTEGER.match(text) for text in texts):
        return False
    values = [int(text) for text in texts]
    return values[0] in (0, 1) and values == list(range(values[0], values[0] + len(values)))


def _gap(values: np.ndarray, half: np.ndarray, step: float) -> float:
    """How far the line t0 + step k is from passing through every interval v_k +- h_k,
    at its best t0 (<= 0: it passes)."""
    k = step * np.arange(len(values))
    return float(np.max(values - half - k) - np.min(values + half - k))


def _uniform(values: np.ndarray, texts: list[str], step: float | None = None) -> bool:
    """Increasing by equal steps (of ``step`` if given) to the precision printed.

    A value printed with unit u (0.001 for ``0.002``, 1e-4 for ``1.234e-01``) is within u/2
    of the true one: equal steps fit if some line t0 + step k passes within u_k/2 of every
    value v_k (rounding of the times themselves, e.g. float32, allowed on top). Without
    ``step``, the best one: how far the line misses is convex in its step, and the best
    step is near the mean step (golden-section search around it).
    """
    if len(values) < 2 or not np.all(np.diff(values) > 0):
        return False
    half = np.array([_unit(text) for text in texts]) / 2
    slack = 2 * _TIMES_RTOL * float(np.max(np.abs(values)))
    if step is not None:
        return _gap(values, half, step) <= slack
    steps = np.diff(values)
    low, high = steps.min() - 2 * half.max(), steps.max() + 2 * half.max()
    ratio = (np.sqrt(5) - 1) / 2
    for _ in range(_GOLDEN_STEPS):
        a, b = high - ratio * (high - low), low + ratio * (high - low)
        if _gap(values, half, a) <= _gap(values, half, b):
            high = b
        else:
            low = a
    return min(_gap(values, half, low), _gap(values, half, high)) <= slack


def _steady(values: np.ndarray) -> bool:
    steps = np.diff(values)
    median = np.median(steps)
    return bool(np.all(steps > 0) and np.all(np.abs(steps - median) <= _STEADY * median))


def _row_values(texts: list[str]) -> np.ndarray | None:
    values = [_number(text) for text in texts]
    if any(value is None for value in values):
        return None
    array = np.array(values, dtype=float)
    return array if np.all(np.isfinite(array)) else None


def _header_times(texts: list[str], sfreq: float | None, path: Path) -> np.ndarray | None:
    """The times of a row that is a header by its corner cell; None for column labels."""
    values = _row_values(texts)
    if values is None:
        if any(_number(text) is not None for text in texts):
            raise InputError(f"{path}: its first row mixes numbers and text; {_CSV_LAYOUT}")
        return None  # column labels of text
    if _consecutive(texts):
        return None  # 0, 1, ..., T - 1: pandas' default column labels, not seconds
    if len(values) > 1 and not np.all(np.diff(values) > 0):
        raise InputError(
            f"{path}: its first row is a header (its first cell says so) but its numbers do "
            "not increase: give the times in seconds there, or column labels"
        )
    if sfreq is not None and len(values) > 1 and not _uniform(values, texts, 1.0 / sfreq):
        raise InputError(
            f"{path}: the times in its first row do not step by 1/sfreq = {1 / sfreq:g} s "
            f"(sfreq={sfreq:g} Hz): give the sampling rate of these data"
        )
    return values


def _first_row_kind(texts: list[str], named: str | None, sfreq: float | None, path: Path) -> str:
    """Whether a first row of numbers with no header corner is "times", "labels" (column
    numbers) or a "channel"; refused when the evidence does not tell."""
    values = _row_values(texts)
    if values is None:
        return "channel"  # text among the numbers: refused when the table is read
    if sfreq is not None:
        times = len(values) > 1 and _uniform(values, texts, 1.0 / sfreq)
    elif len(values) < 3:
        times = len(values) == 2 and values[1] > values[0] and named is None
        if times:
            raise InputError(
                f"{path}: a first row of two increasing numbers: times or a channel? {_SAY_WHICH}"
            )
    else:
        times = _uniform(values, texts)
        if not times and named is None and _steady(values):
            steps = np.diff(values)
            raise InputError(
                f"{path}: its first row increases steadily (steps {steps.min():.4g} to "
                f"{steps.max():.4g}) but not by equal steps to the precision printed: times "
                f"with jitter, or a drifting channel? {_SAY_WHICH}"
            )
    if _consecutive(texts) and len(values) >= 3 and named is None:
        return "labels"
    if times and named is not None:
        raise InputError(
            f"{path}: its first row, named {named!r}, steps evenly like sample times: a "
            f"channel or the times? {_SAY_WHICH}"
        )
    return "times" if times else "channel"


def _label_column(first_column: list[str], path: Path) -> bool:
    """In a table of numbers only, whether the first column is row labels (not samples)."""
    texts = [text.strip() for text in first_column]
    if _consecutive(texts) and len(texts) >= 3:
        return True  # pandas' default index, channels numbered: the evidence of 3 rows
    values = _row_values(texts)
    numbered = (
        values is not None
        and len(values) > 1
        and values[0] in (0, 1)
        and np.array_equal(values, values[0] + np.arange(len(values)))
    )
    # row numbers on fewer rows, or with a decimal point, or under a first row: either
    if _consecutive(texts) or numbered or _consecutive(texts[1:]) and len(texts) > 3:
        shown = ", ".join(texts[:3]) + (", ..." if len(texts) > 3 else "")
        raise InputError(
            f"{path}: its first column is {shown}: row numbers, or each channel's first "
            "sample? Say which: give the channels names in the first column, leave the "
            "numbers out (np.savetxt, or to_csv(index=False)), or save the arrays to .npz"
        )
    return False


def _layout(
    first: list[str], first_column: list[str], n_fields: int, sfreq: float | None, path: Path
) -> tuple[bool, bool, np.ndarray | None]:
    """``(header, label_column, times)``: whether the first line is a header, whether the
    first column is labels, and the times (or None), read off the content."""
    body = first_column[1:]
    kinds = {_number(text) is None for text in body}
    if len(kinds) > 1:
        named = next(i for i, text in enumerate(body, 2) if _number(text) is None)
        unnamed = next(i for i, text in enumerate(body, 2) if _number(text) is not None)
        raise InputError(
            f"{path}: data row {named} is named and data row {unnamed} is not (first "
            f"column); {_CSV_LAYOUT}"
        )
    names = kinds == {True}
    corner = first[0].strip().strip('"').lower()
    if body and len(first) == n_fields - 1:  # a header with no corner cell (R's write.table)
        return True, True, _header_times(first, sfreq, path)
    if body and corner in HEADER_WORDS:
        return True, True, _header_times(first[1:], sfreq, path)
    if names or not body:
        if _number(first[0]) is None:  # a named channel, unless its numbers say otherwise
            if body:  # (one line is a channel: a header over nothing is none)
                _first_row_kind(first[1:], first[0], sfreq, path)  # refuses a row like times
            return False, True, None
        if body:
            raise InputError(f"{path}: the rows are named but not the first; {_CSV_LAYOUT}")
        return False, _label_column(first_column, path), None
    if _number(first[0]) is None:
        raise InputError(f"{path}: cannot tell its layout; {_CSV_LAYOUT}")
    if _label_column(first_column, path):
        return False, True, None
    kind = _first_row_kind(first, None, sfreq, path)
    if kind == "channel":
        return False, False, None
    return True, False, _row_values(first) if kind == "times" else None


def _lines(path: Path) -> list[tuple[int, str]]:
    try:
        text = path.read_text(encoding="utf-8-sig")  # a BOM (Excel's UTF-8) is not a name
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"{path}: cannot be read as CSV: {err}") from err
    lines = [
        (number, line)
        for number, line in enumerate(text.splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not lines:
        raise InputError(f"{path}: no data; {_CSV_LAYOUT}")
    return lines


def read_csv(
    path: Path, sfreq: float | None = None
) -> tuple[np.ndarray, list[str] | None, np.ndarray | None]:
    """Data from a CSV file, its layout read off the content (module docstring).

    Parameters
    ----------
    path : Path
    sfreq : float, optional
        The sampling rate (Hz): a first row stepping by ``1 / sfreq`` is the times.

    Returns
    -------
    data : ndarray, shape (n_channels, n_times)
    ch_names : list of str or None
    times : ndarray, shape (n_times,) or None
        Seconds.

    Raises
    ------
    skf_ref.InputError
        A layout the content does not tell (the message says how to say it), a line with
        another number of cells, a cell that is no number, a channel named twice.
    """
    if sfreq is not None:
        sfreq = check_real("sfreq", sfreq, positive=True)
    lines = _lines(path)
    table = _Table(lines, path)
    header, labels, times = _layout(table.first, table.first_column, table.n_fields, sfreq, path)
    body = "\n".join(line for _, line in lines[int(header) :])
    if table.decimal_comma:
        body = body.translate(_COMMA)  # the names are read from first_column
    try:
        values = np.loadtxt(
            io.StringIO(body),
            delimiter=table.delimiter,
            usecols=range(int(labels), table.n_fields),
            comments=None,
            quotechar='"',
            ndmin=2,
        )
    except ValueError as err:  # a cell that is no number
        raise InputError(f"{path}: cannot be read as CSV ({_CSV_LAYOUT}): {err}") from err
    data = check_array(f"{path}", values, ("n_channels", "n_times"))
    if data.shape[1] == 0:
        raise InputError(f"{path}: no samples, only a column of names; {_CSV_LAYOUT}")
    if times is not None and len(times) != data.shape[1]:
        raise InputError(
            f"{path}: {len(times)} times in the first row, {data.shape[1]} columns of data"
        )
    return data, _channel_names(table.first_column[int(header) :], labels, path), times


class _Table:
    """How a CSV file's lines are cut into cells: its delimiter, decimal mark, first row and
    first column (as text), and the number of cells a row has (every row checked)."""

    def __init__(self, lines: list[tuple[int, str]], path: Path) -> None:
        self.delimiter = delimiter = _delimiter([line for _, line in lines[:5]])
        head = [_split(line, delimiter) for _, line in lines[:5]]
        self.decimal_comma = delimiter in (";", "\t") and any(
            _DECIMAL_COMMA.match(cell) for row in head for cell in row[1:]
        )
        column = [_first(line, delimiter) for _, line in lines]
        if self.decimal_comma:
            head = [[cell.translate(_COMMA) for cell in row] for row in head]
            column = [cell.translate(_COMMA) for cell in column]
        self.first, self.first_column = head[0], column
        self.n_fields = len(head[1]) if len(head) > 1 else len(head[0])
        for number, line in lines[2:]:
            if _fields(line, delimiter) != self.n_fields:
                raise self._uneven(path, number, _fields(line, delimiter), lines[1][0])
        if len(self.first) not in (self.n_fields, self.n_fields - 1):
            raise self._uneven(path, lines[0][0], len(self.first), lines[1][0])

    def _uneven(self, path: Path, number: int, cells: int, reference: int) -> InputError:
        return InputError(
            f"{path}: line {number} has {cells} cells and line {reference} has {self.n_fields}: "
            "every row needs one cell per column"
        )


def _first(line: str, delimiter: str | None) -> str:
    """The first cell of a line (without cutting the rest, where no cell is quoted)."""
    if '"' in line:
        return _split(line, delimiter)[0]
    if delimiter is None:
        return line.split(maxsplit=1)[0]
    return line.split(delimiter, 1)[0].strip()


def _channel_names(column: list[str], labels: bool, path: Path) -> list[str] | None:
    """The names of a first column of labels; None for row numbers (0..n-1, 1..n)."""
    if not labels:
        return None
    texts = [text.strip() for text in column]
    if all(_number(text) is not None for text in texts) and (
        _consecutive(texts) or len(texts) < 3 and all(_INTEGER.match(t) for t in texts)
    ):
        return None
    return check_names(f"{path}: its first column (channel names)", texts, unit="row")
