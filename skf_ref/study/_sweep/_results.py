"""Results files of a sweep: read without writing, checked line by line, locked while written.

A CSV gets one whole line per finished run in a single ``write`` call, flushed to disk; a torn
last line (a write cut short by power loss or a kill) is ignored when the file is read and
cut off, with a warning, when a sweep resumes writing. A byte-order mark (a CSV saved by
Excel as UTF-8) is read past.

While a sweep writes, the file is locked, and the lock belongs to the file, not to the name
it was opened by: a symbolic link leads to the same lock (beside the file it points to), and
a CSV is also locked itself (``flock`` on the file, where the system has it), so a hard link
to it cannot be written by a second sweep either. (A Parquet file is replaced at each write,
which ends any hard link to it.) A Parquet file is rewritten through a
temporary file and a rename after each task. Any other damage (a line with missing or extra
fields, an empty or non-numeric key, a run written twice, columns of another program) is an
:class:`~skf_ref.InputError` naming the file and the line: nothing is dropped or recomputed
silently.
"""

from __future__ import annotations

import csv
import io
import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any, Literal

import pandas as pd

from ..._utils.atomic_files import atomic_path
from ..._utils.checks import InputError, check_path
from ._grid import KEY, row_key

fcntl: ModuleType | None
try:
    import fcntl
except ImportError:  # Windows: the lock file alone
    fcntl = None

__all__ = ["ResultsFile", "TornLineWarning", "read_results"]

# pandas before 3.1 reads some floats back one unit in the last place off unless asked to
# round-trip (3.1 reads every float exactly and deprecates the option): rows kept as written
_EXACT_FLOATS = (
    {"float_precision": "round_trip"}
    if tuple(int(part) for part in pd.__version__.split(".")[:2]) < (3, 1)
    else {}
)


class TornLineWarning(UserWarning):
    """A results file ended in a torn line (an interrupted write); it was cut off."""


def _lock_path(out: Path) -> Path:
    """The lock file of the file ``out`` names, wherever symbolic links lead."""
    real = out.resolve()
    return real.with_name(f".{real.name}.lock")


def _is_parquet(out: Path) -> bool:
    return out.suffix == ".parquet"


def read_results(out: str | os.PathLike) -> pd.DataFrame:
    """The rows already in a results file (none if it does not exist). Never writes.

    Parameters
    ----------
    out : path-like
        A ``.csv`` or ``.parquet`` file written by :func:`skf_ref.study._sweep.run_sweep`.

    Returns
    -------
    pandas.DataFrame
        Every complete row; a torn last line of a CSV (no final newline) is left out.

    Raises
    ------
    skf_ref.InputError
        The file is not a results file or is damaged; the message names the file and line.
    """
    path = Path(out)
    if not path.exists() or path.stat().st_size == 0:
        return pd.DataFrame()
    if _is_parquet(path):
        try:
            frame = pd.read_parquet(path)
        except Exception as err:  # pyarrow raises its own types for unreadable files
            raise InputError(f"{path} is not a readable Parquet file: {err}") from err
        return _checked(frame, path, lambda i: f"row {i}")
    text = _complete_lines(path)
    _check_fields(text, path)
    frame = pd.read_csv(io.StringIO(text), keep_default_na=False, na_values=[""], **_EXACT_FLOATS)
    return _checked(frame, path, lambda i: f"line {i + 2}")


def _complete_lines(out: Path) -> str:
    data = out.read_bytes()
    data = data[: data.rfind(b"\n") + 1]  # a torn last line is not a row yet
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise InputError(
            f"{out} is not a results file: byte {err.start} is not UTF-8 text"
        ) from err


def _check_fields(text: str, out: Path) -> None:
    rows = csv.reader(io.StringIO(text))
    header = next(rows, [])
    missing = [column for column in KEY if column not in header]
    if missing:
        raise InputError(
            f"{out} is not a results file of skf-ref sweep: its header lacks the columns "
            f"{missing}; give a new file name"
        )
    for number, fields in enumerate(rows, start=2):
        if len(fields) != len(header):
            raise InputError(
                f"{out}, line {number}: {len(fields)} fields, expected {len(header)}; the file "
                "is damaged: delete that line (its run is recomputed) or the file"
            )


def _checked(frame: pd.DataFrame, out: Path, where: Callable[[int], str]) -> pd.DataFrame:
    missing = [column for column in KEY if column not in frame.columns]
    if missing:
        raise InputError(
            f"{out} is not a results file of skf-ref sweep: it lacks the columns {missing}"
        )
    seen: dict[tuple, int] = {}
    for i, row in enumerate(frame[list(KEY)].itertuples(index=False)):
        values = dict(zip(KEY, row, strict=True))
        for column, value in values.items():
            if pd.isna(value) or value == "":
                raise InputError(f"{out}, {where(i)}: {column!r} is empty; the file is damaged")
        try:
            key = row_key(values)
        except ValueError as err:
            raise InputError(f"{out}, {where(i)}: a key column is not a number ({err})") from err
        if key in seen:
            raise InputError(
                f"{out}, {where(i)} repeats the run of {where(seen[key])}; the file is damaged: "
                "delete one of them"
            )
        seen[key] = i
    return frame


class ResultsFile:
    """A results file opened for a sweep: locked, checked, appended one batch of runs at a time.

    Use as a context manager. A second sweep on the same file fails at once with an
    :class:`~skf_ref.InputError` saying the file is in use; the lock is released on exit.

    Parameters
    ----------
    out : path-like
        ``.csv`` or ``.parquet``.

    Attributes
    ----------
    existing : pandas.DataFrame
        The rows already there when the file was opened.
    """

    def __init__(self, out: str | os.PathLike) -> None:
        self.out = check_path("out", out)
        if self.out.suffix not in (".csv", ".parquet"):
            raise InputError(f"out must be a .csv or .parquet file name, got {str(self.out)!r}")
        self.existing = pd.DataFrame()
        self._lock: Any = None
        self._file_lock: int | None = None
        self._columns: list[str] = []

    def __enter__(self) -> ResultsFile:
        from filelock import FileLock, Timeout

        if _is_parquet(self.out):
            import pyarrow  # noqa: F401  (fail before any work if Parquet cannot be written)
        self._lock = FileLock(_lock_path(self.out), timeout=0)
        try:
            self._lock.acquire()
        except Timeout:
            raise self._in_use() from None
        try:
            if not _is_parquet(self.out) and self.out.exists():
                self._lock_file()
            self.existing = read_results(self.out)
            self._columns = list(self.existing.columns)
            if not _is_parquet(self.out):
                self._cut_torn_line()
        except BaseException:
            self._release()
            raise
        return self

    def __exit__(self, *exc: object) -> Literal[False]:
        self._release()
        return False

    def _in_use(self) -> InputError:
        return InputError(
            f"{self.out} is in use by another sweep (locked): wait for it to finish or write "
            "to another file"
        )

    def _lock_file(self, flags: int = os.O_RDONLY) -> None:
        """Lock the CSV itself (its inode): shared by every name of it, hard links too."""
        fd = os.open(self.out, flags, 0o644)
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise self._in_use() from None
        self._file_lock = fd

    def _release(self) -> None:
        if self._file_lock is not None:
            os.close(self._file_lock)  # releases the flock
            self._file_lock = None
        if self._lock is not None:
            self._lock.release()

    def _cut_torn_line(self) -> None:
        if not self.out.exists():
            return
        data = self.out.read_bytes()
        whole = data.rfind(b"\n") + 1
        if whole < len(data):
            with open(self.out, "r+b") as f:
                f.truncate(whole)
            warnings.warn(
                f"{self.out}: cut off a torn last line (an interrupted write); its run is "
                "recomputed",
                TornLineWarning,
                stacklevel=3,
            )

    def add(self, rows: Sequence[dict[str, Any]]) -> None:
        """Append finished runs.

        Parameters
        ----------
        rows : sequence of dict
            One per run, with the same keys in the same order.
        """
        if not rows:
            return
        if _is_parquet(self.out):
            self.existing = pd.concat([self.existing, pd.DataFrame(rows)], ignore_index=True)
            with atomic_path(self.out) as tmp:
                self.existing.to_parquet(tmp, index=False)
            return
        frame = pd.DataFrame(rows)
        header = not self._columns
        if header:
            self._columns = list(frame.columns)
        elif list(frame.columns) != self._columns:
            raise InputError(
                f"{self.out}: its columns differ from this sweep's rows (written by another "
                "version of skf_ref?); give a new file name"
            )
        if self._file_lock is None:  # the file is new: it is locked as it is created
            self._lock_file(os.O_WRONLY | os.O_APPEND | os.O_CREAT)
        text = frame.to_csv(index=False, header=header, lineterminator="\n")
        fd = os.open(self.out, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            # whole lines (with the header, the first time), synced once per batch: an
            # interruption tears at most the last line, which the next run cuts off
            os.write(fd, text.encode())
            os.fsync(fd)
        finally:
            os.close(fd)
