"""Benchmark: wall time, CPU time and peak memory of every SKF path and of MNE's sLORETA.

``python -m validation.bench [--out DIR] [--repeats N] [--size N_COLUMNS,N_CHANNELS,N_TIMES]``
``[--paths P1,P2] [--blas-threads N] [--competitor] [--floor] [--long] [--no-table]``

Each row runs one path on one size: the SKF with ``"rts-standardized"`` smoothing
(``skf_ref.reconstruct`` with ``path`` = filterpy, dense or spectral, asking for ``z``;
its time includes every preparation, the SVD among them), ``apply_skf`` (the MNE route at
its defaults, exponent 0.5 without smoothing: channel picking, MNE's whitener, the spectral
path and the source estimate, from an evoked, a forward and a covariance), ``tune``
(PM-SNR and EP-SNR chosen by marginal likelihood, :func:`skf_ref.tune`: a 13 x 13 grid
over -20..40 dB and a bounded refinement, SVD included), or MNE-Python's sLORETA:
``mne-sloreta`` is ``mne.minimum_norm.apply_inverse`` on an inverse operator made
beforehand, ``mne-sloreta+make`` also times ``make_inverse_operator`` (MNE's SVD),
on the same sphere-model forward (``skf_ref.study._scenario.make_head_model``) and the same data
(a dipole at one grid position with a 10 Hz-like oscillation plus white noise, seeded).

Time is the median wall time of up to ``--repeats`` runs (fewer when one run is slow; the
count is in the table), with its interquartile range, the median CPU time of the process
(every thread) and the machine's load before each run (1-minute average and tasks runnable
then, :mod:`validation.timing`). ``--competitor`` runs everything beside a single-threaded
busy loop in another process. Peak memory is the peak of memory traced by ``tracemalloc``
(numpy arrays and Python objects) during one extra run, above what was allocated before it:
the memory the call itself needs. Paths the memory guard refuses are reported as not
runnable, with the memory they would need. Results go to ``DIR/results.md`` and
``DIR/results.csv``; ``--floor`` adds the smoothed z against its floor, quiet and beside a
competitor (:mod:`validation.floor`, ``DIR/floor.csv``), ``--long`` the long recording
(:mod:`validation.long_recording`), each as a section of ``results.md`` that later runs
keep; ``--no-table`` runs only those.

BLAS threads. numpy's and scipy's BLAS (OpenBLAS here) run on as many threads as they
choose, so a time means little without them: every row records the BLAS libraries and
their thread counts as they were while it was timed (threadpoolctl, through
:func:`skf_ref._utils.provenance.blas_threads`), and the markdown header names the machine, the
libraries and their threads. ``--blas-threads N`` runs the whole benchmark under
``threadpoolctl.threadpool_limits(N, user_api="blas")``; the limit is recorded beside every
timing.
"""

import argparse
import sys
from collections.abc import Callable, Sequence
from contextlib import nullcontext
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from skf_ref._utils.atomic_files import atomic_path
from skf_ref._utils.provenance import machine
from validation import floor, timing
from validation.problem import blas_columns, make_problem, skf_runner

SIZES = ((600, 64, 41), (1500, 64, 41), (9000, 64, 41), (9000, 64, 1000), (150000, 128, 1000))
PATHS = ("filterpy", "dense", "spectral", "tune", "apply_skf", "mne-sloreta", "mne-sloreta+make")
#: The heading of the table's section of results.md (what the table run replaces).
TABLE_HEADING = "## Every path"


def _mne_inputs(problem):
    """The problem as MNE objects: an evoked with the average-reference projector, a cov."""
    import mne

    head, Y = problem["head"], problem["Y"]
    info = head.info.copy()
    evoked = mne.EvokedArray(Y, info, tmin=0.0, verbose=False)
    if not evoked.info["projs"]:  # MNE's EEG inverse needs the average-reference projector
        evoked.set_eeg_reference("average", projection=True, verbose=False)
    cov = mne.Covariance(
        problem["noise_std"] ** 2 * np.eye(len(info.ch_names)),
        info.ch_names,
        bads=[],
        projs=[],
        nfree=1000,
        verbose=False,
    )
    return evoked, cov


def _tune_runner(problem):
    from skf_ref import tune

    return lambda: tune(problem["head"].leadfield, problem["Y"], noise_std=problem["noise_std"])


def _apply_skf_runner(problem):
    from skf_ref import apply_skf

    evoked, cov = _mne_inputs(problem)
    return lambda: apply_skf(evoked, problem["head"].fwd, cov)


def _mne_runner(problem, with_make):
    from mne.minimum_norm import apply_inverse, make_inverse_operator

    head = problem["head"]
    evoked, cov = _mne_inputs(problem)

    def make():
        return make_inverse_operator(
            evoked.info, head.fwd, cov, loose=1.0, depth=None, verbose=False
        )

    prepared = None if with_make else make()

    def run():
        inverse = make() if with_make else prepared
        return apply_inverse(evoked, inverse, lambda2=1 / 9, method="sLORETA", verbose=False)

    return run


def _runner(problem, path):
    if path.startswith("mne-sloreta"):
        return _mne_runner(problem, with_make=path.endswith("+make"))
    if path == "apply_skf":
        return _apply_skf_runner(problem)
    if path == "tune":
        return _tune_runner(problem)
    return skf_runner(problem, path)


def _not_runnable(path, n_columns, n_times):
    """The memory the path needs if the guard refuses it, else None."""
    from skf_ref._utils import memory

    if path not in ("filterpy", "dense"):
        return None
    needed = memory.covariance_memory(n_columns, n_times, path, "rts-standardized")
    return needed if needed > memory.available_memory() / 2 else None


def _limited(blas_limit):
    """``threadpool_limits`` to ``blas_limit`` BLAS threads, or no limit for None."""
    if blas_limit is None:
        return nullcontext()
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=blas_limit, user_api="blas")


def benchmark(
    sizes: Sequence[tuple[int, int, int]] = SIZES,
    paths: Sequence[str] = PATHS,
    repeats: int = 5,
    progress: Callable[[str], object] = print,
    blas_limit: int | None = None,
    busy: bool = False,
) -> pd.DataFrame:
    """Run every path at every size.

    Parameters
    ----------
    sizes : sequence of (n_columns, n_channels, n_times)
        The sizes to run, each with :func:`~validation.problem.make_problem`.
    paths : sequence of str
        Of :data:`PATHS`.
    repeats : int
        Runs timed per row at most (:func:`validation.timing.measure`).
    progress : callable
        Called with one line per finished row.
    blas_limit : int, optional
        Run everything under ``threadpool_limits(blas_limit, user_api="blas")``; default:
        the libraries' own thread counts.
    busy : bool
        Run everything beside a competitor (:func:`validation.timing.competitor`).

    Returns
    -------
    pandas.DataFrame
        One row per size and path: ``seconds`` (median wall time), ``q1_seconds``,
        ``q3_seconds``, ``cpu_seconds``, ``runs``, ``load_1min``, ``runnable``,
        ``peak_mib`` (NaN when not runnable), ``status``, ``note``, ``competitor`` and the
        BLAS it ran with (:func:`blas_columns`).
    """
    rows = []
    with _limited(blas_limit), timing.competitor(busy):
        for n_columns, n_channels, n_times in sizes:
            problem = make_problem(n_columns, n_channels, n_times)
            for path in paths:
                row: dict[str, Any] = dict(
                    n_columns=n_columns, n_channels=n_channels, n_times=n_times
                )
                row["path"] = path
                needed = _not_runnable(path, n_columns, n_times)
                if needed is not None:
                    row.update(seconds=np.nan, runs=0, peak_mib=np.nan, status="not runnable")
                    row["note"] = f"needs {needed / 2**30:.1f} GiB for its covariances"
                else:
                    timed = timing.measure(_runner(problem, path), repeats)
                    row.update(timed, peak_mib=timed.pop("peak_bytes") / 2**20, status="ok")
                    row.pop("peak_bytes", None)
                    row["note"] = ""
                row["competitor"] = busy
                row.update(blas_columns(blas_limit))
                rows.append(row)
                progress(_format_row(row))
    return pd.DataFrame(rows)


def _format_row(row):
    if row["status"] != "ok":
        return f"{row['n_columns']:>7} {row['n_times']:>5} {row['path']:<12} {row['note']}"
    return (
        f"{row['n_columns']:>7} {row['n_times']:>5} {row['path']:<12} "
        f"{row['seconds']:10.4f} s ({row['cpu_seconds']:.3f} CPU-s) {row['peak_mib']:9.1f} MiB "
        f"({row['runs']} runs, {row['blas_threads']} BLAS threads, load "
        f"{row['load_1min']:.2f}/{row['runnable']:.0f})"
    )


def targets(table: pd.DataFrame) -> list[str]:
    """The issue's four performance targets, read off a results table.

    Parameters
    ----------
    table : pandas.DataFrame
        As returned by :func:`benchmark`.

    Returns
    -------
    list of str
        One markdown bullet per target whose rows were run.
    """
    seconds = {
        (r.n_columns, r.n_channels, r.n_times, r.path): r.seconds for r in table.itertuples()
    }
    peak = {(r.n_columns, r.n_channels, r.n_times, r.path): r.peak_mib for r in table.itertuples()}
    lines = []
    key = (1500, 64, 41)
    if (*key, "filterpy") in seconds and (*key, "spectral") in seconds:
        ratio = seconds[key + ("filterpy",)] / seconds[key + ("spectral",)]
        lines.append(f"- spectral vs filterpy at 1500 columns: {ratio:.0f}x faster (target 1000x)")
    key = (9000, 64, 41)
    if (*key, "spectral") in seconds:
        lines.append(
            f"- paper scale, smoothed: {seconds[key + ('spectral',)]:.3f} s (target < 1 s)"
        )
    key = (9000, 64, 1000)
    if (*key, "spectral") in seconds and (*key, "mne-sloreta") in seconds:
        ratio = seconds[key + ("spectral",)] / seconds[key + ("mne-sloreta",)]
        lines.append(f"- (9000, 64, 1000): {ratio:.1f}x MNE's sLORETA time (target <= 2x)")
    if (*key, "apply_skf") in seconds and (*key, "mne-sloreta+make") in seconds:
        ratio = seconds[key + ("apply_skf",)] / seconds[key + ("mne-sloreta+make",)]
        lines.append(
            f"- (9000, 64, 1000): apply_skf {ratio:.2f}x MNE's make_inverse_operator + "
            "apply_inverse sLORETA (target <= 2x)"
        )
    key = (150000, 128, 1000)
    if (*key, "spectral") in seconds:
        lines.append(
            f"- 150000 columns x 1000 steps, smoothed z: {seconds[key + ('spectral',)]:.1f} s, "
            f"{peak[key + ('spectral',)] / 1024:.2f} GiB traced peak (target: within 1.15x its "
            "floor quiet and 1.5x beside a competitor, the section below)"
        )
    for key, target in (((9000, 64, 41), 0.5), ((150000, 128, 1000), 5.0)):
        if (*key, "tune") in seconds:
            lines.append(
                f"- tuning PM-SNR and EP-SNR at {key}: {seconds[key + ('tune',)]:.2f} s "
                f"(target < {target:g} s)"
            )
    return lines


def to_markdown(table: pd.DataFrame) -> str:
    """The results as a markdown table.

    Parameters
    ----------
    table : pandas.DataFrame
        As returned by :func:`benchmark`.

    Returns
    -------
    str
    """
    lines = [
        "| n_columns | n_channels | n_times | path | time (s) [IQR] | CPU (s) | runs "
        "| load | BLAS threads | peak memory (MiB) | note |",
        "|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for _, row in table.iterrows():
        ok = row["status"] == "ok"
        if ok:
            seconds = f"{row['seconds']:.4g} [{row['q1_seconds']:.4g}, {row['q3_seconds']:.4g}]"
            cpu, peak = f"{row['cpu_seconds']:.4g}", f"{row['peak_mib']:.1f}"
            load = f"{row['load_1min']:.2f} / {row['runnable']:.0f}"
        else:
            seconds, cpu, peak, load = "not runnable", "-", "-", "-"
        lines.append(
            f"| {row['n_columns']} | {row['n_channels']} | {row['n_times']} | {row['path']} "
            f"| {seconds} | {cpu} | {row['runs']} | {load} | {row['blas_threads']} | {peak} "
            f"| {row['note']} |"
        )
    return "\n".join(lines) + "\n"


def report(table: pd.DataFrame, blas_limit: int | None = None) -> str:
    """The table's section of results.md: machine, BLAS and its threads, table, targets.

    Parameters
    ----------
    table : pandas.DataFrame
        As returned by :func:`benchmark`.
    blas_limit : int, optional
        The ``--blas-threads`` limit the table was measured under.
    """
    busy = bool(len(table)) and bool(table["competitor"].any())
    return "".join(
        [
            TABLE_HEADING,
            "\n\n",
            "\n".join(header_lines(table, blas_limit)),
            " Beside a competitor (a single-threaded busy loop)." if busy else "",
            "\n\n",
            to_markdown(table),
            "\nTargets:\n\n",
            "\n".join(targets(table)),
            "\n",
        ]
    )


def header_lines(table: pd.DataFrame | None = None, blas_limit: int | None = None) -> list[str]:
    """The report's header: machine, package versions, BLAS libraries and their threads.

    The BLAS line is read from the table's rows (what each timing ran with), so it cannot
    disagree with them.
    """
    info = machine()
    versions = ", ".join(f"{name} {version}" for name, version in info["versions"].items())
    if table is not None and len(table):
        blas = sorted(set(table["blas"]))
    else:
        blas = [blas_columns(blas_limit)["blas"]]
    limit = (
        f"limited to {blas_limit} by `--blas-threads {blas_limit}` (threadpoolctl)"
        if blas_limit is not None
        else "not limited: each library's default (`--blas-threads N` to limit)"
    )
    return [
        f"Machine: {info['platform']}, {info['cpus']} CPUs, Python {info['python']}; {versions}.",
        f"BLAS (threadpoolctl, while timing): {' | '.join(blas)}; threads {limit}.",
        "Median wall time [interquartile range], median CPU time of the process (every "
        "thread), load before each run (1-minute average / tasks runnable besides the "
        "benchmark); peak traced memory of one run.",
    ]


def main(argv: Sequence[str] | None = None) -> int:
    """Command line entry point; returns the exit status."""
    try:
        args = parse_args(argv)
    except ValueError as err:
        print(f"bench: {err}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    results = args.out / "results.md"
    text = results.read_text() if results.exists() else "# Benchmarks (docs/performance.md)\n"
    progress = lambda line: print(line, flush=True)  # noqa: E731
    if args.table:
        table = benchmark(
            args.sizes,
            args.paths,
            args.repeats,
            progress=progress,
            blas_limit=args.blas_threads,
            busy=args.competitor,
        )
        with atomic_path(args.out / "results.csv") as tmp:
            table.to_csv(tmp, index=False)
        text = timing.replace_section(text, TABLE_HEADING, report(table, args.blas_threads))
    with _limited(args.blas_threads):
        if args.floor:
            text = timing.replace_section(text, floor.HEADING, _floor(args, progress))
        if args.long:
            from validation import long_recording

            print("long recording ...", flush=True)
            row = long_recording.measure(blas_threads=args.blas_threads)
            text = long_recording.save(row, args.out, text)
    with atomic_path(results) as tmp:
        tmp.write_text(text)
    print(f"wrote {results}")
    return 0


def _floor(args, progress):
    """Run the floor comparison quiet and beside a competitor; its section of results.md."""
    problem = make_problem(*floor.SIZE)
    rows = []
    for busy in (False, True):
        progress(
            f"smoothed z against its floor at {floor.SIZE}, {'competitor' if busy else 'quiet'}"
        )
        rows.append(floor.compare(problem, args.repeats, busy=busy, progress=progress))
    with atomic_path(args.out / "floor.csv") as tmp:
        pd.DataFrame(rows).to_csv(tmp, index=False)
    return floor.to_markdown(rows, header_lines(blas_limit=args.blas_threads)[:2])


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, not the usage: main prints it and returns 2
        raise ValueError(message)


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line's options, checked.

    Parameters
    ----------
    argv : list of str, optional
        Arguments after the program name; default ``sys.argv[1:]``.

    Returns
    -------
    argparse.Namespace
        ``out`` (Path), ``repeats`` (int), ``sizes`` (list of 3-tuples), ``paths`` (list
        of str), ``blas_threads`` (int, or None for no limit), ``competitor``, ``floor``,
        ``long``, ``table`` (bool).

    Raises
    ------
    ValueError
        With a one-line message, for any bad argument.
    """
    parser = _Parser(prog="python -m validation.bench", description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("validation/bench"))
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument(
        "--size",
        action="append",
        metavar="N_COLUMNS,N_CHANNELS,N_TIMES",
        help="a size to run (repeatable); default: the five sizes of the issue",
    )
    parser.add_argument("--paths", default=",".join(PATHS))
    parser.add_argument(
        "--blas-threads",
        type=int,
        metavar="N",
        help="run the whole benchmark under threadpoolctl.threadpool_limits(N) for BLAS "
        "(default: the libraries' own thread counts); recorded beside every timing",
    )
    parser.add_argument(
        "--competitor",
        action="store_true",
        help="run the table beside a single-threaded busy loop in another process",
    )
    parser.add_argument(
        "--floor",
        action="store_true",
        help="also the smoothed z at 150000 x 128 x 1000 against its floor, quiet and beside "
        "a competitor (validation/floor.py)",
    )
    parser.add_argument(
        "--long",
        action="store_true",
        help="also the long-recording benchmark (validation/long_recording.py; 16 GB on disk)",
    )
    parser.add_argument(
        "--no-table", dest="table", action="store_false", help="only --floor and --long"
    )
    args = parser.parse_args(argv)
    try:
        sizes = [tuple(int(v) for v in s.split(",")) for s in args.size] if args.size else SIZES
        if any(len(s) != 3 for s in sizes) or args.repeats < 1:
            raise ValueError
    except ValueError:
        raise ValueError("--size takes N_COLUMNS,N_CHANNELS,N_TIMES; --repeats >= 1") from None
    args.sizes = [tuple(s) for s in sizes]
    args.paths = args.paths.split(",")
    unknown = set(args.paths) - set(PATHS)
    if unknown:
        raise ValueError(f"unknown --paths {sorted(unknown)}; choose from {PATHS}")
    if args.blas_threads is not None and args.blas_threads < 1:
        raise ValueError(f"--blas-threads must be at least 1, got {args.blas_threads}")
    return args


if __name__ == "__main__":
    sys.exit(main())
