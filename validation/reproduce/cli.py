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
from datetime import UTC, datetime
from pathlib import Path

from skf_ref._utils.atomic_files import atomic_path

from .baselines import baseline_files, baseline_jobs, describe, read_baselines
from .cells import best_cell, result_files, run_cell_sweeps, run_variants
from .figures import FIGURE_GROUPS, make_figures, save_source_placement
from .overview import Overview, overview_text
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

__all__ = ["main", "output_folder", "prepare_out"]


# --------------------------------------------------------------------------- results files


def prepare_out(out, wanted, fresh=False, names=RESULTS):
    """Create ``out``; delete its results files if stale (or if ``fresh``).

    Parameters
    ----------
    out : Path
        Report folder.
    wanted : dict
        The current :func:`manifest`.
    fresh : bool
        Delete the results files even if the recorded settings match.
    names : sequence of str
        The results files, relative to ``out``.

    Returns
    -------
    str or None
        Why the results files were deleted, or None if they are reused.
    """
    out.mkdir(parents=True, exist_ok=True)
    recorded = out / MANIFEST
    existing = [out / name for name in names if (out / name).exists()]
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
    parser.add_argument(
        "--quick",
        action="store_true",
        help="a smoke run: 2 seeds, 500 positions, 12 mm grids, tiny sets, the first cell's "
        "figures only (not evidence)",
    )
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
    parser.add_argument(
        "--mne-testing-data",
        metavar="DIR",
        help="MNE's testing dataset folder, for the BEM cells (default: MNE's own lookup, "
        "never downloading)",
    )
    parser.add_argument(
        "--cache-dir", metavar="DIR", help="where the BEM forward models are cached"
    )
    return parser


def _settings(args, realistic=True):
    preset = QUICK if args.quick else FULL
    settings = Settings(
        seeds=preset.seeds if args.seeds is None else args.seeds,
        n_positions=preset.n_positions if args.n_positions is None else args.n_positions,
        fine_step=preset.fine_step if args.fine_step is None else args.fine_step,
        quick=args.quick,
        realistic=realistic,
        spacing_mm=preset.spacing_mm,
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
        ``--n-positions``, ``--fine-step`` changing a value, or no testing dataset for the
        BEM cells) and ``out`` is the committed report folder or inside it.
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


def _sweep_cells(settings, out, n_jobs, progress, common):
    """Every cell's sweeps (:func:`cells.run_cell_sweeps`): cell name -> CellResult.

    A full run's cells each hold hundreds of tasks, run on all workers one cell after
    another; a ``--quick`` run's hold a few small ones each, where a pool per sweep (five
    a cell) costs more than the work: one cell per worker, each sweeping in its process.
    """
    from joblib import Parallel, delayed

    if not settings.quick:
        return {
            cell.name: run_cell_sweeps(cell, settings, out, n_jobs, progress, **common)
            for cell in settings.cells
        }
    swept = Parallel(n_jobs=n_jobs)(
        delayed(run_cell_sweeps)(cell, settings, out, 1, False, **common)
        for cell in settings.cells
    )
    return {result.cell.name: result for result in swept}


def _cell_jobs(results, settings, wanted, out):
    """The jobs that judge every cell (:func:`_judge_cell`) and draw its figures, and what
    makes the judged results of their outputs.

    Drawing a cell's 15 figures is most of a judge's time: they are drawn in two jobs
    (:data:`figures.FIGURE_GROUPS`), first, beside the cells' verdicts. A ``--quick`` run
    draws the first cell's only (every kind of figure, once). A cell without figures writes
    its page in its job; the others' are written by ``judged(outputs)``, which returns the
    judged results (cell name -> CellResult).
    """
    drawn = [r.cell.name for k, r in enumerate(results.values()) if k == 0 or not settings.quick]
    jobs = [
        (_draw, results[name], settings, out, group) for name in drawn for group in FIGURE_GROUPS
    ]
    jobs += [
        (_judge_cell, result, settings, None if name in drawn else (wanted, out))
        for name, result in results.items()
    ]

    def judged(outputs):
        figures, verdicts = outputs[: -len(results)], outputs[-len(results) :]
        cells = {result.cell.name: result for result in verdicts}
        for k, name in enumerate(drawn):  # their pages once their figures are drawn
            groups = figures[k * len(FIGURE_GROUPS) : (k + 1) * len(FIGURE_GROUPS)]
            cells[name].figures = {key: files for group in groups for key, files in group.items()}
            _write_cell(cells[name], settings, wanted, out)
        return cells

    return jobs, judged


def _draw(result, settings, out, names):
    """A group of a cell's figures (:func:`figures.make_figures`); their file names."""
    runs = CheckedRuns(result.head, result.paper)
    folder = out / result.cell.name
    return make_figures(folder, runs, settings, result.fine, result.controls, names)


def _judge_cell(result, settings, page=None):
    """Verdicts and diagnostics of one cell; the judged result. ``page``: (manifest,
    report folder) to write its page too (a cell without figures)."""
    from .rules_v2 import evaluate_v2
    from .rules_v3 import evaluate_v3

    runs = CheckedRuns(result.head, result.paper)
    result.findings = evaluate(result.paper)
    result.findings_v2 = evaluate_v2(result.paper, result.controls)
    result.findings_v3 = evaluate_v3(result.paper, result.controls)
    result.diagnostics = diagnostics(runs, settings.seeds)
    if page is not None:
        _write_cell(result, settings, *page)
    return result


def _write_cell(result, settings, wanted, out):
    """A judged cell's summary.csv and CELL.md."""
    folder = out / result.cell.name
    with atomic_path(folder / "summary.csv") as tmp:
        summary_table(result.paper, result.fine).to_csv(
            tmp, index=False, float_format="%.6g", lineterminator="\n"
        )
    data = ReportData(
        settings=settings,
        head=result.head,
        manifest=wanted,
        paper=result.paper,
        fine=result.fine,
        findings=result.findings,
        figures=result.figures,
        diagnostics=result.diagnostics,
        sensitivity=result.sensitivity,
        findings_v2=result.findings_v2,
        findings_v3=result.findings_v3,
        truth=result.truth,
        title=result.cell.title,
    )
    with atomic_path(folder / "CELL.md") as tmp:
        tmp.write_text(report_text(data))


def _placement(out, results):
    heads, truths = {}, {}
    for conductor in ("sphere", "bem"):
        volume = results.get(f"{conductor}-volume")
        anatomical = results.get(f"{conductor}-anatomical")
        if anatomical is None or volume is None:
            continue
        label = "sphere (template)" if conductor == "sphere" else "BEM (sample subject)"
        heads[label], truths[label] = anatomical.head, anatomical.truth
    return save_source_placement(out, heads, truths)


def _generated(elapsed, jobs, computed, total):
    """The one line of REPORT.md that changes between identical runs: date and wall time."""
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    return (
        f"Generated: {stamp}; wall time {elapsed:.0f} s with --jobs {jobs} "
        f"({computed} of {total} runs computed, {total - computed} reused from the results "
        "files)."
    )


def _after_the_sweeps(results, settings, wanted, out, args, common):
    """Judge the cells, run the baselines and the worth study's first phase: one pool.

    The sphere grid's sensitivity runs first, on all workers (its section is in that cell's
    page). Then the cells' figures and verdicts (:func:`_cell_jobs`), the baselines' jobs
    (the longest first) and the worth study's first phase go to the workers together, in
    that order: as the cells' and then the baselines' outputs come back the parent writes
    the cells' pages and checks the baselines and writes their sections, while the workers
    go on.

    Returns
    -------
    judged : dict
        Cell name -> the judged CellResult.
    headline, details : str
        The baselines' sections (:func:`specificity_report.specificity_text`).
    worth : Worth
        Phase A's jobs done (:func:`worth.run.finish_worth` next).
    """
    from joblib import Parallel, delayed

    from .worth.run import start_worth

    if "sphere-volume" in results:
        result = results["sphere-volume"]
        folder = out / result.cell.name
        result.sensitivity = run_sensitivity(result.head, settings.seeds, folder, args.jobs)
    cells, judged = _cell_jobs(results, settings, wanted, out)
    baselines = baseline_jobs(settings, out, **common)
    worth, phase_a = start_worth(settings, out, fresh=args.fresh, **common)
    outputs = Parallel(n_jobs=args.jobs, return_as="generator")(
        delayed(function)(*arguments) for function, *arguments in [*cells, *baselines, *phase_a]
    )
    results = judged([next(outputs) for _ in cells])
    for _ in baselines:
        next(outputs)
    headline, details = _specificity(settings, out, results)
    for _ in outputs:
        pass
    return results, headline, details, worth


def _specificity(settings, out, results):
    """Check the baselines against the sweeps, apply the rule, draw the figures.

    Returns
    -------
    headline, details : str
        The report's sections (:func:`specificity_report.specificity_text`).
    """
    from . import specificity, specificity_report
    from .recommend import CHOICE_SEEDS

    raw = read_baselines(settings, out)
    specificity.check_against_sweeps(raw, results)
    chosen = raw["seed"].isin(CHOICE_SEEDS)
    choice = specificity.recommendation(raw[chosen])
    specificity.write_recommendation(out, *choice[:2], raw.loc[chosen, "seed"].unique())
    label = specificity.setting_label(choice[0])
    figures = specificity_report.write_figures(raw[~chosen], settings, out, label)
    with atomic_path(out / "baselines" / "scores.csv") as tmp:
        table = specificity.scores(raw[~chosen])
        table.to_csv(tmp, index=False, float_format="%.6g", lineterminator="\n")
    return specificity_report.specificity_text(table, choice, settings, figures)


_NO_DATASET = (
    "reproduce: the BEM cells need MNE's testing dataset: give --mne-testing-data DIR (DIR: "
    "the folder mne.datasets.testing.data_path() returns; nothing is downloaded); running "
    "the sphere cells only"
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
    from skf_ref.study import scenario as simulate
    from skf_ref.study.head import find_testing_data
    from skf_ref.study.sweep import read_results

    from .worth.run import finish_worth
    from .worth.text import worth_text, write_headline

    start = time.perf_counter()
    try:
        args = _parser().parse_args(argv)
        testing = find_testing_data(args.mne_testing_data)
        settings = _settings(args, realistic=testing is not None)
        out = output_folder(settings, args.out)
        head = simulate.make_head_model(settings.n_positions, MONTAGE)
        simulate.simulate(head, simulate.p20n20_scenario(), 30.0, 0)  # the grid holds it
    except (_UsageError, ValueError) as err:
        print(f"reproduce: {err}", file=sys.stderr)
        return 2
    if testing is None:
        print(_NO_DATASET, file=sys.stderr)
    wanted = dict(manifest(settings, testing), baselines=describe(settings))
    names = result_files(settings)
    reason = prepare_out(out, wanted, args.fresh, names + baseline_files(settings))
    if reason is not None:
        print(f"reproduce: deleted the previous results ({reason})", file=sys.stderr)
    before = sum(len(read_results(out / name)) for name in names)
    progress = sys.stderr.isatty()
    common = dict(testing_data=testing, cache_dir=args.cache_dir)
    results = _sweep_cells(settings, out, args.jobs, progress, common)
    results, headline, details, worth = _after_the_sweeps(
        results, settings, wanted, out, args, common
    )
    best = best_cell(results)
    variants = []
    if not settings.quick:
        best_cell_ = next(cell for cell in settings.cells if cell.name == best)
        variants = run_variants(best_cell_, settings, out, args.jobs, progress, **common)
    worth = finish_worth(worth, args.jobs)
    worth_part = worth_text(worth, out)
    total = sum(len(read_results(out / name)) for name in names)
    skipped = None if testing is not None else "MNE's testing dataset was not given or found"
    data = Overview(
        settings=settings,
        manifest=wanted,
        results=results,
        skipped=skipped,
        variants=variants,
        best=best,
        figures={"placement": _placement(out, results)},
    )
    text = overview_text(data)
    elapsed = time.perf_counter() - start
    generated = _generated(elapsed, args.jobs, total - before, total)
    title, rest = text.split("\n", 1)
    before_rules, rules = rest.split("\n## Decision rules\n", 1)
    rules = f"## Decision rules\n{rules.rstrip()}\n\n{details}"
    rest = f"{before_rules}\n{worth_part}\n{headline}\n{rules}"
    with atomic_path(out / "REPORT.md") as tmp:
        tmp.write_text(f"{title}\n\n{generated}\n{rest}")
    write_headline(worth, out, rest, elapsed)
    for cell in settings.cells:
        result = results[cell.name]
        verdicts = ", ".join(
            f"F{a.number} {a.verdict} / {b.verdict} / {c.verdict}"
            for a, b, c in zip(
                result.findings, result.findings_v2, result.findings_v3, strict=True
            )
        )
        print(f"{cell.title} (v1 / v2 / v3): {verdicts}")
    print(f"reproduce: wrote {out / 'REPORT.md'} in {elapsed:.1f} s")
    return 0
