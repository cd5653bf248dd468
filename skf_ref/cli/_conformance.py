"""``skf-ref conformance export``: the pinned conformance suite, to check another SKF against."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

__all__ = ["add_parser", "run_export"]

# skf_ref.conformance._case_files.FORMATS, spelled out so that building the parser imports no numpy
_FORMATS = ("npz", "mat")

_EXAMPLES = """\
examples:
  skf-ref conformance export skf-cases                 # every case as .npz and .mat
  skf-ref conformance export skf-cases --format mat    # MATLAB and Octave only
  skf-ref conformance export skf-cases-v2 --suite 2    # version 2, as skf_ref 0.3 wrote it
  skf-ref conformance export skf-cases-v3 --suite 3    # version 3, without the AR(1) cases

Then run your implementation on each case (its inputs: L, Y, noise_cov, theta0, q,
transition, exponent, smoother, and from version 3 standardize and n_orient; a scalar
noise_cov c is R = c I, a variance), save its
outputs (z, z_filtered, x, x_filtered, weights, log_likelihood) and check them with
`skf-ref compare CASE_FILE YOURS`. The runners run_cases.m (MATLAB, Octave) and
run_cases.py (Python) do the first two for every case. manifest.json lists the cases,
what each exercises, its tolerance, the versions and every file's sha256;
docs/conformance.md describes the files.
"""


def add_parser(subparsers: Any) -> None:
    """Add ``conformance`` (and its action ``export``) to the ``skf-ref`` subcommands.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``skf-ref``'s parser's ``add_subparsers`` returned.
    """
    parser = subparsers.add_parser(
        "conformance",
        help="conformance cases to check your own SKF against",
        description="Small fixed problems with the reference's answers, for checking "
        "another implementation of the SKF (MATLAB, C++, Julia, GPU ...).",
    )
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    export = actions.add_parser(
        "export",
        help="copy the cases, manifest.json and the runners to a folder",
        description="Copy the pinned conformance suite (every case's inputs and expected "
        "outputs, one file per case and format, and manifest.json with their sha256) and "
        "the runners run_cases.m and run_cases.py to DIR. The files are the suite's, byte "
        "for byte, whatever the version of skf_ref. A file of DIR named like a case or the "
        "manifest that holds other bytes is replaced only with --overwrite (the suite's own "
        "bytes stay as they are). A runner already in DIR that you adapted is kept: the "
        "shipped one is written beside it (run_cases_shipped.py).",
        epilog=_EXAMPLES,
    )
    export.add_argument("directory", type=Path, metavar="DIR", help="folder (made if missing)")
    export.add_argument(
        "--format",
        nargs="+",
        choices=_FORMATS,
        default=list(_FORMATS),
        help="file formats: NumPy .npz, MATLAB v5 .mat (MATLAB and Octave read it with load)",
    )
    export.add_argument(
        "--suite",
        type=int,
        choices=(2, 3, 4),
        default=4,
        help="the suite version: 4 (this skf_ref's, the default: version 3's cases and two "
        "of the stationary AR(1) prior), or 3 or 2 (their files byte for byte, as earlier "
        "skf_ref exported them)",
    )
    export.add_argument(
        "--overwrite",
        action="store_true",
        help="replace files of DIR named like the suite's cases or manifest that hold other "
        "bytes (never an adapted runner)",
    )
    export.add_argument("--quiet", action="store_true", help="no summary")
    export.set_defaults(run=run_export)


def run_export(args: argparse.Namespace) -> list[Path]:
    """Run ``skf-ref conformance export``: write the suite's cases and runners.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    import warnings

    from .._utils.checks import InputError
    from ..conformance import export, manifest

    with warnings.catch_warnings(record=True) as kept:
        warnings.simplefilter("always", UserWarning)
        try:
            written = export(
                args.directory, args.format, suite=args.suite, overwrite=args.overwrite
            )
        except InputError as err:  # the library's advice, as the command line's flag
            raise InputError(str(err).replace("overwrite=True", "--overwrite")) from None
    for warning in kept:  # a runner the user edited: kept, the shipped one beside it
        print(f"skf-ref: note: {warning.message}", file=sys.stderr)
    if not args.quiet:
        n_cases = sum(path.suffix in (".npz", ".mat") for path in written)
        print(
            f"wrote {n_cases} case files, the runners run_cases.m and run_cases.py, and "
            f"manifest.json to {args.directory} (conformance suite version {args.suite}, "
            f"computed by skf_ref {manifest(args.suite)['skf_ref_version']})",
            file=sys.stderr,
        )
    return written
