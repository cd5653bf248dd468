"""Benchmark: the AR(1) prior's time constant and PM-SNR chosen by the likelihood (``tune``).

``python -m validation.tune_time_constant [--size N_CHANNELS,N_COLUMNS,N_TIMES]``
``[--repeats N] [--blas-threads N] [--write]``

The issue's target: ``tune(L, Y, noise_std=1, time_constant_ms="auto", sfreq=500)`` under 1 s
at 60 channels x 8000 lead-field columns x 300 samples (the default size). The problem is
drawn from the model itself (seeded): a Gaussian lead field, sources from the stationary
AR(1) prior (time constant 20 ms at 500 Hz, PM-SNR 0 dB), unit white noise. Timed, each
with wall time, the CPU time of this process (all its threads), the 1-minute load average
and the tasks runnable (``validation.timing.measure``), and the BLAS library and threads
(threadpoolctl):

- ``tune-time-constant``: the whole choice, as a user calls it (checks, whitening and SVD,
  the 13 x 13 grid of PM-SNR and log(tau), the L-BFGS-B refinement, the result);
- ``svd``: its first part alone, the whitening and thin SVD of the lead field
  (``SpectralBasis``), which depends on the size of the lead field;
- ``search``: the rest, the likelihood over the grid and the refinement on the projected
  data (rank-r recursions, no n-dimensional array), which depends on rank and samples only;
- ``tune-ep-snr``: the random walk's ``tune`` (EP-SNR and PM-SNR, ``"auto"``) on the same
  data, for comparison.

``--write`` writes ``validation/bench/tune_time_constant.md``. Exit status 0.
"""

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

from validation.timing import load, measure

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "bench" / "tune_time_constant.md"
SFREQ = 500.0
TIME_CONSTANT_MS = 20.0


def problem(n_channels, n_columns, n_times, seed=0):
    """``L`` (n_channels, n_columns) and ``Y`` drawn from the AR(1) prior, unit noise."""
    from skf_ref import ar1_priors

    rng = np.random.default_rng(seed)
    L = rng.standard_normal((n_channels, n_columns))
    theta0, q, rho = ar1_priors(L, 1.0, 0.0, TIME_CONSTANT_MS, SFREQ)
    X = np.empty((n_columns, n_times))
    X[:, 0] = np.sqrt(theta0) * rng.standard_normal(n_columns)
    for t in range(1, n_times):
        X[:, t] = rho * X[:, t - 1] + np.sqrt(q) * rng.standard_normal(n_columns)
    return L, L @ X + rng.standard_normal((n_channels, n_times))


def blas():
    """The BLAS libraries and their threads, as threadpoolctl reports them."""
    from threadpoolctl import threadpool_info

    return "; ".join(
        f"{entry['internal_api']} {entry.get('version')}, {entry['num_threads']} threads"
        for entry in threadpool_info()
        if entry["user_api"] == "blas"
    )


def run(size, repeats):
    """Every timing of the module docstring: ``[(name, measure's dict, note)]``."""
    import pandas  # noqa: F401  (the result's table: imported once, as in a session)
    import scipy.optimize  # noqa: F401  (the refinement)

    from skf_ref import tune
    from skf_ref.method import SpectralBasis

    L, Y = problem(*size)
    chosen = {}

    def whole():
        chosen["ar1"] = tune(L, Y, noise_std=1.0, time_constant_ms="auto", sfreq=SFREQ)

    def random_walk():
        with warnings.catch_warnings():  # a bound, if the walk's EP-SNR wants one
            warnings.simplefilter("ignore", UserWarning)
            chosen["walk"] = tune(L, Y, noise_std=1.0)

    eye = np.eye(len(L))
    rows = [("tune-time-constant", measure(whole, repeats, trace_memory=False))]
    rows.append(("svd", measure(lambda: SpectralBasis(L, eye), repeats, trace_memory=False)))
    search = rows[0][1]["seconds"] - rows[1][1]["seconds"]
    cpu = rows[0][1]["cpu_seconds"] - rows[1][1]["cpu_seconds"]
    rows.append(("search", dict(seconds=search, cpu_seconds=cpu), "the difference of the two"))
    rows.append(("tune-ep-snr", measure(random_walk, repeats, trace_memory=False)))
    rows = [row if len(row) == 3 else (*row, "") for row in rows]
    return rows, chosen


def table(rows, chosen, size):
    """The results as markdown."""
    ar1, walk = chosen["ar1"], chosen["walk"]
    lines = [
        "# Choosing the AR(1) prior's time constant: time",
        "",
        "Written by `python -m validation.tune_time_constant --write` (its docstring says what "
        "each row times).",
        "",
        f"Size: {size[0]} channels x {size[1]} lead-field columns x {size[2]} samples at "
        f"{SFREQ:g} Hz; data from the AR(1) prior at {TIME_CONSTANT_MS:g} ms, PM-SNR 0 dB. "
        f"BLAS: {blas()}. Load before: {load()[0]:.2f} (1-minute average).",
        "",
        f"Chosen: {ar1!r}; the random walk's: {walk!r}.",
        "",
        "| what | wall s (median) | CPU s (median) | load 1 min | runnable | runs | note |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, m, note in rows:
        lines.append(
            f"| {name} | {m['seconds']:.3f} | {m['cpu_seconds']:.3f} | "
            f"{m.get('load_1min', float('nan')):.2f} | {m.get('runnable', float('nan')):.0f} | "
            f"{m.get('runs', '')} | {note} |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="60,8000,300", help="channels,columns,samples")
    parser.add_argument("--repeats", type=int, default=7, help="timed runs of each")
    parser.add_argument("--blas-threads", type=int, help="limit BLAS to this many threads")
    parser.add_argument("--write", action="store_true", help=f"write {RESULTS.name}")
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.split(","))
    if args.blas_threads is not None:
        from threadpoolctl import threadpool_limits

        threadpool_limits(args.blas_threads, user_api="blas")
    rows, chosen = run(size, args.repeats)
    text = table(rows, chosen, size)
    print(text)
    if args.write:
        RESULTS.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
