"""Benchmark: the spectral path with the stationary AR(1) prior against the paper's random walk.

``python -m validation.ar1_bench [--out DIR] [--size N_COLUMNS,N_CHANNELS,N_TIMES]``
``[--rounds N] [--time-constant-ms TAU]``

The same problem (:func:`validation.problem.make_problem`: the sphere head, a BioSemi
montage, a dipole with noise; 150 000 columns x 128 channels x 1000 steps by default) runs
the spectral path smoothed (``"rts-standardized"``, exponent 1.25; ``z`` asked for) under two
priors: the paper's walk (``transition=1``, EP-SNR 20 dB) and the AR(1) of
:func:`skf_ref.ar1_priors` (``transition = exp(-dt / tau)``, ``q = (1 - rho**2) theta0``) at
1 kHz. Rounds alternate the two (the order swapping each round), so both runs of a round saw
the same load; each round gives one ratio, AR(1) over walk. The table reports medians and
interquartile ranges of the wall and CPU times and of the ratios, beside the BLAS threads
(threadpoolctl) and the load average. The target (issue 42): a ratio of at most 1.05.
Results go to ``DIR/ar1.md`` and ``DIR/ar1.csv`` (default ``validation/bench``).
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

import skf_ref
from validation import timing
from validation.problem import blas_columns, make_problem

SFREQ = 1000.0


def _runner(problem, theta0, q, transition):
    L = problem["head"].leadfield

    def run():
        rec = skf_ref.reconstruct(
            L, problem["Y"], noise_std=problem["noise_std"], theta0=theta0, q=q,
            transition=transition, exponent=1.25, smoother="rts-standardized",
            path="spectral",
        )  # fmt: skip
        return rec.z  # the spectral path computes its outputs on access

    return run


def _timed(run):
    before = timing.load()
    wall, cpu = time.perf_counter(), time.process_time()
    run()
    return time.perf_counter() - wall, time.process_time() - cpu, before


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=Path("validation/bench"))
    parser.add_argument("--size", default="150000,128,1000")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--time-constant-ms", type=float, default=10.0)
    args = parser.parse_args(argv)
    n_columns, n_channels, n_times = (int(v) for v in args.size.split(","))
    problem = make_problem(n_columns, n_channels, n_times)
    L, sigma = problem["head"].leadfield, problem["noise_std"]
    walk = _runner(problem, problem["theta0"], problem["q"], 1.0)
    ar1 = _runner(problem, *skf_ref.ar1_priors(L, sigma, 0.0, args.time_constant_ms, SFREQ))
    walk(), ar1()  # warm: imports, first allocations
    pairs = []
    for k in range(args.rounds):
        if k % 2:
            b, a = _timed(ar1), _timed(walk)
        else:
            a, b = _timed(walk), _timed(ar1)
        pairs.append((a, b))
    row = dict(
        n_columns=n_columns, n_channels=n_channels, n_times=n_times,
        time_constant_ms=args.time_constant_ms, sfreq=SFREQ,
        **timing.pair_summary(pairs, "walk", "ar1"), **blas_columns(),
    )  # fmt: skip
    args.out.mkdir(parents=True, exist_ok=True)
    pd.DataFrame([row]).to_csv(args.out / "ar1.csv", index=False, float_format="%.6g")
    text = (
        f"skf_ref {skf_ref.__version__}; {n_columns} columns x {n_channels} channels x "
        f"{n_times} steps, spectral, rts-standardized, exponent 1.25; AR(1) tau "
        f"{args.time_constant_ms:g} ms at {SFREQ:g} Hz against the walk (EP 20 dB); "
        f"{row['pairs']} alternated rounds; BLAS: {row['blas']}.\n\n"
        "| prior | wall s (median) | CPU s (median) |\n|---|---|---|\n"
        f"| random walk | {row['walk_seconds']:.2f} | {row['walk_cpu_seconds']:.2f} |\n"
        f"| AR(1) | {row['ar1_seconds']:.2f} | {row['ar1_cpu_seconds']:.2f} |\n\n"
        f"AR(1) / walk: wall {row['ratio']:.3f} [{row['ratio_q1']:.3f}, "
        f"{row['ratio_q3']:.3f}], CPU {row['cpu_ratio']:.3f} [{row['cpu_ratio_q1']:.3f}, "
        f"{row['cpu_ratio_q3']:.3f}] (median [IQR] over rounds); load {row['load_1min']:.1f} "
        f"(1-minute average), {row['runnable']:.0f} other tasks runnable (median).\n"
    )
    (args.out / "ar1.md").write_text(text, encoding="utf-8")
    print(text)
    return 0 if np.isfinite(row["ratio"]) else 1


if __name__ == "__main__":
    sys.exit(main())
