"""The ``skf-ref`` command line.

A user's mistake (a bad option, an unreadable file, input the package refuses) prints one
line naming the flag or file and exits with status 2; Ctrl-C prints one line and exits with
130; files appear whole or not at all (written to a hidden temporary in the same folder,
then renamed). Anything else is a bug in the package and shows its traceback. ``--debug``
shows the traceback of every error.
"""

import os
import re
import sys

from ..checks import InputError
from ..version import __version__
from . import demo, sweep
from ._args import Parser

__all__ = ["build_parser", "main"]


def build_parser():
    """The ``skf-ref`` argument parser.

    Returns
    -------
    argparse.ArgumentParser
    """
    parser = Parser(
        prog="skf-ref",
        description="Standardized Kalman filter (SKF) for EEG source localization: the "
        "P20/N20 study of Prasikala et al. (2025) and parameter sweeps over it.",
    )
    parser.add_argument("--version", action="version", version=f"skf-ref {__version__}")
    parser.add_argument(
        "--debug", action="store_true", help="show the traceback of an error (for bug reports)"
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    demo.add_parser(subparsers)
    sweep.add_parser(subparsers)
    return parser


def _debug_asked(argv):
    return "--debug" in argv[: argv.index("--")] if "--" in argv else "--debug" in argv


def main(argv=None):
    """Entry point of ``skf-ref``; returns the exit status.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        0 on success, 2 on a usage or input error, 130 when interrupted.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.command is None:
            parser.print_help()
            return 0
        os.environ.setdefault("MPLBACKEND", "Agg")
        args.run(args)
    except SystemExit as exit_:  # --help and --version
        return exit_.code if isinstance(exit_.code, int) else 0
    except (InputError, OSError, MemoryError) as err:
        if _debug_asked(argv):
            raise
        print(f"skf-ref: error: {_one_line(err)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        if _debug_asked(argv):
            raise
        print("skf-ref: interrupted; files already written are complete", file=sys.stderr)
        return 130
    return 0


def _one_line(err):
    text = str(err) or type(err).__name__
    if isinstance(err, OSError) and err.filename is not None and str(err.filename) not in text:
        text = f"{text}: {err.filename}"
    return re.sub(r"\s*\n\s*", " ", text).strip()
