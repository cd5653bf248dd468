"""The long-recording benchmark: a recording far larger than memory, streamed to disk.

``python -m validation.bench --long [--no-table]`` runs it (beside the usual table unless
``--no-table``). One reconstruction of 10 000 sources x 64 channels x 200 000 samples (an
hour-like recording), ``"rts-standardized"`` smoothing, exponent 1.25, its smoothed ``z``
(16 GB) written by ``Reconstruction.to_zarr``, block of rows by block, in a fresh process,
which reports its wall time, its CPU time (every thread), the step from which the
recursions are held (the steady state, skf_ref/method/_paths/recursions.py) and its peak
resident memory (``VmHWM`` of ``/proc/self/status``: on Linux ``ru_maxrss`` of a child
counts its parent's resident memory at the fork, 4.9 GiB once after the bench's largest
sizes). The machine's load is recorded before it starts. ``python -m
validation.long_recording`` runs it alone and replaces its section of
``validation/bench/results.md``. The physical limit is this machine's plain sequential write
of the same number of bytes (a file written in blocks of the same size), timed the same way:
both end with ``os.sync()``, so neither is flattered by the page cache. The targets: at
least :data:`SPEEDUP_TARGET` times faster than before the steady state was held
(:data:`BASELINE_SECONDS`), in
less than :data:`MEMORY_TARGET_GIB` of resident memory.
"""

import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from validation import timing

__all__ = [
    "BASELINE_SECONDS",
    "HEADING",
    "MEMORY_TARGET_GIB",
    "SIZE",
    "SPEEDUP_TARGET",
    "main",
    "measure",
    "save",
    "sequential_write",
    "stream",
    "to_markdown",
]

#: (n_sources, n_channels, n_times)
SIZE = (10_000, 64, 200_000)
#: The heading of its section of validation/bench/results.md.
HEADING = "## Long recording, streamed to disk"
#: The time before the steady state was held (z computed twice, every step in full), as
#: skf_ref 0.2's benchmark recorded it.
BASELINE_SECONDS = 160.8
SPEEDUP_TARGET = 3.0
MEMORY_TARGET_GIB = 1.5


def stream(n_sources, n_channels, n_times, folder, seed=0):
    """Reconstruct and write the smoothed ``z`` to ``folder/z.zarr``; in this process.

    Returns
    -------
    dict
        ``seconds`` (reconstruct + write + sync), ``peak_rss_gib``, ``bytes``.
    """
    from skf_ref import priors_from_snr, reconstruct
    from skf_ref._utils.provenance import blas_threads
    from skf_ref.io import to_zarr

    rng = np.random.default_rng(seed)
    L = rng.standard_normal((n_channels, n_sources))
    L -= L.mean(axis=0)
    sources = np.cumsum(rng.standard_normal((3, n_times)), axis=1)
    Y = L[:, :3] @ sources + rng.standard_normal((n_channels, n_times))
    theta0, q = priors_from_snr(L, 1.0, 0.0, 20.0, n_times)
    cpu, start = _cpu_seconds(), time.perf_counter()
    rec = reconstruct(
        L, Y, noise_std=1.0, theta0=theta0, q=q, exponent=1.25, smoother="rts-standardized"
    )
    to_zarr(rec, Path(folder) / "z.zarr", arrays=("z",))
    os.sync()
    seconds, cpu = time.perf_counter() - start, _cpu_seconds() - cpu
    peak = _peak_resident_bytes()
    blas = max((b["threads"] for b in blas_threads()), default=1)
    return dict(
        seconds=seconds,
        cpu_seconds=cpu,
        peak_rss_gib=peak / 2**30,
        bytes=8 * n_sources * n_times,
        blas=blas,
        steady=rec.lazy_outputs.steady,
    )


def _cpu_seconds():
    """CPU time of this process, every thread, user and system (writes to disk are system)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _peak_resident_bytes():
    """This process's peak resident memory since it started (its own, not its parent's)."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024  # kB
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # KiB on Linux


def sequential_write(nbytes, folder, block_bytes=64 * 2**20):
    """Seconds to write ``nbytes`` to one file in ``block_bytes`` pieces, then sync."""
    block = np.random.default_rng(0).standard_normal(block_bytes // 8)
    path = Path(folder) / "sequential.bin"
    start = time.perf_counter()
    with open(path, "wb") as f:
        for _ in range(nbytes // block_bytes):
            f.write(block.data)
    os.sync()
    seconds = time.perf_counter() - start
    path.unlink()
    return seconds


def measure(size=SIZE, folder=None, blas_threads=None):
    """Run :func:`stream` in a fresh process and :func:`sequential_write` of the same bytes.

    Parameters
    ----------
    size : (int, int, int)
        (n_sources, n_channels, n_times).
    folder : path-like, optional
        Where to write (default a temporary folder beside the current directory); emptied.
    blas_threads : int, optional
        BLAS threads of the process that reconstructs (``OPENBLAS_NUM_THREADS``); default
        the library's own.

    Returns
    -------
    dict
        ``n_sources``, ``n_channels``, ``n_times``, ``seconds``, ``cpu_seconds``,
        ``speedup`` (over :data:`BASELINE_SECONDS`), ``steady``, ``load_1min`` and
        ``runnable`` (before it), ``peak_rss_gib``, ``gib_written``, ``throughput_mib_s``,
        ``sequential_mib_s``, ``fraction_of_disk``, ``blas_threads`` (of the process that
        reconstructed).
    """
    folder = Path(tempfile.mkdtemp(dir=folder or ".", prefix=".skf-long-"))
    load_1min, runnable = timing.load()
    try:
        code = (
            "import json, sys; from validation.long_recording import stream; "
            f"print(json.dumps(stream(*{tuple(size)}, {str(folder)!r})))"
        )
        result = subprocess.run(
            [sys.executable, "-c", code],
            capture_output=True,
            text=True,
            check=False,
            cwd=Path(__file__).resolve().parents[1],  # the checkout: validation importable
            env=os.environ
            | ({} if blas_threads is None else {"OPENBLAS_NUM_THREADS": str(blas_threads)}),
        )
        if result.returncode != 0:
            last = (result.stderr.strip().splitlines() or ["no message"])[-1]
            raise RuntimeError(f"the long-recording run failed: {last}")
        streamed = json.loads(result.stdout.strip().splitlines()[-1])
        shutil.rmtree(folder / "z.zarr")
        raw = sequential_write(streamed["bytes"], folder)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    mib = streamed["bytes"] / 2**20
    return dict(
        n_sources=size[0],
        n_channels=size[1],
        n_times=size[2],
        seconds=streamed["seconds"],
        cpu_seconds=streamed["cpu_seconds"],
        speedup=BASELINE_SECONDS / streamed["seconds"],
        steady=streamed["steady"],
        load_1min=load_1min,
        runnable=runnable,
        peak_rss_gib=streamed["peak_rss_gib"],
        gib_written=streamed["bytes"] / 2**30,
        throughput_mib_s=mib / streamed["seconds"],
        sequential_mib_s=mib / raw,
        fraction_of_disk=raw / streamed["seconds"],
        blas_threads=streamed["blas"],
    )


def to_markdown(row):
    """The long-recording result as a markdown section (heading included)."""
    return (
        f"{HEADING}\n\n"
        f"{row['n_sources']} sources x {row['n_channels']} channels x {row['n_times']} samples, "
        '"rts-standardized", exponent 1.25: the smoothed z '
        f"({row['gib_written']:.1f} GiB) written to a zarr store block by block; the "
        f"recursions held from step {row['steady']} on. Load before: 1-minute average / "
        "tasks runnable besides the benchmark.\n\n"
        "| time (s) | CPU (s) | load | peak resident memory (GiB) | throughput (MiB/s) "
        "| plain sequential write (MiB/s) | fraction of the disk's speed | BLAS threads |\n"
        "|---:|---:|---:|---:|---:|---:|---:|---:|\n"
        f"| {row['seconds']:.1f} | {row['cpu_seconds']:.1f} "
        f"| {row['load_1min']:.2f} / {row['runnable']:.0f} | {row['peak_rss_gib']:.2f} "
        f"| {row['throughput_mib_s']:.0f} | {row['sequential_mib_s']:.0f} "
        f"| {row['fraction_of_disk']:.2f} | {row['blas_threads']} |\n\n"
        f"Targets: {row['speedup']:.1f}x faster than before the steady state "
        f"({BASELINE_SECONDS} s; "
        f"target {SPEEDUP_TARGET:g}x), {row['peak_rss_gib']:.2f} GiB resident (target < "
        f"{MEMORY_TARGET_GIB:g} GiB).\n"
    )


def save(row, out, text):
    """Write ``long_recording.csv`` in ``out``; ``text`` (results.md) with this section.

    Returns
    -------
    str
        ``text`` with its long-recording section replaced (or added).
    """
    import pandas as pd

    from skf_ref._utils.atomic_files import atomic_path

    with atomic_path(out / "long_recording.csv") as tmp:
        pd.DataFrame([row]).to_csv(tmp, index=False)
    return timing.replace_section(text, HEADING, to_markdown(row))


def main(out=Path("validation/bench")):
    """Run :func:`measure` alone and replace its section of ``out/results.md``."""
    from skf_ref._utils.atomic_files import atomic_path

    row = measure()
    results = out / "results.md"
    text = save(row, out, results.read_text() if results.exists() else "")
    with atomic_path(results) as tmp:
        tmp.write_text(text)
    print(to_markdown(row))
    return 0


if __name__ == "__main__":
    sys.exit(main())
