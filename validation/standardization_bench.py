"""Benchmark: standardization per position and the smoother standardized by its own variance.

``python -m validation.standardization_bench [--size N_COLUMNS,N_CHANNELS,N_TIMES]``
``[--repeats N] [--competitor]`` writes its section of ``validation/bench/results.md`` and
``validation/bench/standardization.csv``.

At 150 000 lead-field columns x 128 channels x 1000 steps by default (the benchmark problem
of :func:`validation.bench.make_problem`: a sphere-model volume grid, free orientation,
PM-SNR 0 dB, EP-SNR 20 dB; its covariance recursion does not settle within 1000 steps, so
every step has weights of its own), each comparison times ``reconstruct(...).z`` from the
lead field and the data, the SVD included, on the spectral path:

- ``standardize="position"`` (``n_orient=3``) against the column form, filter only, at
  exponent 0.5 (target: at most :data:`TARGETS` ``["position-0.5"]`` times the column
  form) and at 1.25 (the paper's; target for exponents other than 0.5);
- ``smoother="rts-smoothed-weights"`` against ``"rts-state"``, exponent 0.5, column form.

The two runs of a comparison alternate, so that both see the same load; each pair gives one
ratio, and the table reports medians with interquartile ranges of wall time, of process CPU
time (every thread) and of the ratios, and the load (1-minute average and tasks runnable
besides the benchmark) before the runs. One pair is run first and not timed: it warms the
libraries and, where numba is installed, compiles the 3 x 3 closed form of the position
form (once per installation: numba caches it on disk), whose one-off time is reported.

numba is the optional extra ``fast`` (in ``all``); the README's ``pip install ".[test]"``
and CI do not install it. Every comparison is therefore run twice, with the compiled
closed form and without it (numpy's, as in an installation without numba), unless
``--numba installed`` or ``--numba absent`` picks one; without numba installed only the
second runs. The smoother's comparison (column form) does not use numba: it runs once.
"""

import argparse
import contextlib
import sys
import time
from pathlib import Path

import pandas as pd

from skf_ref._utils.atomic_files import atomic_path
from validation import timing

__all__ = [
    "CLOSED_FORM",
    "COMPARISONS",
    "HEADING",
    "SIZE",
    "TARGETS",
    "compare",
    "main",
    "numba_used",
    "to_markdown",
]

#: (n_columns, n_channels, n_times)
SIZE = (150_000, 128, 1000)
#: Its section of validation/bench/results.md.
HEADING = "## Standardization per position and the smoothed weights"
#: label: (baseline settings, compared settings)
COMPARISONS = {
    "position-0.5": (
        dict(exponent=0.5, smoother=None),
        dict(exponent=0.5, smoother=None, standardize="position", n_orient=3),
    ),
    "position-1.25": (
        dict(exponent=1.25, smoother=None),
        dict(exponent=1.25, smoother=None, standardize="position", n_orient=3),
    ),
    "rts-smoothed-weights": (
        dict(exponent=0.5, smoother="rts-state"),
        dict(exponent=0.5, smoother="rts-smoothed-weights"),
    ),
}
#: The comparisons whose compared run takes the 3 x 3 closed form (numba's, where used).
CLOSED_FORM = ("position-0.5", "position-1.25")
#: The issue's targets: the compared run's time over the baseline's, at most.
TARGETS = {"position-0.5": 1.3, "position-1.25": 2.0, "rts-smoothed-weights": 1.3}


def runner(problem, settings):
    """``reconstruct(...).z`` of ``problem`` on the spectral path, with ``settings``."""
    from skf_ref import reconstruct

    L = problem["head"].leadfield

    def run():
        rec = reconstruct(
            L,
            problem["Y"],
            noise_std=problem["noise_std"],
            theta0=problem["theta0"],
            q=problem["q"],
            path="spectral",
            **settings,
        )
        return rec.z  # computed on access

    return run


@contextlib.contextmanager
def numba_used(used):
    """The position form's closed form compiled by numba (``used``) or in numpy, as in an
    installation without numba; yields the ``numba`` column: its version, or "absent"."""
    from skf_ref.method import _sym3_compiled

    installed = _sym3_compiled.AVAILABLE
    _sym3_compiled.AVAILABLE = used
    try:
        yield _sym3_compiled.numba.__version__ if used else "absent"
    finally:
        _sym3_compiled.AVAILABLE = installed


def _timed(run):
    load = timing.load()
    cpu, start = time.process_time(), time.perf_counter()
    run()
    return time.perf_counter() - start, time.process_time() - cpu, load


def compare(problem, label, repeats=5, progress=print):
    """Alternate the baseline and the compared run of one comparison.

    Returns
    -------
    dict
        One row: median wall and CPU times of both, the median ratios with quartiles, the
        load, the untimed first pair's times.
    """
    from validation.bench import blas_columns

    baseline, compared = (runner(problem, s) for s in COMPARISONS[label])
    first = (_timed(baseline), _timed(compared))
    pairs = []
    for i in range(repeats):
        pairs.append((_timed(baseline), _timed(compared)))
        (bw, bc, _), (cw, cc, load) = pairs[-1]
        progress(
            f"  {label}, pair {i + 1}: baseline {bw:.2f} s ({bc:.2f} CPU-s), compared "
            f"{cw:.2f} s ({cc:.2f} CPU-s), ratio {cw / bw:.3f}, load {load[0]:.2f}/{load[1]:.0f}"
        )
    n, m, T = (problem["head"].leadfield.shape[1], *problem["Y"].shape)
    return dict(
        comparison=label,
        n_columns=n,
        n_channels=m,
        n_times=T,
        **timing.pair_summary(pairs, "baseline", "compared"),
        first_compared_seconds=first[1][0],
        target=TARGETS[label],
        **blas_columns(),
    )


def to_markdown(rows, header=()):
    """The comparisons as a markdown section (heading included), ``header`` lines first."""
    lines = [
        HEADING,
        "",
        *([*header, ""] if header else []),
        "`reconstruct(...).z` on the spectral path, from the lead field and the data (SVD "
        "included), the two runs of each comparison alternated "
        "(validation/standardization_bench.py). Baselines: the column form at the same "
        'exponent; `"rts-state"` for the smoother. Medians over the pairs; ratios are '
        "medians of per-pair ratios [interquartile range]; the first pair is not timed "
        "(its compared run, with numba's one-off compilation where it happens, is given). "
        "Load: 1-minute average / tasks runnable besides the benchmark, before each run. "
        "numba: the version that compiled the position form's 3 x 3 closed form, or "
        "\"absent\" (numpy's closed form, as without the extra `fast`: the README's "
        '`pip install ".[test]"` and CI).',
        "",
        "| comparison | numba | size | pairs | baseline s (CPU-s) | compared s (CPU-s) "
        "| ratio, wall | ratio, CPU | target | first compared run s | load | BLAS |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['comparison']} | {r['numba']} "
            f"| {r['n_columns']} x {r['n_channels']} x {r['n_times']} "
            f"| {r['pairs']} | {r['baseline_seconds']:.2f} ({r['baseline_cpu_seconds']:.2f}) "
            f"| {r['compared_seconds']:.2f} ({r['compared_cpu_seconds']:.2f}) "
            f"| {r['ratio']:.3f} [{r['ratio_q1']:.3f}, {r['ratio_q3']:.3f}] "
            f"| {r['cpu_ratio']:.3f} [{r['cpu_ratio_q1']:.3f}, {r['cpu_ratio_q3']:.3f}] "
            f"| <= {r['target']:g} | {r['first_compared_seconds']:.2f} "
            f"| {r['load_1min']:.2f} / {r['runnable']:.0f} | {r['blas']} |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m validation.standardization_bench")
    parser.add_argument("--size", default=",".join(map(str, SIZE)))
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--comparisons", default=",".join(COMPARISONS))
    parser.add_argument("--competitor", action="store_true")
    parser.add_argument("--numba", choices=("both", "installed", "absent"), default="both")
    parser.add_argument("--out", default=str(Path(__file__).parent / "bench"))
    args = parser.parse_args(argv)
    from validation.bench import header_lines, make_problem

    size = tuple(int(v) for v in args.size.split(","))
    labels = args.comparisons.split(",")
    unknown = [label for label in labels if label not in COMPARISONS]
    if unknown:
        parser.error(f"--comparisons: unknown {unknown}; known: {list(COMPARISONS)}")
    from skf_ref.method._sym3_compiled import AVAILABLE

    if args.numba == "installed" and not AVAILABLE:
        parser.error("--numba installed: numba is not installed (pip install numba)")
    uses = {"both": [True, False] if AVAILABLE else [False], "installed": [True]}
    problem = make_problem(*size)
    rows = []
    with timing.competitor(args.competitor):
        for k, used in enumerate(uses.get(args.numba, [False])):
            with numba_used(used) as version:
                for label in labels:
                    if label in CLOSED_FORM:
                        rows.append({**compare(problem, label, args.repeats), "numba": version})
                    elif k == 0:  # no closed form: numba plays no part
                        rows.append({**compare(problem, label, args.repeats), "numba": "-"})
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table = pd.DataFrame(rows)
    table["competitor"] = args.competitor
    with atomic_path(out / "standardization.csv") as path:
        table.to_csv(path, index=False)
    header = header_lines(table)[:2]  # machine, versions, BLAS (no memory column here)
    if args.competitor:
        header = [*header, "Beside a competitor (a single-threaded busy loop)."]
    results = out / "results.md"
    text = results.read_text() if results.exists() else "# Benchmarks\n"
    with atomic_path(results) as path:
        Path(path).write_text(timing.replace_section(text, HEADING, to_markdown(rows, header)))
    print(to_markdown(rows, header))
    return 0


if __name__ == "__main__":
    sys.exit(main())
