"""``python -m validation.reproduce``: the evidence study v3, from its pre-registration."""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

from skf_ref._utils.atomic_files import atomic_path


def _parser():
    parser = argparse.ArgumentParser(prog="python -m validation.reproduce", description=__doc__)
    parser.add_argument("--mne-testing-data", help="root of MNE's testing dataset")
    parser.add_argument("--jobs", type=int, default=1, help="processes (default 1)")
    parser.add_argument("--out", default="validation/report", help="report folder")
    parser.add_argument("--work", help="folder of the runs' rows (default: the cache)")
    parser.add_argument("--quick", action="store_true", help="sphere head, tiny sizes (dev)")
    return parser


def main(argv=None):
    """Run the study and write the report; returns the process's exit status."""
    args = _parser().parse_args(argv)
    from skf_ref.study._head import cache_dir, find_testing_data

    root = None
    if not args.quick:
        root = find_testing_data(args.mne_testing_data)
        if root is None:
            print("reproduce: MNE's testing data not found (give --mne-testing-data DIR, or "
                  "use --quick)", file=sys.stderr)  # fmt: skip
            return 2
        root = str(root)
    work = Path(args.work) if args.work else cache_dir() / ("v3-quick" if args.quick else "v3")
    return run(root, args.quick, args.jobs, Path(args.out), work)


def _invocations(work, start, computed):
    """The wall time of every invocation that computed cells (``work/timing.json``), summed."""
    path = work / "timing.json"
    log = json.loads(path.read_text()) if path.exists() else []
    log.append(dict(started=time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(start)),
                    wall_s=round(time.time() - start), cells_computed=computed))  # fmt: skip
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(log, indent=1) + "\n")
    return float(sum(entry["wall_s"] for entry in log if entry["cells_computed"] > 0))


def run(root, quick, jobs, out, work):
    """The two phases, the rule, and the report in ``out``."""
    from threadpoolctl import threadpool_info

    from . import rule, write
    from .design import CANDIDATES, DESIGNS, QUICK_CANDIDATES, named
    from .run import phase_a, phase_b, read_cells, save_sources

    start, cpu = time.time(), time.process_time()
    cells_before = len(list((work / "cells").glob("*.csv")))
    save_sources(work, root, quick)
    phase_a(work, root, quick, jobs)
    rows = read_cells(work, "*-a.csv")
    limits = rule.thresholds(rows)
    choice = rule.summarize(rule.with_detection(rows, limits), by=("design", "method"))
    candidates = QUICK_CANDIDATES if quick else CANDIDATES
    default, table = rule.choose(choice, candidates)
    designs = [d for d in DESIGNS if d in choice.index.get_level_values(0)]
    met = bool(table.iloc[0]["designs_met"] == len(designs))
    taus = rows[rows["method"] == named(default)["N4" if not default.by_data else "N1"].label]
    tau = (
        float(taus["tau_ms"].median())
        if "tau_ms" in taus and taus["tau_ms"].notna().any()
        else 30.0
    )
    phase_b(work, root, quick, jobs, default, tau)
    every = read_cells(work)
    every = every[~every.duplicated(["set", "condition", "design", "kind", "run", "method"])]
    limits = rule.thresholds(every)
    every = rule.with_detection(every, limits)
    scored_rows = every[every["set"] == "scored"]
    scored = rule.summarize(scored_rows, by=("design", "method"))
    tasks = every.drop_duplicates(["set", "condition", "design", "cpu_s"])["cpu_s"]
    wall = _invocations(work, start, len(list((work / "cells").glob("*.csv"))) - cells_before)
    blas = [(i.get("internal_api"), i.get("num_threads"), i.get("architecture"))
            for i in threadpool_info()]  # fmt: skip
    meta = dict(
        minutes=f"{wall / 60:.0f}", wall_s=round(wall), invocations="timing.json",
        cpu_s_main=round(time.process_time() - cpu), cpu_s_tasks=round(float(tasks.sum())),
        jobs=jobs, load=os.getloadavg(), machine=platform.processor() or platform.machine(),
        blas=blas, quick=quick, window_tau_ms=tau,
    )  # fmt: skip
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "rule.csv", index=False, float_format="%.4g")
    with atomic_path(out / "timing.json") as tmp:  # every invocation's wall time
        Path(tmp).write_text((work / "timing.json").read_text())
    choice.to_csv(out / "choice_summary.csv", float_format="%.4g")
    scored.to_csv(out / "scored_summary.csv", float_format="%.4g")
    with atomic_path(out / "rows.csv.gz") as tmp:
        every.to_csv(
            tmp, index=False, float_format="%.5g", compression={"method": "gzip", "mtime": 0}
        )
    head = write.headline(out / "headline.json", scored_rows, scored, default, met, meta)
    write.report(
        out / "REPORT.md", rows, scored_rows, choice, scored, default, table, meta, head["tables"]
    )
    with atomic_path(out / "default.json") as tmp:
        Path(tmp).write_text(json.dumps(dict(
            exponent=default.exponent, dynamics=default.dynamics,
            standardize=default.standardize, smoother=default.smoother,
        ), indent=1) + "\n")  # fmt: skip
    print(f"default: {default.label} (every design met on the choice set: {met}); "
          f"{meta['minutes']} min")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
