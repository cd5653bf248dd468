"""Benchmark: applying a prepared SKF operator against MNE's sLORETA with its own.

``python -m validation.operator_bench [--out DIR] [--repeats N]``
``[--size N_COLUMNS,N_CHANNELS,N_TIMES] [--blas-threads N] [--profile]``

At the paper's scale by default (9501 lead-field columns: 3167 positions with free
orientation on a sphere-model volume grid, BioSemi 64, 1000 samples), on one evoked (a
dipole plus white noise, seeded, with the average-reference projector) and one noise
covariance:

- ``mne-sloreta``: ``mne.minimum_norm.apply_inverse(evoked, inverse, 1/9, "sLORETA",
  prepared=True)`` on an operator made (``make_inverse_operator``, ``loose=1``, no depth
  weighting) and prepared (``prepare_inverse_operator``) beforehand: MNE's fastest route;
- ``skf``, ``skf-rts-standardized``, ``skf-rts-state``: ``skf_ref.apply_skf(evoked,
  operator)`` on an operator made by ``skf_ref.make_skf_operator`` beforehand, exponent 0.5
  without smoothing (the package's default) and with each smoother. The operator keeps
  the covariance recursion of the evoked's length, so each timed run is what every data
  set after the first costs: selecting and whitening the data, the filter, the outputs and
  the source estimate.

The runs are interleaved (one of each path per round, the order rotating) so that every
path sees the same load, and each round gives one ratio to MNE's time: the table reports
medians and interquartile ranges over the rounds, of wall time, of process CPU time (both
cores' work) and of the ratios. Every row records the BLAS threads (threadpoolctl) and the
load average before and after. ``--profile`` adds where an SKF application spends its
time: each stage timed on its own, and cProfile's largest cumulative entries. Results go
to ``DIR/operator.md`` and ``DIR/operator.csv`` (``operator-blasN.*`` with
``--blas-threads N``).
"""

import argparse
import cProfile
import io
import os
import pstats
import sys
import time
from contextlib import nullcontext
from pathlib import Path

import numpy as np
import pandas as pd

from skf_ref._utils.atomic_files import atomic_path
from skf_ref._utils.provenance import blas_threads, machine

SIZE = (9501, 64, 1000)
PATHS = ("mne-sloreta", "skf", "skf-rts-standardized", "skf-rts-state")
MONTAGES = {32: "biosemi32", 64: "biosemi64", 128: "biosemi128"}
#: The issue's targets: an SKF application's time over MNE's, at most.
TARGETS = {"skf": 1.0, "skf-rts-standardized": 1.5, "skf-rts-state": 1.5}


def make_inputs(n_columns, n_channels, n_times, seed=0):
    """A sphere-model forward, an evoked and a noise covariance at one size.

    Parameters
    ----------
    n_columns : int
        Lead-field columns, three per position.
    n_channels : {32, 64, 128}
    n_times : int
    seed : int

    Returns
    -------
    evoked : mne.Evoked
        A dipole with a 10 Hz-like oscillation plus white noise (peak SNR 20 dB), with the
        average-reference projector.
    forward : mne.Forward
    noise_cov : mne.Covariance
        The white noise's.
    """
    import mne

    from skf_ref.study._scenario import make_head_model

    head = make_head_model(n_positions=n_columns // 3, montage=MONTAGES[n_channels])
    rng = np.random.default_rng(seed)
    L = head.fwd["sol"]["data"]
    column = int(rng.integers(L.shape[1]))
    clean = np.outer(L[:, column], 10e-9 * np.sin(2 * np.pi * np.arange(n_times) / 40))
    noise_std = 0.1 * np.max(np.abs(clean))
    data = clean + noise_std * rng.standard_normal(clean.shape)
    evoked = mne.EvokedArray(data, head.info.copy(), tmin=0.0, verbose=False)
    if not evoked.info["projs"]:  # MNE's inverse needs the average-reference projector
        evoked.set_eeg_reference("average", projection=True, verbose=False)
    names = evoked.ch_names
    cov = mne.Covariance(noise_std**2 * np.eye(len(names)), names, [], [], 1000, verbose=False)
    return evoked, head.fwd, cov


def make_runners(evoked, forward, noise_cov):
    """Each path as a call with no arguments, its operator made (and timed) beforehand.

    Returns
    -------
    runners : dict
        ``{path: callable}``.
    made : dict
        Seconds each operator took to make (and, for MNE's, to prepare).
    """
    import mne
    from mne.minimum_norm import apply_inverse, make_inverse_operator, prepare_inverse_operator

    import skf_ref

    made = {}
    start = time.perf_counter()
    inverse = make_inverse_operator(
        evoked.info, forward, noise_cov, loose=1.0, depth=None, verbose=False
    )
    inverse = prepare_inverse_operator(inverse, evoked.nave, 1 / 9, "sLORETA", verbose=False)
    made["mne-sloreta"] = time.perf_counter() - start
    start = time.perf_counter()
    operator = skf_ref.make_skf_operator(evoked.info, forward, noise_cov, verbose=False)
    skf_ref.apply_skf(evoked, operator, verbose=False)  # the recursion of this length, kept
    made["skf"] = time.perf_counter() - start

    def mne_run():
        return apply_inverse(evoked, inverse, 1 / 9, "sLORETA", prepared=True, verbose=False)

    def skf_run(smoother):
        def call():
            return skf_ref.apply_skf(evoked, operator, smoother=smoother, verbose=False)

        call.operator = operator
        return call

    mne.set_log_level("WARNING")
    runners = {
        "mne-sloreta": mne_run,
        "skf": skf_run(None),
        "skf-rts-standardized": skf_run("rts-standardized"),
        "skf-rts-state": skf_run("rts-state"),
    }
    return runners, made


def measure(runners, repeats):
    """Interleaved rounds: wall and CPU seconds of every path in each round.

    Returns
    -------
    pandas.DataFrame
        One row per round and path: ``round``, ``path``, ``seconds``, ``cpu_seconds``.
    """
    paths = list(runners)
    rows = []
    for round_ in range(repeats):
        order = paths[round_ % len(paths) :] + paths[: round_ % len(paths)]
        for path in order:
            cpu, wall = time.process_time(), time.perf_counter()
            runners[path]()
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            rows.append(dict(round=round_, path=path, seconds=wall, cpu_seconds=cpu))
    return pd.DataFrame(rows)


def summarize(
    rounds, size, made, load_before, load_after, blas_limit=None, targets=None, reference=None
):
    """Medians and IQRs per path, and of each round's ratio to MNE's time.

    Parameters
    ----------
    rounds : pandas.DataFrame
        :func:`measure`'s.
    size : dict
        What was measured (``n_columns``, ``n_channels``, ``n_times``, ...): a column each.
    made : dict
        Seconds each operator took to make; the SKF paths share ``made["skf"]``.
    load_before, load_after : tuple of float
        ``os.getloadavg()``.
    blas_limit : int, optional
    targets : dict, optional
        Each path's target ratio (default :data:`TARGETS`).
    reference : str, optional
        The path the ratios divide by (default ``"mne-sloreta"``).

    Returns
    -------
    pandas.DataFrame
        One row per path.
    """
    targets = TARGETS if targets is None else targets
    reference = "mne-sloreta" if reference is None else reference
    mne_time = rounds[rounds.path == reference].set_index("round")["seconds"]
    blas = blas_threads()
    described = "; ".join(f"{b['library']} {b['version']} ({b['threads']})" for b in blas)
    rows = []
    for path, group in rounds.groupby("path", sort=False):
        ratio = group.set_index("round")["seconds"] / mne_time
        quartiles = {
            name: np.percentile(values, [25, 50, 75])
            for name, values in (
                ("seconds", group.seconds),
                ("cpu_seconds", group.cpu_seconds),
                ("ratio", ratio),
            )
        }
        rows.append(
            dict(
                **size,
                path=path,
                rounds=len(group),
                **{f"{k}_median": q[1] for k, q in quartiles.items()},
                **{f"{k}_iqr": q[2] - q[0] for k, q in quartiles.items()},
                target=targets.get(path, np.nan),
                made_seconds=made.get(path, made["skf"] if path.startswith("skf") else np.nan),
                blas=described or "none",
                blas_threads=max((b["threads"] for b in blas), default=1),
                blas_limit="none" if blas_limit is None else blas_limit,
                load_before=" ".join(f"{x:.2f}" for x in load_before),
                load_after=" ".join(f"{x:.2f}" for x in load_after),
            )
        )
    return pd.DataFrame(rows)


def profile(run, top=15):
    """Where one call of ``run`` spends its time: cProfile's largest cumulative entries.

    (cProfile sees this thread only: work the spectral path hands to worker threads shows
    as waiting; :func:`stages` times the stages themselves.)
    """
    profiler = cProfile.Profile()
    profiler.runcall(run)
    text = io.StringIO()
    stats = pstats.Stats(profiler, stream=text).strip_dirs().sort_stats("cumulative")
    stats.print_stats(top)
    return text.getvalue()


def stages(evoked, operator, smoother, repeats):
    """Median wall seconds of each stage of ``apply_skf(evoked, operator)``.

    ``select``: the operator's channels of the data, checked (projectors, reference);
    ``filter``: whitening and the spectral model's recursions on the data (``r x T``);
    ``z``: the standardized estimate, ``n x T`` (the spectral path's rows, smoother
    included); ``amplitude``: the norm of each position's three components; ``stc``: the
    source estimate around it.
    """
    import skf_ref

    times = {name: [] for name in ("select", "filter", "z", "amplitude", "stc")}
    tmin, tstep = evoked.times[0], 1 / evoked.info["sfreq"]
    for _ in range(repeats):
        marks = [time.perf_counter()]
        data = operator.select(evoked.info, evoked.data, "evoked")
        marks.append(time.perf_counter())
        rec = operator.reconstruct(data, smoother=smoother)
        marks.append(time.perf_counter())
        rec.z  # noqa: B018 (computed on first access)
        marks.append(time.perf_counter())
        rec.amplitude(3)
        marks.append(time.perf_counter())
        skf_ref.io.make_stc(rec, operator.forward["src"], tmin, tstep)
        marks.append(time.perf_counter())
        for name, start, stop in zip(times, marks[:-1], marks[1:], strict=True):
            times[name].append(stop - start)
    return {name: float(np.median(values)) for name, values in times.items()}


def report_table(table, what, digits=4):
    """The markdown's first lines: machine, BLAS and load, ``what`` was measured, the table."""
    info = machine()
    versions = ", ".join(f"{name} {version}" for name, version in info["versions"].items())
    first = table.iloc[0]
    lines = [
        f"Machine: {info['platform']}, {info['cpus']} CPUs, Python {info['python']}; {versions}.",
        f"BLAS (threadpoolctl): {first.blas}; limit {first.blas_limit}. Load average (1, 5, "
        f"15 min) before: {first.load_before}; after: {first.load_after}.",
        f"{what}; {first.rounds} interleaved rounds. Medians (IQR) over the rounds; the ratio "
        "is each round's time over MNE's in the same round.",
        "",
        "| path | wall (s) | CPU (s) | ratio to MNE | target | operator made (s) |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for row in table.itertuples():
        target = "" if np.isnan(row.target) else f"<= {row.target:g}"
        lines.append(
            f"| {row.path} | {row.seconds_median:.{digits}f} ({row.seconds_iqr:.{digits}f}) "
            f"| {row.cpu_seconds_median:.{digits}f} ({row.cpu_seconds_iqr:.{digits}f}) "
            f"| {row.ratio_median:.2f} ({row.ratio_iqr:.2f}) | {target} "
            f"| {row.made_seconds:.3f} |"
        )
    return lines


def report(table, profiles=None, stage_times=None):
    """The markdown file: machine, BLAS, load, the table, the targets and any profile."""
    first = table.iloc[0]
    what = f"Size: {first.n_columns} columns, {first.n_channels} channels, {first.n_times} samples"
    lines = report_table(table, what)
    if stage_times:
        names = list(next(iter(stage_times.values())))
        lines += [
            "",
            "Where an SKF application's time goes (median wall seconds of each stage; "
            "`stc` includes what `amplitude` computed again):",
            "",
            "| path | " + " | ".join(names) + " |",
            "|---|" + "---:|" * len(names),
        ]
        for path, times in stage_times.items():
            lines.append(f"| {path} | " + " | ".join(f"{times[n]:.4f}" for n in names) + " |")
    for path, text in (profiles or {}).items():
        lines += ["", f"Profile of one `{path}` application (cumulative seconds):", "", "```"]
        lines += [text.rstrip(), "```"]
    return "\n".join(lines) + "\n"


def blas_limited(blas_limit=None):
    """A context limiting the BLAS threads to ``blas_limit`` (threadpoolctl), or not at all."""
    if blas_limit is None:
        return nullcontext()
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=blas_limit, user_api="blas")


def timed_rounds(runners, repeats):
    """Every path run once (first-call imports and allocations), then :func:`measure`.

    Returns
    -------
    rounds : pandas.DataFrame
    load_before, load_after : tuple of float
        ``os.getloadavg()`` around the rounds.
    """
    for call in runners.values():
        call()
    load_before = os.getloadavg()
    rounds = measure(runners, repeats)
    return rounds, load_before, os.getloadavg()


def write_results(folder, stem, table, text):
    """``FOLDER/STEM.csv`` and ``FOLDER/STEM.md``, each whole or not at all; print the text."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with atomic_path(folder / f"{stem}.csv") as tmp:
        table.to_csv(tmp, index=False)
    with atomic_path(folder / f"{stem}.md") as tmp:
        tmp.write_text(text)
    print(text)


def run(size=SIZE, repeats=15, blas_limit=None, with_profile=False):
    """The whole benchmark at one size.

    Returns
    -------
    table : pandas.DataFrame
        :func:`summarize`'s.
    profiles : dict
        ``{path: text}`` with ``with_profile``.
    stage_times : dict
        ``{path: {stage: seconds}}`` (:func:`stages`) with ``with_profile``.
    """
    evoked, forward, noise_cov = make_inputs(*size)
    with blas_limited(blas_limit):
        runners, made = make_runners(evoked, forward, noise_cov)
        rounds, load_before, load_after = timed_rounds(runners, repeats)
        fields = dict(n_columns=size[0], n_channels=size[1], n_times=size[2])
        table = summarize(rounds, fields, made, load_before, load_after, blas_limit)
        profiles, stage_times = {}, {}
        if with_profile:
            profiles = {path: profile(runners[path]) for path in ("mne-sloreta", "skf")}
            operator = runners["skf"].operator
            stage_times = {
                path: stages(evoked, operator, smoother, repeats)
                for path, smoother in (
                    ("skf", None),
                    ("skf-rts-standardized", "rts-standardized"),
                    ("skf-rts-state", "rts-state"),
                )
            }
    return table, profiles, stage_times


def main(argv=None):
    """Command line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(prog="python -m validation.operator_bench")
    parser.add_argument("--out", type=Path, default=Path("validation/bench"))
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--size", default=",".join(map(str, SIZE)))
    parser.add_argument("--blas-threads", type=int, metavar="N")
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.split(","))
    table, profiles, stage_times = run(size, args.repeats, args.blas_threads, args.profile)
    stem = "operator" if args.blas_threads is None else f"operator-blas{args.blas_threads}"
    write_results(args.out, stem, table, report(table, profiles, stage_times))
    return 0


if __name__ == "__main__":
    sys.exit(main())
