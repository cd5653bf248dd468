"""The command line: arguments, the results folder, the sweeps, and the report written.

``python -m validation.reproduce`` runs :func:`main`. The results files are resumable;
:func:`prepare_out` deletes them when they were computed under other settings or code.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

from skf_ref.files import atomic_path

from .figures import make_figures
from .report import ReportData, report_text
from .rules import evaluate
from .runs import CheckedRuns, diagnostics
from .sensitivity import run_sensitivity
from .settings import (
    DEFAULT_OUT,
    FINE_RANGE,
    FULL,
    MANIFEST,
    MONTAGE,
    QUICK,
    QUICK_OUT,
    RESULTS,
    Settings,
    manifest,
)
from .stats import summary_table

__all__ = ["main", "output_folder", "prepare_out", "run_sweeps"]


# --------------------------------------------------------------------------- results files


def prepare_out(out, wanted, fresh=False):
    """Create ``out``; delete its results files if stale (or if ``fresh``).

    Parameters
    ----------
    out : Path
        Report folder.
    wanted : dict
        The current :func:`manifest`.
    fresh : bool
        Delete the results files even if the recorded settings match.

    Returns
    -------
    str or None
        Why the results files were deleted, or None if they are reused.
    """
    out.mkdir(parents=True, exist_ok=True)
    recorded = out / MANIFEST
    existing = [out / name for name in RESULTS if (out / name).exists()]
    try:
        previous = json.loads(recorded.read_text()) if recorded.exists() else None
    except json.JSONDecodeError:
        previous = None
    reason = None
    if fresh:
        reason = "--fresh"
    elif existing and previous != json.loads(json.dumps(wanted)):
        reason = "settings, versions or skf_ref sources changed since they were computed"
    if reason is not None:
        for path in existing:
            path.unlink()
    with atomic_path(recorded) as tmp:
        tmp.write_text(json.dumps(wanted, indent=1, sort_keys=True) + "\n")
    return reason if existing else None


def run_sweeps(settings, out, n_jobs, progress):
    """Run (or resume) both sweeps; return the sorted paper and fine tables and the new rows.

    Parameters
    ----------
    settings : Settings
    out : Path
    n_jobs : int
    progress : bool

    Returns
    -------
    paper, fine : pandas.DataFrame
        Every row of the results files, sorted by the sweep key (only this run's grids:
        :func:`prepare_out` deleted files computed under other settings).
    computed : int
        Rows computed by this call (the others were reused).
    """
    from skf_ref.sweep import read_results, run_sweep

    before = sum(len(read_results(out / name)) for name in RESULTS)
    kwargs = dict(n_jobs=n_jobs, n_positions=settings.n_positions, montage=MONTAGE)
    run_sweep(settings.paper_grid(), out / RESULTS[0], progress=progress, **kwargs)
    for grid in settings.fine_grids():
        run_sweep(grid, out / RESULTS[1], progress=progress, **kwargs)
    tables = [_sorted_rewrite(out / name) for name in RESULTS]
    computed = sum(len(t) for t in tables) - before
    return tables[0], tables[1], computed


def _sorted_rewrite(path):
    """Sort a results file by its key and rewrite it (atomically); return the table."""
    from skf_ref.sweep import KEY, read_results

    table = read_results(path)
    table = table.sort_values(list(KEY), kind="stable", ignore_index=True)
    if "blas" in table:
        table["blas"] = table["blas"].map(_sorted_words)
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False, lineterminator="\n")
    return table


def _sorted_words(value):
    """The words of a ``blas`` cell in sorted order.

    ``skf_ref.provenance.blas_threads`` lists the loaded BLAS libraries in an order that
    varies from process to process (threadpoolctl's order follows the string hash seed), so
    sweep rows computed by different workers name the same libraries in different orders.
    Sorting them keeps the results files regenerable byte for byte.
    """
    return " ".join(sorted(value.split())) if isinstance(value, str) else value


# --------------------------------------------------------------------------- arguments


class _UsageError(Exception):
    pass


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise _UsageError(message)


def _parser():
    parser = _Parser(
        prog="python -m validation.reproduce",
        description="Reproduce the paper's findings with fixed decision rules; write "
        "REPORT.md, figures and the sweep tables.",
    )
    parser.add_argument("--quick", action="store_true", help="3 seeds, ~1000 positions, 20 dB map")
    parser.add_argument(
        "--out",
        type=Path,
        help=f"report folder (default: the committed {DEFAULT_OUT.parent.name}/"
        f"{DEFAULT_OUT.name}/ for the full preset, ./{QUICK_OUT}/ for any other run)",
    )
    parser.add_argument("--jobs", type=int, default=1, help="parallel workers (-1: all cores)")
    parser.add_argument("--fresh", action="store_true", help="recompute every run")
    parser.add_argument("--seeds", type=int, help="override the preset's number of seeds")
    parser.add_argument("--n-positions", type=int, help="override the preset's head model size")
    parser.add_argument("--fine-step", type=float, help="override the fine map's step (dB)")
    return parser


def _settings(args):
    preset = QUICK if args.quick else FULL
    settings = Settings(
        seeds=preset.seeds if args.seeds is None else args.seeds,
        n_positions=preset.n_positions if args.n_positions is None else args.n_positions,
        fine_step=preset.fine_step if args.fine_step is None else args.fine_step,
        quick=args.quick,
    )
    if args.jobs == 0 or args.jobs < -1:
        raise _UsageError(f"--jobs must be a positive number of workers or -1, got {args.jobs}")
    if settings.seeds < 2:
        raise _UsageError(
            f"--seeds must be at least 2 (for a standard error), got {settings.seeds}"
        )
    span = FINE_RANGE[1] - FINE_RANGE[0]
    steps = span / settings.fine_step if settings.fine_step > 0 else 0.5
    if not math.isfinite(steps) or abs(steps - round(steps)) > 1e-9 or round(steps) < 1:
        raise _UsageError(
            f"--fine-step must be a positive step that divides {span:g} dB, got "
            f"{settings.fine_step:g}"
        )
    return settings


def _inside(path, folder):
    path, folder = path.resolve(), folder.resolve()
    return path == folder or folder in path.parents


def output_folder(settings, out=None):
    """The folder a run writes to; refuse to let a partial run replace the committed report.

    Parameters
    ----------
    settings : Settings
    out : Path, optional
        The ``--out`` argument.

    Returns
    -------
    Path
        ``out`` if given, else :data:`DEFAULT_OUT` (the committed report) for the full
        preset and :data:`QUICK_OUT` (untracked, in the current directory) for any other.

    Raises
    ------
    ValueError
        If the settings are not the full preset's (``--quick``, or ``--seeds``,
        ``--n-positions``, ``--fine-step`` changing a value) and ``out`` is the committed
        report folder or inside it.
    """
    full = settings.is_full()
    if out is None:
        return DEFAULT_OUT if full else QUICK_OUT
    if not full and _inside(out, DEFAULT_OUT):
        raise ValueError(
            f"--out {out} is the committed report folder, which only the full run writes; "
            f"a --quick or partial run writes elsewhere (default ./{QUICK_OUT})"
        )
    return out


# --------------------------------------------------------------------------- main


def _report_data(settings, head, wanted, paper, fine, out):
    """Judge the findings, draw the figures, run the diagnostics and the sensitivity analysis."""
    runs = CheckedRuns(head, paper)
    return ReportData(
        settings=settings,
        head=head,
        manifest=wanted,
        paper=paper,
        fine=fine,
        findings=evaluate(paper),
        figures=make_figures(out, runs, settings, fine),
        diagnostics=diagnostics(runs, settings.seeds),
        sensitivity=run_sensitivity(head, settings.seeds, out),
    )


def _generated(elapsed, jobs, computed, total):
    """The one line of REPORT.md that changes between identical runs: date and wall time."""
    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return (
        f"Generated: {stamp}; wall time {elapsed:.0f} s with --jobs {jobs} "
        f"({computed} of {total} runs computed, {total - computed} reused from the results "
        "files)."
    )


def main(argv=None):
    """Run the reproduction and write the report.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 for bad arguments (one line on stderr).
    """
    from skf_ref import simulate

    start = time.perf_counter()
    try:
        args = _parser().parse_args(argv)
        settings = _settings(args)
        out = output_folder(settings, args.out)
        head = simulate.make_head_model(settings.n_positions, MONTAGE)
        simulate.simulate(head, simulate.p20n20_scenario(), 30.0, 0)  # the grid holds it
    except (_UsageError, ValueError) as err:
        print(f"reproduce: {err}", file=sys.stderr)
        return 2
    wanted = manifest(settings)
    reason = prepare_out(out, wanted, args.fresh)
    if reason is not None:
        print(f"reproduce: deleted the previous results ({reason})", file=sys.stderr)
    paper, fine, computed = run_sweeps(settings, out, args.jobs, sys.stderr.isatty())
    data = _report_data(settings, head, wanted, paper, fine, out)
    with atomic_path(out / "summary.csv") as tmp:
        summary_table(paper, fine).to_csv(
            tmp, index=False, float_format="%.6g", lineterminator="\n"
        )
    text = report_text(data)
    elapsed = time.perf_counter() - start
    generated = _generated(elapsed, args.jobs, computed, len(paper) + len(fine))
    title, rest = text.split("\n", 1)
    with atomic_path(out / "REPORT.md") as tmp:
        tmp.write_text(f"{title}\n\n{generated}\n{rest}")
    for finding in data.findings:
        print(f"F{finding.number}: {finding.verdict}")
    print(f"reproduce: wrote {out / 'REPORT.md'} in {elapsed:.1f} s")
    return 0
