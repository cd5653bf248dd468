"""The ``skf-ref`` command line.

A user's mistake (a bad option, an unreadable file, input the package refuses) prints one
line naming the flag or file and exits with status 2, and nothing else (warnings raised
on the way, MNE's among them, are shown only when the command succeeds); Ctrl-C, at any
moment, prints one line and exits with 130; files appear whole or not at all (written to a
hidden temporary in the same folder, then renamed). Anything else is a bug in the package
and shows its traceback. ``--debug`` shows the traceback of every error.

This module imports nothing heavy at import time, so that Ctrl-C while numpy, scipy or MNE
load is an interruption like any other. Its names (``__all__``) are the public API; the
subcommands' modules are their implementation.
"""

import os
import re
import signal
import sys

TYPE_CHECKING = False  # typing.TYPE_CHECKING, without importing typing (mypy reads it so)
if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable, Sequence
    from types import FrameType
    from typing import NoReturn

__all__ = ["main"]


def __dir__() -> list[str]:
    return list(__all__)


_INTERRUPTED = "skf-ref: interrupted; files already written are complete"


def build_parser() -> "argparse.ArgumentParser":
    """The ``skf-ref`` argument parser.

    Returns
    -------
    argparse.ArgumentParser
        With a subcommand per command (``args.run(args)`` runs it).
    """
    from .._version import __version__
    from . import _bids, _compare, _conformance, _demo, _reconstruct, _sweep, _sys_info
    from ._args import Parser

    parser = Parser(
        prog="skf-ref",
        description="Standardized Kalman filter (SKF) for EEG source localization: your own "
        "data in, source estimates out; the P20/N20 study of Prasikala et al. (2025) and "
        "parameter sweeps over it; conformance cases to check another implementation.",
    )
    parser.add_argument("--version", action="version", version=f"skf-ref {__version__}")
    parser.add_argument(
        "--debug", action="store_true", help="show the traceback of an error (for bug reports)"
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    _demo.add_parser(subparsers)
    _reconstruct.add_parser(subparsers)
    _bids.add_parser(subparsers)
    _sweep.add_parser(subparsers)
    _conformance.add_parser(subparsers)
    _compare.add_parser(subparsers)
    _sys_info.add_parser(subparsers)
    return parser


def _debug_asked(argv: list[str]) -> bool:
    return "--debug" in (argv[: argv.index("--")] if "--" in argv else argv)


def main(argv: "Sequence[str] | None" = None) -> int:
    """Entry point of ``skf-ref``; returns the exit status.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        0 on success, 1 when ``compare`` finds a disagreement, 2 on a usage or input
        error, 130 when interrupted.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    mistakes: tuple[type[Exception], ...] = (OSError, MemoryError)
    try:
        from .._utils.checks import InputError
        from .._utils.extras import MissingDependencyError

        mistakes = (InputError, MissingDependencyError, OSError, MemoryError)
        parser = build_parser()
        args = parser.parse_args(argv)
        if args.command is None:
            parser.print_help()
            return 0
        os.environ.setdefault("MPLBACKEND", "Agg")
        _run_showing_warnings_on_success(args)
    except KeyboardInterrupt:
        if _debug_asked(argv):
            raise
        print(_INTERRUPTED, file=sys.stderr)
        return 130
    except SystemExit as exit_:  # --help, --version, and the sweep's own interruption
        return exit_.code if isinstance(exit_.code, int) else 0
    except mistakes as err:
        if _debug_asked(argv):
            raise
        print(f"skf-ref: error: {_one_line(err)}", file=sys.stderr)
        return 2
    return 0


def _run_showing_warnings_on_success(args: "argparse.Namespace") -> None:
    """``args.run(args)``; the warnings it raised are shown after it, only if it succeeds:
    an error is one line, with no third-party text around it."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        args.run(args)
    for warning in caught:
        warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)


#: Interruptions seen while the command ran (one may have been swallowed on its way: a
#: KeyboardInterrupt raised inside a finalizer is only printed, "Exception ignored ...").
_SEEN: "list[int]" = []


def _interrupt(signum: int, frame: "FrameType | None") -> "NoReturn":
    _SEEN.append(signum)
    raise KeyboardInterrupt


_INTERRUPTED_LINE = f"{_INTERRUPTED}\n".encode()


def _end_now(
    signum: "int | None" = None,
    frame: "FrameType | None" = None,
    _write: "Callable[[int, bytes], int]" = os.write,
    _exit: "Callable[[int], NoReturn]" = os._exit,
    _line: bytes = _INTERRUPTED_LINE,
) -> None:
    """Ctrl-C once the command is done: one line and status 130, at once. Everything it
    uses is bound here, so that it works while the interpreter takes modules apart."""
    _write(2, _line)
    _exit(130)


def _quiet_interrupts(hook: "Callable") -> "Callable":
    """``sys.unraisablehook`` that drops a KeyboardInterrupt: it is reported by the status."""

    def unraisable(info: "sys.UnraisableHookArgs") -> None:
        if not isinstance(info.exc_value, KeyboardInterrupt):
            hook(info)

    return unraisable


def _save_coverage() -> None:
    """Save a coverage measurement of this process (a test run's), if one is running: its
    own exit handler, registered before :func:`_exit_after_handlers`, never runs."""
    coverage = sys.modules.get("coverage")
    current = getattr(getattr(coverage, "Coverage", None), "current", lambda: None)()
    if current is not None:
        current.stop()
        current.save()


def _exit_after_handlers(
    status: "list[int]", _exit: "Callable[[int], NoReturn]" = os._exit
) -> None:
    """The last exit handler (registered first): flush and end with ``status[0]``, before
    the interpreter resets its signal handlers (a Ctrl-C then would kill the process
    without a word) or turns an interruption it saw into a signal of its own."""
    try:
        _save_coverage()
    except Exception:  # never fail the exit for a measurement
        pass
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, OSError, ValueError):  # closed or replaced
            pass
    _exit(status[0])


def console() -> "NoReturn":
    """The ``skf-ref`` console script: :func:`main`, then exit with its status.

    Ctrl-C at any moment ends with one line and status 130: while the command runs (it
    stops, every file written is complete, :func:`main`); while it winds down (its exit
    handlers stop joblib's workers) or after it, even when the interruption was caught and
    dropped on the way (a KeyboardInterrupt inside a finalizer, which Python only prints):
    files are complete, and the status says the run was interrupted.
    """
    import atexit

    status = [0]
    atexit.register(_exit_after_handlers, status)  # runs last, after joblib's handlers
    sys.unraisablehook = _quiet_interrupts(sys.unraisablehook)
    signal.signal(signal.SIGINT, _interrupt)
    try:
        status[0] = main()
        signal.signal(signal.SIGINT, _end_now)
    except KeyboardInterrupt:  # after main's own handling, before the line above
        signal.signal(signal.SIGINT, _end_now)
        print(_INTERRUPTED, file=sys.stderr)
        status[0] = 130
    if _SEEN and status[0] != 130:  # interrupted, and the interruption swallowed
        print(_INTERRUPTED, file=sys.stderr)
        status[0] = 130
    sys.exit(status[0])


def _one_line(err: BaseException) -> str:
    text = str(err) or type(err).__name__
    if isinstance(err, OSError) and err.filename is not None and str(err.filename) not in text:
        text = f"{text}: {err.filename}"
    return re.sub(r"\s*\n\s*", " ", text).strip()
