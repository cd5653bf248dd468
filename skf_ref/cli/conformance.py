"""``skf-ref conformance export``: the conformance cases, to check another SKF against."""

import sys
from pathlib import Path

__all__ = ["add_parser", "run_export"]

# skf_ref.conformance.FORMATS, spelled out so that building the parser imports no numpy
_FORMATS = ("npz", "mat")

_EXAMPLES = """\
examples:
  skf-ref conformance export skf-cases                 # every case as .npz and .mat
  skf-ref conformance export skf-cases --format mat    # MATLAB and Octave only

Then run your implementation on each case (its inputs: L, Y, noise_cov, theta0, q,
transition, exponent, smoother), save its outputs (z, z_filtered, x, x_filtered, weights,
log_likelihood) and check them with `skf-ref compare CASE_FILE YOURS`. manifest.json lists
the cases, what each exercises, the tolerance and the versions; docs/conformance.md
describes the files.
"""


def add_parser(subparsers):
    """Add ``conformance`` (and its action ``export``) to the ``skf-ref`` subcommands."""
    parser = subparsers.add_parser(
        "conformance",
        help="conformance cases to check your own SKF against",
        description="Small fixed problems with the reference's answers, for checking "
        "another implementation of the SKF (MATLAB, C++, Julia, GPU ...).",
    )
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    export = actions.add_parser(
        "export",
        help="write the cases and manifest.json to a folder",
        description="Write every conformance case (inputs and expected outputs of the dense "
        "reference path) as one file per case and format, and manifest.json, to DIR. The "
        "files are the same, byte for byte, every time.",
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
    export.add_argument("--quiet", action="store_true", help="no summary")
    export.set_defaults(run=run_export)


def run_export(args):
    """Run ``skf-ref conformance export``; returns the files written."""
    from ..conformance import CONFORMANCE_VERSION, TOLERANCE, export

    written = export(args.directory, args.format)
    if not args.quiet:
        print(
            f"wrote {len(written) - 1} case files and manifest.json to {args.directory} "
            f"(conformance set {CONFORMANCE_VERSION}, tolerance {TOLERANCE:g})",
            file=sys.stderr,
        )
    return written
