"""``skf-ref compare``: your SKF's outputs against a conformance case; the likely mistake."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._args import positive

if TYPE_CHECKING:
    from ..conformance._compare import Comparison

__all__ = ["add_parser", "run"]

_EXAMPLES = """\
examples:
  skf-ref compare skf-cases/average_reference.mat mine.mat
  skf-ref compare skf-cases/average_reference.npz mine.csv --json report.json

THEIRS holds any of z, z_filtered, x, x_filtered, weights ((n_sources, n_times)) and
log_likelihood: a .npz or .mat file with those names, or a .csv long table with the
header output,source,step,value (source and step counting from 1; empty for
log_likelihood). An output given as (n_times, n_sources) is compared as its transpose
and reported as transposed. A .npz or .mat file may also hold the intermediate quantities
(P_pred, S, K, P_filt, w, ...: docs/conformance.md); the report then names the first that
leaves the tolerance, its equation, step and row (first_divergence in the JSON). Exit
status: 0 when everything given agrees; 1 when something does not, or is transposed (the
report says where it first goes wrong, names a known mistake only when it reproduces or
explains the numbers, and says when they agree to the precision of float32 or of the
digits printed); 2 when the files cannot be used (no output name, another shape, not a
case file).
"""


def add_parser(subparsers: Any) -> None:
    """Add ``compare`` to the ``skf-ref`` subcommands.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``skf-ref``'s parser's ``add_subparsers`` returned.
    """
    parser = subparsers.add_parser(
        "compare",
        help="check your SKF's outputs against a conformance case and name the likely mistake",
        description="Compare another implementation's outputs with a conformance case "
        "(skf-ref conformance export): per output, the largest relative difference, the "
        "first time step over the tolerance and a verdict; when something disagrees, where it "
        "first goes wrong and which known mistake, if any, explains the numbers.",
        epilog=_EXAMPLES,
    )
    parser.add_argument("case", type=Path, metavar="CASE_FILE", help="a case's .npz or .mat")
    parser.add_argument("theirs", type=Path, metavar="THEIRS", help="your outputs: .npz/.mat/.csv")
    parser.add_argument(
        "--tolerance",
        type=positive(),
        help="largest relative difference that agrees (default: the case's, 1e-6; 1e-4 for "
        "a float32 implementation)",
    )
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the result as JSON")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --json file")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> Comparison:
    """Run ``skf-ref compare``: print the report; exit status 1 when something disagrees.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    skf_ref.conformance._compare.Comparison
        The comparison (when every output agrees: else ``SystemExit(1)``).
    """
    from .._utils.atomic_files import atomic_path, check_output_path
    from ..conformance._compare import compare

    if args.json is not None:  # before any work: a folder that exists, no input replaced
        check_output_path(
            args.json,
            name="argument --json",
            suffixes=(".json",),
            inputs={"CASE_FILE": args.case, "THEIRS": args.theirs},
            overwrite=args.overwrite,
            overwrite_hint="give --overwrite to replace it",
        )
    result = compare(args.case, args.theirs, tolerance=args.tolerance)
    if args.json is not None:
        # without --overwrite, a file that appeared meanwhile is never replaced
        with atomic_path(args.json, overwrite=args.overwrite) as tmp:
            tmp.write_text(json.dumps(result.to_dict(), indent=1) + "\n", encoding="utf-8")
    print(result.report())
    if not result.agrees:
        raise SystemExit(1)
    return result
