"""The long-recording benchmark: a recording far larger than memory, streamed to disk.

``python -m validation.bench --long`` runs it beside the usual table. One reconstruction of
10 000 sources x 64 channels x 200 000 samples (an hour-like recording), ``"rts-standardized"``
smoothing, exponent 1.25, its smoothed ``z`` (16 GB) written by ``Reconstruction.to_zarr``,
block of rows by block, in a fresh process, which reports its wall time and its peak
resident memory (``VmHWM`` of ``/proc/self/status``: on Linux ``ru_maxrss`` of a child
counts its parent's resident memory at the fork, 4.9 GiB once after the bench's largest
sizes). ``python -m validation.long_recording`` runs it alone and replaces its section of
``validation/bench/results.md``. The physical limit is this machine's plain sequential write
of the same number of bytes (a file written in blocks of the same size), timed the same way:
both end with ``os.sync()``, so neither is flattered by the page cache.
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

__all__ = [
    "HEADING",
    "SIZE",
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


def stream(n_sources, n_channels, n_times, folder, seed=0):
    """Reconstruct and write the smoothed ``z`` to ``folder/z.zarr``; in this process.

    Returns
    -------
    dict
        ``seconds`` (reconstruct + write + sync), ``peak_rss_gib``, ``bytes``.
    """
    from skf_ref import priors_from_snr, reconstruct
    from skf_ref._utils.provenance import blas_threads

    rng = np.random.default_rng(seed)
    L = rng.standard_normal((n_channels, n_sources))
    L -= L.mean(axis=0)
    sources = np.cumsum(rng.standard_normal((3, n_times)), axis=1)
    Y = L[:, :3] @ sources + rng.standard_normal((n_channels, n_times))
    theta0, q = priors_from_snr(L, 1.0, 0.0, 20.0, n_times)
    start = time.perf_counter()
    rec = reconstruct(
        L, Y, noise_std=1.0, theta0=theta0, q=q, exponent=1.25, smoother="rts-standardized"
    )
    rec.to_zarr(Path(folder) / "z.zarr", arrays=("z",))
    os.sync()
    seconds = time.perf_counter() - start
    peak = _peak_resident_bytes()
    blas = max((b["threads"] for b in blas_threads()), default=1)
    return dict(
        seconds=seconds, peak_rss_gib=peak / 2**30, bytes=8 * n_sources * n_times, blas=blas
    )


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
        ``n_sources``, ``n_channels``, ``n_times``, ``seconds``, ``peak_rss_gib``,
        ``gib_written``, ``throughput_mib_s``, ``sequential_mib_s``, ``fraction_of_disk``,
        ``blas_threads`` (of the process that reconstructed).
    """
    folder = Path(tempfile.mkdtemp(dir=folder or ".", prefix=".skf-long-"))
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
        peak_rss_gib=streamed["peak_rss_gib"],
        gib_written=streamed["bytes"] / 2**30,
        throughput_mib_s=mib / streamed["seconds"],
        sequential_mib_s=mib / raw,
        fraction_of_disk=raw / streamed["seconds"],
        blas_threads=streamed["blas"],
    )


def to_markdown(row):
    """The long-recording result as a markdown section."""
    return (
        f"\n{HEADING}\n\n"
        f"{row['n_sources']} sources x {row['n_channels']} channels x {row['n_times']} samples, "
        '"rts-standardized", exponent 1.25: the smoothed z '
        f"({row['gib_written']:.1f} GiB) written to a zarr store block by block.\n\n"
        "| time (s) | peak resident memory (GiB) | throughput (MiB/s) "
        "| plain sequential write (MiB/s) | fraction of the disk's speed | BLAS threads |\n"
        "|---:|---:|---:|---:|---:|---:|\n"
        f"| {row['seconds']:.1f} | {row['peak_rss_gib']:.2f} | {row['throughput_mib_s']:.0f} "
        f"| {row['sequential_mib_s']:.0f} | {row['fraction_of_disk']:.2f} "
        f"| {row['blas_threads']} |\n"
    )


def save(row, out, table):
    """Write ``long_recording.csv`` and ``results.md`` in ``out``: ``table`` (the bench's
    markdown, without any earlier long-recording section) followed by this one."""
    import pandas as pd

    from skf_ref._utils.atomic_files import atomic_path

    with atomic_path(out / "long_recording.csv") as tmp:
        pd.DataFrame([row]).to_csv(tmp, index=False)
    table = table.split(HEADING)[0].rstrip("\n") + "\n"
    with atomic_path(out / "results.md") as tmp:
        tmp.write_text(table + to_markdown(row))


def main(out=Path("validation/bench")):
    """Run :func:`measure` alone and replace its section of ``out/results.md``."""
    row = measure()
    results = out / "results.md"
    save(row, out, results.read_text() if results.exists() else "")
    print(to_markdown(row))
    return 0


if __name__ == "__main__":
    sys.exit(main())
