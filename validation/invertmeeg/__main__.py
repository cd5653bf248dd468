"""Run invertmeeg's benchmark with the SKF beside its solvers; write the results table.

``python -m validation.invertmeeg --mne-testing-data DIR [--out DIR] [--n-samples N]
[--seed S] [--solvers ID ...]``

Needs invertmeeg (``pip install invertmeeg``, GPL-3; not a dependency of skf_ref) and MNE's
testing dataset in ``DIR`` (the folder ``mne.datasets.testing.data_path()`` returns; nothing
is downloaded). Run from the repository's root, in an environment with skf_ref and
invertmeeg.

invertmeeg's ``BenchmarkRunner`` does everything that is scored: it simulates its four
datasets (focal, multi-source, extended, noisy; 50 time points each), builds and applies each
solver, with its own regularization choice, and computes its metrics (MLE, EMD, spatial
dispersion, average precision, correlation) and its ranks. This script only gives it a
forward (:mod:`validation.invertmeeg.forward`: invertmeeg's own needs fsaverage, which is
not here), registers the SKF (:mod:`validation.invertmeeg.solver`), and writes into ``OUT``:

- ``benchmark.json``: the runner's own results file (``BenchmarkRunner.save``: every sample's
  metrics, its ranks);
- ``results.csv``: per dataset and solver, each metric's median and quartiles over the
  samples (MLE and EMD converted to mm from the runner's metres), the runner's rank on that
  dataset and its global rank, the solver's time;
- ``RESULTS.md``: that table, with the versions, seed, samples, times, BLAS threads and load;
- ``run.json``: those, and the time constant the SKF's priors chose on each sample.

``--tables-only`` writes the last two again from ``benchmark.json`` and ``run.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np
import pandas as pd

#: invertmeeg's standard static solvers, its random-noise floor, and the best of its
#: published leaderboard's global ranks (results/release/leaderboard.json of invertmeeg's
#: repository, February 2026: FlexChampagne, OmniChampagne, AltProj (id "flex-ap") and
#: SubspaceSBL among its first five). Its runner's default set also has MacKay's Champagne
#: ("champagne-mackay"), left out: about 2 minutes per sample here on two busy cores.
SOLVERS = (
    "mne",
    "dspm",
    "sloreta",
    "eloreta",
    "lcmv",
    "flex-champagne",
    "omni-champagne",
    "flex-ap",
    "subspace-sbl",
    "random-noise",
    "skf",
)
DATASETS = ("focal_source", "multi_source", "extended_source", "noisy")
#: Samples per dataset: invertmeeg's default is 50; 5 kept the run of record to 22 minutes on
#: two cores shared at a load near 12 (every data-dependent solver is made once per sample;
#: FlexChampagne and OmniChampagne took 15-25 s a sample).
N_SAMPLES = 5
SEED = 0
#: The runner's metric names, ours, the factor to the unit reported.
METRICS = (
    ("mle", "MLE (mm)", 1000.0),
    ("emd", "EMD (mm)", 1000.0),
    ("sd", "SD", 1.0),
    ("ap", "AP", 1.0),
    ("correlation", "r", 1.0),
)
HERE = Path(__file__).resolve().parent


def versions():
    from importlib import metadata

    import invert  # noqa: F401
    import mne
    import threadpoolctl

    import skf_ref

    blas = [
        f"{pool['internal_api']} {pool['num_threads']}"
        for pool in threadpoolctl.threadpool_info()
        if pool["user_api"] == "blas"
    ]
    return {
        "invertmeeg": metadata.version("invertmeeg"),
        "mne": mne.__version__,
        "numpy": np.__version__,
        "skf_ref": skf_ref.__version__,
        "python": platform.python_version(),
        "blas_threads": ", ".join(blas),
        "cpus": os.cpu_count(),
    }


def run(testing_data, n_samples=N_SAMPLES, seed=SEED, solvers=SOLVERS, datasets=DATASETS):
    """The runner's results and what the SKF's priors chose, with times and load."""
    from invert.benchmark import BENCHMARK_DATASETS, BenchmarkRunner

    from .forward import benchmark_forward
    from .solver import CHOICES, register

    register()
    load_before = os.getloadavg()
    t0, c0 = time.perf_counter(), time.process_time()
    fwd, info = benchmark_forward(testing_data)
    forward_s = time.perf_counter() - t0
    runner = BenchmarkRunner(
        fwd,
        info,
        solvers=list(solvers),
        datasets={name: BENCHMARK_DATASETS[name] for name in datasets},
        n_samples=n_samples,
        n_jobs=1,  # the solvers one after another: their times are their own
        random_seed=seed,
    )
    del CHOICES[:]
    runner.run()
    meta = dict(
        n_samples=n_samples,
        seed=seed,
        n_positions=int(fwd["nsource"]),
        n_channels=len(info["ch_names"]),
        forward_s=forward_s,
        wall_s=time.perf_counter() - t0,
        cpu_s=time.process_time() - c0,
        load_before=load_before,
        load_after=os.getloadavg(),
        time_constants_ms=[c.time_constant_ms for c in CHOICES],
        at_bound=[dict(c.at_bound) for c in CHOICES],
        **versions(),
    )
    return runner, meta


def table(saved):
    """``results.csv``'s rows from the runner's saved results (``benchmark.json``)."""
    rows = []
    for result in saved["results"]:
        dataset, solver = result["dataset_name"], result["solver_name"]
        row = dict(dataset=dataset, solver=solver, n=len(result["samples"]))
        for key, name, factor in METRICS:
            values = factor * np.array([s[key] for s in result["samples"]], dtype=float)
            with np.errstate(invalid="ignore"):  # inf - inf in the interpolation
                quartiles = np.nanpercentile(values, [25, 50, 75])
            # SD is infinite where the truth's FWHM is 0 (invertmeeg's convention): a
            # quartile between a finite and an infinite value is infinite, not NaN
            quartiles[np.isnan(quartiles) & np.isinf(values).any()] = np.inf
            q1, median, q3 = quartiles
            row.update({f"{name} median": median, f"{name} q1": q1, f"{name} q3": q3})
        row["rank"] = saved["ranks"][dataset].get(solver, np.nan)
        row["global rank"] = saved["global_ranks"].get(solver, np.nan)
        row["time (s)"] = (result.get("timing") or {}).get("total_seconds", np.nan)
        rows.append(row)
    return pd.DataFrame(rows)


def _cell(row, name):
    digits = 1 if "mm" in name else 2
    median, q1, q3 = (row[f"{name} {s}"] for s in ("median", "q1", "q3"))
    return f"{median:.{digits}f} [{q1:.{digits}f}, {q3:.{digits}f}]"


def markdown(frame, meta):
    lines = [
        "# The SKF on invertmeeg's benchmark",
        "",
        "Written by `python -m validation.invertmeeg` (its docstring says how to run it). "
        "invertmeeg's `BenchmarkRunner` simulated the data, ran every solver and scored "
        "them with its own metrics and ranks; the SKF ran through the adapter "
        "`validation/invertmeeg/solver.py` at skf_ref's defaults, its priors chosen by "
        "the data.",
        "",
        f"- **Forward**: the sample subject (MNE's testing data), cortex labels of aseg "
        f"at 7 mm, {meta['n_positions']} positions, fixed radial orientation, "
        f"{meta['n_channels']} EEG electrodes with an average reference, three-layer BEM "
        "(`validation/invertmeeg/forward.py` says why: invertmeeg's own forward needs "
        "fsaverage, which is not on this machine and cannot be downloaded).",
        f"- **Protocol**: invertmeeg's four datasets as it defines them (50 time points), "
        f"{meta['n_samples']} samples each (its default is 50; fewer for the run time), "
        f"random seed {meta['seed']}, `n_jobs=1`.",
        f"- **Versions**: invertmeeg {meta['invertmeeg']}, mne {meta['mne']}, numpy "
        f"{meta['numpy']}, skf_ref {meta['skf_ref']}, Python {meta['python']}.",
        f"- **Time**: {meta['wall_s']:.0f} s wall, {meta['cpu_s']:.0f} s CPU (the forward "
        f"{meta['forward_s']:.0f} s of it), on {meta['cpus']} shared cores; BLAS threads: "
        f"{meta['blas_threads']}; load average (1, 5, 15 min) before "
        f"{', '.join(f'{v:.2f}' for v in meta['load_before'])}, after "
        f"{', '.join(f'{v:.2f}' for v in meta['load_after'])}.",
    ]
    taus = np.array([t for t in meta["time_constants_ms"] if t is not None], dtype=float)
    on_bound = sum(bool(b) for b in meta["at_bound"])
    if taus.size:
        q1, med, q3 = np.percentile(taus, [25, 50, 75])
        lines.append(
            f"- **The SKF's priors**: PM-SNR 0 dB, AR(1) time constant chosen by the "
            f"marginal likelihood: median {med:.1f} ms [{q1:.1f}, {q3:.1f}] over its "
            f"{taus.size} applications, on an end of the searched 1-1000 ms in {on_bound}."
        )
    lines += [
        "",
        "Median [IQR] over the samples. MLE and EMD in mm (the runner's distances are "
        "metres here), lower is better; SD (spatial dispersion: the estimate's FWHM over the "
        "truth's), lower is better; AP (average precision) and r (correlation), higher is "
        "better. Rank: invertmeeg's, the mean over the five metrics of each solver's rank "
        "by the metric's mean on that dataset (1 is best); global rank: its mean over the "
        "datasets. SD is infinite on a sample where the truth's FWHM is 0 (invertmeeg's "
        "convention). Time: the solver's seconds on the dataset's samples, as the runner "
        "measured them, on the loaded machine above.",
        "",
        "invertmeeg's solvers logged `Failed to build SSP projector (No mne attribute "
        "make_projector); using I.` with this MNE: they ran without the info's "
        "average-reference projector, on the simulator's unreferenced data and lead field "
        "(consistent with each other); the SKF applies the average reference to both.",
        "",
    ]
    names = [name for _, name, _ in METRICS]
    for dataset, part in frame.groupby("dataset", sort=False):
        lines += [f"## {dataset}", ""]
        lines.append("| solver | " + " | ".join(names) + " | rank | time (s) |")
        lines.append("|---" * (len(names) + 3) + "|")
        for _, row in part.sort_values("rank").iterrows():
            cells = [_cell(row, name) for name in names]
            lines.append(
                f"| {row['solver']} | "
                + " | ".join(cells)
                + f" | {row['rank']:.1f} | {row['time (s)']:.1f} |"
            )
        lines.append("")
    ranks = frame.drop_duplicates("solver").sort_values("global rank")
    lines += ["## Global rank", "", "| solver | global rank |", "|---|---|"]
    lines += [f"| {r['solver']} | {r['global rank']:.2f} |" for _, r in ranks.iterrows()]
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m validation.invertmeeg", description=__doc__)
    parser.add_argument("--mne-testing-data", type=Path)
    parser.add_argument("--out", type=Path, default=HERE)
    parser.add_argument("--n-samples", type=int, default=N_SAMPLES)
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--solvers", nargs="+", default=list(SOLVERS))
    parser.add_argument("--datasets", nargs="+", default=list(DATASETS))
    parser.add_argument(
        "--tables-only",
        action="store_true",
        help="rewrite results.csv and RESULTS.md from OUT's benchmark.json and run.json",
    )
    args = parser.parse_args(argv)
    if not args.tables_only and args.mne_testing_data is None:
        parser.error("--mne-testing-data is required (except with --tables-only)")
    if args.tables_only:
        meta = json.loads((args.out / "run.json").read_text())
    else:
        runner, meta = run(
            args.mne_testing_data, args.n_samples, args.seed, args.solvers, args.datasets
        )
        args.out.mkdir(parents=True, exist_ok=True)
        runner.save(args.out / "benchmark.json", name="skf_ref on invertmeeg's benchmark")
        (args.out / "run.json").write_text(json.dumps(meta, indent=1) + "\n")
    saved = json.loads((args.out / "benchmark.json").read_text())
    frame = table(saved)
    frame.to_csv(args.out / "results.csv", index=False, float_format="%.6g")
    (args.out / "RESULTS.md").write_text(markdown(frame, meta))
    print((args.out / "RESULTS.md").read_text())


if __name__ == "__main__":
    main()
