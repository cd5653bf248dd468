"""The smoothed z of the spectral path against its floor, on a quiet machine and a busy one.

``python -m validation.bench --floor [--size N_COLUMNS,N_CHANNELS,N_TIMES] [--repeats N]``
writes the section below to ``validation/bench/results.md`` (and ``floor.csv``).

The floor of one smoothed ``z`` (``"rts-standardized"``, exponent 1.25) is the work no way
of computing it can skip: the thin SVD of the whitened lead field (the package's own,
``skf_ref.method._paths.singular_basis.thin_svd``), four (n, r) x (r, T) products (the
raw weights ``(V o V) omega``, the whitened means ``V u``, the projection ``V^T z`` and the
correction ``V delta``), each one BLAS call on every BLAS thread into one new (T, n)
array, as any way of computing ``z`` returns a new array, and one elementwise pass over it
(``w ** -alpha`` in its fastest form,
``skf_ref.method._standardization.standardization_weights``, on one core). The path is
timed from the lead field and the data: ``reconstruct(...).z``, everything included.

A new array costs more than its arithmetic on this machine's virtual machine: memory freed
more than about 1.5 s earlier goes back to the host (the balloon's free page reporting),
and touching it again costs about 2 s per 1.2 GB, against 0.13 s when it is reused at once
(docs/performance.md). Both the floor and the path pay it for their outputs.

Floor and path runs alternate, so that both see the same load; the ratio is the median of
the per-pair ratios of wall times, with its interquartile range, and the same of CPU times.
Each comparison runs quiet, then beside a competitor: a single-threaded busy loop in
another process (:func:`validation.timing.competitor`). The 1-minute load average and the
tasks runnable before each run are recorded beside every number.
"""

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from validation import timing
from validation.problem import blas_columns, skf_runner

__all__ = ["HEADING", "SIZE", "TARGETS", "compare", "floor_runner", "to_markdown"]

#: (n_columns, n_channels, n_times)
SIZE = (150_000, 128, 1000)
#: The heading of its section of validation/bench/results.md.
HEADING = "## Smoothed z against its floor"
#: The largest ratio of path to floor each condition should give (the issue's targets).
TARGETS = {"quiet": 1.15, "competitor": 1.5}
EXPONENT = 1.25


def floor_runner(
    problem: dict[str, Any], exponent: float = EXPONENT
) -> Callable[[], dict[str, float]]:
    """A callable that does the floor's work once and returns its parts' wall times.

    Parameters
    ----------
    problem : dict
        As :func:`validation.problem.make_problem` returns.
    exponent : float
        The standardization exponent of the elementwise pass.

    Returns
    -------
    callable
        Returns ``{"svd": s, "products": s, "elementwise": s}``.
    """
    from skf_ref.method._paths.singular_basis import thin_svd
    from skf_ref.method._standardization import standardization_weights

    Lw = problem["head"].leadfield / problem["noise_std"]
    _, _, V = thin_svd(Lw)
    T = problem["Y"].shape[1]
    rng = np.random.default_rng(0)
    coefficients = rng.standard_normal((T, V.shape[1]))
    weights = rng.uniform(0.1, 1.0, (T, V.shape[1])) @ V.T**2  # positive

    def run() -> dict[str, float]:
        start = time.perf_counter()
        thin_svd(Lw)
        svd = time.perf_counter()
        out = np.empty((T, V.shape[0]))  # a new array, as every output is
        for _ in range(4):
            np.matmul(coefficients, V.T, out=out)
        products = time.perf_counter()
        standardization_weights(weights, exponent, out=out)
        end = time.perf_counter()
        return dict(svd=svd - start, products=products - svd, elementwise=end - products)

    return run


def _timed(run):
    load = timing.load()
    cpu, start = time.process_time(), time.perf_counter()
    parts = run()
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    return wall, cpu, load, parts if isinstance(parts, dict) else {}


def compare(
    problem: dict[str, Any],
    repeats: int = 7,
    busy: bool = False,
    progress: Callable[[str], object] = print,
) -> dict[str, Any]:
    """Alternate floor and path runs; their times and ratios.

    Parameters
    ----------
    problem : dict
        As :func:`validation.problem.make_problem` returns.
    repeats : int
        Pairs of runs timed (after one pair not timed, which warms both up).
    busy : bool
        Run beside a competitor (:func:`validation.timing.competitor`).
    progress : callable
        Called with one line per pair timed.

    Returns
    -------
    dict
        One row: ``condition``, the floor's and the path's median wall and CPU time, the
        floor's parts, the median ratios (wall and CPU) with their quartiles, the load.
    """
    floor, path = floor_runner(problem), skf_runner(problem, "spectral")
    pairs = []
    with timing.competitor(busy):
        floor(), path()  # not timed: allocations and libraries warmed up
        for i in range(repeats):
            pairs.append((_timed(floor), _timed(path)))
            (fw, fc, _, _), (pw, pc, load, _) = pairs[-1]
            progress(
                f"  pair {i + 1}: floor {fw:.3f} s ({fc:.2f} CPU-s), path {pw:.3f} s "
                f"({pc:.2f} CPU-s), ratio {pw / fw:.3f}, load {load[0]:.2f}/{load[1]:.0f}"
            )
    n = problem["head"].leadfield.shape[1]
    m, T = problem["Y"].shape
    condition = "competitor" if busy else "quiet"
    row = dict(
        n_columns=n,
        n_channels=m,
        n_times=T,
        condition=condition,
        **timing.pair_summary(pairs, "floor", "path"),
        **{
            f"floor_{name}_seconds": float(np.median([f[3][name] for f, _ in pairs]))
            for name in ("svd", "products", "elementwise")
        },
        target=TARGETS[condition],
        **blas_columns(),
    )
    return row


def to_markdown(rows: Sequence[dict[str, Any]], header: Sequence[str] = ()) -> str:
    """The comparison as a markdown section (heading included), ``header`` lines first."""
    lines = [
        HEADING,
        "",
        *([*header, ""] if header else []),
        'Smoothed z (`"rts-standardized"`, exponent 1.25) from the lead field and the data, '
        "against its floor: the SVD, four (n, r) x (r, T) products and one elementwise pass, "
        "timed in alternation (validation/floor.py). Medians over the pairs; ratios are "
        "medians of per-pair ratios [interquartile range]. Load: 1-minute average / tasks "
        "runnable besides the benchmark, before each run.",
        "",
        "| size | condition | pairs | path s (CPU-s) | floor s (CPU-s) | floor: SVD + "
        "products + elementwise s | ratio, wall | ratio, CPU | target | load | BLAS |",
        "|---|---|---:|---:|---:|---|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['n_columns']} x {r['n_channels']} x {r['n_times']} | {r['condition']} "
            f"| {r['pairs']} | {r['path_seconds']:.3f} ({r['path_cpu_seconds']:.2f}) "
            f"| {r['floor_seconds']:.3f} ({r['floor_cpu_seconds']:.2f}) "
            f"| {r['floor_svd_seconds']:.3f} + {r['floor_products_seconds']:.3f} + "
            f"{r['floor_elementwise_seconds']:.3f} "
            f"| {r['ratio']:.3f} [{r['ratio_q1']:.3f}, {r['ratio_q3']:.3f}] "
            f"| {r['cpu_ratio']:.3f} [{r['cpu_ratio_q1']:.3f}, {r['cpu_ratio_q3']:.3f}] "
            f"| <= {r['target']:g} | {r['load_1min']:.2f} / {r['runnable']:.0f} "
            f"| {r['blas']} |"
        )
    return "\n".join(lines) + "\n"
