"""The ``skf-ref`` command line.

Errors print one line and exit with status 2; files appear whole or not at all (written
to a temporary name in the same folder, then renamed).
"""

import argparse
import contextlib
import os
import sys
import time
from pathlib import Path

import numpy as np

from ._io import atomic_path
from ._validation import check_real

__all__ = ["main"]


class _UsageError(Exception):
    pass


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise _UsageError(message)


class _Progress:
    """Stage messages on stderr with the time each stage took."""

    def __init__(self, quiet=False):
        self.quiet = quiet

    @contextlib.contextmanager
    def stage(self, text):
        start = time.perf_counter()
        if not self.quiet:
            print(f"{text} ...", end="", file=sys.stderr, flush=True)
        try:
            yield
        finally:
            if not self.quiet:
                print(f" {time.perf_counter() - start:.1f} s", file=sys.stderr, flush=True)


def _demo_parser(subparsers):
    demo = subparsers.add_parser(
        "demo",
        help="the paper's P20/N20 study at one setting: metrics, figures and arrays",
        description="Simulate the P20/N20 scenario, reconstruct it with the SKF with and "
        "without smoothing, print the metrics and write figures (PNG) and arrays (.npz).",
    )
    demo.add_argument("--out", type=Path, default=Path("skf-demo"), help="output folder")
    demo.add_argument("--snr-db", type=float, default=30.0, help="measurement peak SNR (dB)")
    demo.add_argument("--pm-snr-db", type=float, default=0.0, help="PM-SNR (dB)")
    demo.add_argument("--ep-snr-db", type=float, default=20.0, help="EP-SNR (dB)")
    demo.add_argument("--exponent", type=float, default=1.25, help="standardization exponent")
    demo.add_argument(
        "--smoother",
        default="rts-standardized",
        choices=("rts-standardized", "rts-state"),
        help="smoother of the smoothed reconstruction",
    )
    demo.add_argument("--positions", type=int, default=3000, help="source positions (about)")
    demo.add_argument("--montage", default="biosemi64", help="MNE built-in montage")
    demo.add_argument("--seed", type=int, default=0, help="noise seed")
    demo.add_argument("--quiet", action="store_true", help="no progress messages")
    demo.set_defaults(run=run_demo)


def run_demo(args):
    """Run ``skf-ref demo``; returns the metrics as a pandas DataFrame."""
    import pandas as pd

    from . import metrics, plots, simulate
    from .priors import priors_from_snr
    from .reconstruct import reconstruct

    # cheap checks first, so a typo fails at once and not after the head model is built
    check_real("snr_db", args.snr_db)
    check_real("pm_snr_db", args.pm_snr_db)
    check_real("ep_snr_db", args.ep_snr_db)
    check_real("exponent", args.exponent, nonnegative=True)
    progress = _Progress(args.quiet)
    args.out.mkdir(parents=True, exist_ok=True)
    with progress.stage(f"head model ({args.positions} positions, {args.montage})"):
        head = simulate.make_head_model(args.positions, args.montage)
    scenario = simulate.p20n20_scenario()
    sim = simulate.simulate(head, scenario, args.snr_db, args.seed)
    T = sim.Y.shape[1]
    theta0, q = priors_from_snr(head.leadfield, sim.sigma, args.pm_snr_db, args.ep_snr_db, T)
    runs = {}
    with progress.stage(f"SKF, filter only and {args.smoother}"):
        for label, smoother in (("filtered", None), ("smoothed", args.smoother)):
            rec = reconstruct(
                head.leadfield,
                sim.Y,
                noise_std=sim.sigma,
                theta0=theta0,
                q=q,
                exponent=args.exponent,
                smoother=smoother,
            )
            runs[label] = rec
    with atomic_path(args.out / "reconstruction.npz") as tmp:
        np.savez_compressed(
            tmp,
            z_filtered=runs["filtered"].z,
            z_smoothed=runs["smoothed"].z,
            weights=runs["filtered"].weights,
            positions=head.positions,
            times=sim.times,
            Y=sim.Y,
            sigma=sim.sigma,
            true_positions=sim.truth.positions,
            true_waveforms=sim.truth.waveforms,
            theta0=theta0,
            q=q,
        )
    table = pd.DataFrame({k: metrics.summarize(r, head, sim.truth) for k, r in runs.items()})
    print(
        f"SKF, exponent {args.exponent:g}, EP-SNR {args.ep_snr_db:g} dB, PM-SNR "
        f"{args.pm_snr_db:g} dB, data SNR {args.snr_db:g} dB, {head.n_positions} positions"
    )
    print(table.to_string())
    with progress.stage("figures"):
        setting = f"{args.snr_db:g} dB, EP {args.ep_snr_db:g}, PM {args.pm_snr_db:g}"
        for label, rec in runs.items():
            name = "filter only" if label == "filtered" else args.smoother
            title = f"SKF {name}, exponent {args.exponent:g}\n{setting}"
            with atomic_path(args.out / f"time_courses_{label}.png") as tmp:
                plots.plot_time_courses(rec, head, sim.truth, title=title, path=tmp)
            with atomic_path(args.out / f"average_reconstruction_{label}.png") as tmp:
                plots.plot_average_reconstruction(rec, head, sim.truth, title=title, path=tmp)
        with atomic_path(args.out / "metrics.csv") as tmp:
            table.to_csv(tmp)
    if not args.quiet:
        print(f"wrote figures, metrics.csv and reconstruction.npz to {args.out}", file=sys.stderr)
    return table


def _sweep_parser(subparsers):
    sweep = subparsers.add_parser(
        "sweep",
        help="a grid of P20/N20 runs, one tidy row each, resumable",
        description="Run a grid over snr_db x ep_snr_db x pm_snr_db x exponent x smoother x "
        "seed, appending one row per run (parameters, metrics, versions) to FILE (CSV, or "
        "Parquet for a .parquet name). Rerunning with the same FILE skips finished rows. "
        "Axes not given take the paper grid's values.",
    )
    sweep.add_argument("--out", type=Path, required=True, metavar="FILE", help="results file")
    sweep.add_argument("--jobs", type=int, default=1, help="parallel workers (-1: all cores)")
    sweep.add_argument("--grid", choices=("paper",), default="paper", help="the base grid")
    sweep.add_argument("--snr-db", type=float, nargs="+", help="data SNRs (dB)")
    sweep.add_argument("--ep-snr-db", type=float, nargs="+", help="EP-SNRs (dB)")
    sweep.add_argument("--pm-snr-db", type=float, nargs="+", help="PM-SNRs (dB)")
    sweep.add_argument("--exponent", type=float, nargs="+", help="standardization exponents")
    sweep.add_argument(
        "--smoother",
        nargs="+",
        choices=("none", "rts-standardized", "rts-state"),
        help="smoothers ('none': filter only)",
    )
    sweep.add_argument("--seeds", type=int, default=10, help="noise seeds 0 .. SEEDS-1")
    sweep.add_argument("--positions", type=int, default=3000, help="source positions (about)")
    sweep.add_argument("--montage", default="biosemi64", help="MNE built-in montage")
    sweep.add_argument("--quiet", action="store_true", help="no progress bar")
    sweep.set_defaults(run=run_sweep_command)


def run_sweep_command(args):
    """Run ``skf-ref sweep``; returns the results table."""
    from .sweep import paper_grid, run_sweep

    grid = paper_grid(seeds=args.seeds)
    for axis in ("snr_db", "ep_snr_db", "pm_snr_db", "exponent"):
        if getattr(args, axis) is not None:
            grid[axis] = getattr(args, axis)
    if args.smoother is not None:
        grid["smoother"] = [None if s == "none" else s for s in args.smoother]
    try:
        table = run_sweep(
            grid,
            args.out,
            n_jobs=args.jobs,
            n_positions=args.positions,
            montage=args.montage,
            progress=not args.quiet,
        )
    except KeyboardInterrupt:
        print(
            f"skf-ref: interrupted; finished rows are in {args.out}: rerun to resume",
            file=sys.stderr,
        )
        raise SystemExit(130) from None
    if not args.quiet:
        print(f"{len(table)} rows in {args.out}", file=sys.stderr)
    return table


def build_parser():
    """The ``skf-ref`` argument parser."""
    parser = _Parser(prog="skf-ref", description="Standardized Kalman filter for EEG sources.")
    subparsers = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    _demo_parser(subparsers)
    _sweep_parser(subparsers)
    return parser


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
    try:
        args = build_parser().parse_args(argv)
        os.environ.setdefault("MPLBACKEND", "Agg")
        args.run(args)
    except (_UsageError, ValueError, TypeError, MemoryError, OSError) as err:
        print(f"skf-ref: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("skf-ref: interrupted; files already written are complete", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
