"""``skf-ref bids``: an SKF estimate beside each evoked of MNE-BIDS-pipeline's derivatives."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path
from typing import Any

from ..method import RECOMMENDED_SETTING
from ._args import add_skf_options, integer

__all__ = ["add_parser", "run"]

_EXAMPLES = """\
examples:
  skf-ref bids ds000248/derivatives/mne-bids-pipeline
  skf-ref bids DERIV_ROOT --subject 01 02 --jobs 2 --pm-snr-db auto

For each sub-XX/[ses-YY/]{meg,eeg}/ folder of DERIVATIVES_ROOT (the pipeline's deriv_root):
one SKF operator from its forward (*_fwd.fif), noise covariance (*_cov.fif) and the rank
the pipeline saved (*_rank.json), applied to every condition of every evoked
(*_task-TASK_ave.fif), written beside it as *_task-TASK_COND+SKF+hemi.h5, as the pipeline
writes its COND+dSPM+hemi.h5, with the settings, inputs and versions in
*_task-TASK_COND+SKF+hemi.json. Estimates that exist are skipped (--overwrite computes
them again): run the command again to resume an interrupted run. Every file is whole or
absent.
"""


def _root(text: str) -> Path:
    path = Path(text)
    if not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: no such folder")
    return path


def add_parser(subparsers: Any) -> None:
    """Add ``bids`` to the ``skf-ref`` subcommands.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``skf-ref``'s parser's ``add_subparsers`` returned.
    """
    parser = subparsers.add_parser(
        "bids",
        help="an SKF estimate beside each evoked of MNE-BIDS-pipeline's derivatives",
        description="Apply the SKF to every evoked of MNE-BIDS-pipeline's derivatives, one "
        "operator per subject, writing a source estimate per condition beside it "
        "(skf_ref.apply_skf_bids).",
        epilog=_EXAMPLES,
    )
    parser.add_argument(
        "root", type=_root, metavar="DERIVATIVES_ROOT", help="the pipeline's deriv_root"
    )
    parser.add_argument(
        "--subject", nargs="+", metavar="LABEL", help="only these subjects (01 02 ...)"
    )
    parser.add_argument(
        "--noise-cov",
        metavar="PART",
        help="where a folder holds several noise covariances: a part of the name of the one "
        "to take (proc-clean, task-noise ...)",
    )
    model = parser.add_argument_group("the SKF")
    add_skf_options(
        model,
        exponent=RECOMMENDED_SETTING["exponent"],
        smoother=RECOMMENDED_SETTING["smoother"] or "none",
        smoother_help="RTS smoother",
    )
    model.add_argument(
        "--standardize",
        choices=("column", "position"),
        help="each source position's orientations as a whole, or each column of the forward "
        "on its own (default: position with EEG, column for MEG alone)",
    )
    model.add_argument(
        "--pick-ori",
        default="none",
        choices=("none", "vector"),
        help="free orientation: per-position norm ('none') or the three components",
    )
    parser.add_argument(
        "--jobs",
        type=integer(minimum=-1),
        default=1,
        help="subjects computed at once, in processes (-1: every core)",
    )
    parser.add_argument(
        "--overwrite", action="store_true", help="compute existing estimates again"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress messages")
    parser.set_defaults(run=run)


def _ignore_interrupts() -> None:
    """A job's initializer: Ctrl-C is the parent's to handle (it stops the jobs)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def run(args: argparse.Namespace) -> dict[str, list[Path]]:
    """Run ``skf-ref bids``: every estimate not written yet.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    dict
        :func:`skf_ref.apply_skf_bids`'s answer.
    """
    import joblib

    from .._utils.checks import InputError
    from ..io._bids import apply_skf_bids

    if args.jobs == 0:
        raise InputError("argument --jobs: must be a positive number of processes or -1")
    settings = dict(
        pm_snr_db=args.pm_snr_db,
        ep_snr_db=args.ep_snr_db,
        exponent=args.exponent,
        smoother=None if args.smoother == "none" else args.smoother,
        standardize=args.standardize,
        pick_ori=None if args.pick_ori == "none" else args.pick_ori,
    )
    try:
        with joblib.parallel_config(backend="loky", initializer=_ignore_interrupts):
            done = apply_skf_bids(
                args.root,
                subjects=args.subject,
                noise_cov=args.noise_cov,
                n_jobs=args.jobs,
                overwrite=args.overwrite,
                verbose=False,
                **settings,
            )
    except KeyboardInterrupt:
        print(
            f"skf-ref: interrupted; the estimates written in {args.root} are whole: rerun to "
            "resume",
            file=sys.stderr,
        )
        raise SystemExit(130) from None
    except InputError as err:
        text = str(err).replace("noise_cov=PART (--noise-cov PART)", "--noise-cov PART")
        if text.startswith("root: "):
            text = "argument DERIVATIVES_ROOT: " + text[len("root: ") :]
        text = text.replace("subjects: ", "argument --subject: ", 1)
        raise InputError(text) from None
    if not args.quiet:
        for path in done["written"]:
            print(f"wrote {path}", file=sys.stderr)
        print(
            f"{len(done['written'])} estimates written, {len(done['skipped'])} there already"
            + (" (--overwrite computes them again)" if done["skipped"] else ""),
            file=sys.stderr,
        )
    return done
