"""``skf-ref sweep``: a grid of P20/N20 runs, one tidy row each, resumable."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from .._utils.checks import InputError
from ..study._sizes import DEFAULT_POSITIONS, SCENARIO_MIN_POSITIONS
from ._args import Parser, db, integer, nonnegative

if TYPE_CHECKING:
    from collections.abc import Callable

    import pandas as pd

__all__ = ["add_parser", "run"]

_GRID_AXES = ("snr_db", "ep_snr_db", "pm_snr_db", "exponent", "smoother")


def _results_file(text: str) -> Path:
    path = Path(text)
    if path.suffix not in (".csv", ".parquet"):
        raise argparse.ArgumentTypeError(f"must end in .csv or .parquet, got {text!r}")
    return path


def add_parser(subparsers: argparse._SubParsersAction[Parser]) -> None:
    """Add ``sweep`` to the ``skf-ref`` subcommands.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``skf-ref``'s parser's ``add_subparsers`` returned.
    """
    from ..study._sweep import paper_grid

    paper = paper_grid(seeds=10)
    sweep = subparsers.add_parser(
        "sweep",
        help="a grid of P20/N20 runs, one tidy row each, resumable",
        description="Run a grid over snr_db x ep_snr_db x pm_snr_db x exponent x smoother x "
        "seed, appending one row per run (parameters, metrics, versions) to FILE (CSV, or "
        "Parquet for a .parquet name). Rerunning with the same FILE skips finished rows; only "
        "one sweep may write a file at a time. Axes not given take the paper grid's values.",
    )
    sweep.add_argument(
        "--out", type=_results_file, required=True, metavar="FILE", help="results file"
    )
    sweep.add_argument(
        "--jobs", type=integer(minimum=-1), default=1, help="parallel workers (-1: all cores)"
    )
    sweep.add_argument("--grid", choices=("paper",), default="paper", help="the base grid")
    sweep.add_argument("--snr-db", type=db(), nargs="+", default=paper["snr_db"], help="data SNRs")
    sweep.add_argument(
        "--ep-snr-db", type=db(), nargs="+", default=paper["ep_snr_db"], help="EP-SNRs (dB)"
    )
    sweep.add_argument(
        "--pm-snr-db", type=db(), nargs="+", default=paper["pm_snr_db"], help="PM-SNRs (dB)"
    )
    sweep.add_argument(
        "--exponent",
        type=nonnegative(),
        nargs="+",
        default=paper["exponent"],
        help="standardization exponents",
    )
    sweep.add_argument(
        "--smoother",
        nargs="+",
        choices=("none", "rts-standardized", "rts-state"),
        default=["none", "rts-standardized", "rts-state"],
        help="smoothers ('none': filter only)",
    )
    sweep.add_argument(
        "--seeds", type=integer(minimum=1), default=10, help="noise seeds 0 .. SEEDS-1"
    )
    sweep.add_argument(
        "--positions",
        type=integer(minimum=SCENARIO_MIN_POSITIONS),
        default=DEFAULT_POSITIONS,
        help="source positions requested",
    )
    sweep.add_argument("--montage", default="biosemi64", help="MNE built-in montage")
    sweep.add_argument("--quiet", action="store_true", help="no progress bar")
    sweep.set_defaults(run=run)


def _ignore_interrupts() -> None:
    """A worker's initializer: Ctrl-C (sent to every process of the terminal's group) is
    the parent's to handle; it stops the workers itself, and they print nothing."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run_sweep(
    args: argparse.Namespace, grid: dict, run_sweep: Callable, torn_line: type[Warning]
) -> pd.DataFrame:
    """run_sweep, its workers deaf to Ctrl-C; on an interruption one line, then exit 130.

    Only the sweep's own notes (a torn last line cut off) are printed, before anything
    else; joblib's warnings (the tasks it cancelled) are dropped on an interruption and
    shown on success.
    """
    import warnings

    import joblib

    interrupted = False
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", torn_line)
        try:
            with joblib.parallel_config(backend="loky", initializer=_ignore_interrupts):
                table = run_sweep(
                    grid,
                    args.out,
                    n_jobs=args.jobs,
                    n_positions=args.positions,
                    montage=args.montage,
                    verbose=not args.quiet,
                    size_name="--positions",
                )
        except KeyboardInterrupt:
            interrupted = True
    for warning in caught:
        if issubclass(warning.category, torn_line):
            print(f"skf-ref: note: {warning.message}", file=sys.stderr)
    if interrupted:
        print(
            f"skf-ref: interrupted; finished rows are in {args.out}: rerun to resume",
            file=sys.stderr,
        )
        raise SystemExit(130)
    for warning in caught:
        if not issubclass(warning.category, torn_line):
            warnings.warn_explicit(
                warning.message, warning.category, warning.filename, warning.lineno
            )
    return table


def run(args: argparse.Namespace) -> pd.DataFrame:
    """Run ``skf-ref sweep``: the grid's runs not yet in the results file.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    pandas.DataFrame
        Every row of the results file (:func:`skf_ref.study._sweep.run_sweep`).
    """
    from .._utils.atomic_files import check_output_path
    from ..study._head import check_montage
    from ..study._sweep import TornLineWarning, paper_grid, run_sweep

    if args.jobs == 0:
        raise InputError("argument --jobs: must be a positive number of workers or -1")
    check_output_path(args.out, name="argument --out")  # resumed: an existing one is kept
    try:
        check_montage(args.montage)
    except InputError as err:
        raise InputError(f"argument --montage: {err}") from None
    grid = paper_grid(seeds=args.seeds)
    for axis in _GRID_AXES:
        grid[axis] = getattr(args, axis)
    grid["smoother"] = [None if s == "none" else s for s in args.smoother]
    table = _run_sweep(args, grid, run_sweep, TornLineWarning)
    if not args.quiet:
        print(f"{len(table)} rows in {args.out}", file=sys.stderr)
    return table
