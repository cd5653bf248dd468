"""skf_ref's log, and ``verbose=`` as MNE-Python uses it.

Functions that report progress log to the ``"skf_ref"`` logger at INFO and take
``verbose=None``: None keeps the logger's level (INFO unless the user set another, as in
MNE), True means INFO, False WARNING, or a level name or number.
"""

import contextlib
import logging
import os
import sys
import time
from collections.abc import Iterator
from types import FrameType
from typing import TextIO

__all__ = ["caller_stacklevel", "logger", "progress", "verbosity"]

_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep


class _Stderr(logging.StreamHandler[TextIO]):
    """Writes to ``sys.stderr`` as it is when a message comes (redirections included)."""

    @property
    def stream(self) -> TextIO:
        return sys.stderr

    @stream.setter
    def stream(self, value: TextIO) -> None:
        pass


logger = logging.getLogger("skf_ref")
if not logger.handlers:  # once per process: messages alone, on stderr, as MNE prints them
    _handler = _Stderr()
    _handler.setFormatter(logging.Formatter("%(message)s"))
    logger.addHandler(_handler)
    logger.setLevel(logging.INFO)
    logger.propagate = False


def _level(verbose: bool | str | int | None) -> int:
    from .checks import InputError

    if verbose is None:
        return logger.level
    if isinstance(verbose, bool):
        return logging.INFO if verbose else logging.WARNING
    if isinstance(verbose, str) and isinstance(logging.getLevelName(verbose.upper()), int):
        return logging.getLevelName(verbose.upper())  # a known name gives its number
    if isinstance(verbose, int):
        return verbose
    raise InputError(
        "verbose must be None, a bool, a level name ('INFO', 'WARNING', ...) or a number, "
        f"got {verbose!r}"
    )


@contextlib.contextmanager
def verbosity(verbose: bool | str | int | None) -> Iterator[None]:
    """Set the logger's level for the duration of a call (``verbose=`` of the caller).

    Examples
    --------
    >>> with verbosity(False):
    ...     logger.info("not shown")
    """
    level, before = _level(verbose), logger.level
    logger.setLevel(level)
    try:
        yield
    finally:
        logger.setLevel(before)


@contextlib.contextmanager
def progress(text: str) -> Iterator[None]:
    """Log ``text`` and, when the block ends, the seconds it took (INFO)."""
    start = time.perf_counter()
    logger.info("%s ...", text)
    yield
    logger.info("%s: %.1f s", text, time.perf_counter() - start)


def caller_stacklevel() -> int:
    """``stacklevel`` for a ``warnings.warn`` in the calling function that points at the
    first frame outside skf_ref: the user's line, however deep inside the package the
    warning is raised."""
    frame: FrameType | None = sys._getframe(1)  # the function that calls warnings.warn
    level = 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(_PACKAGE):
        frame, level = frame.f_back, level + 1
    return level
