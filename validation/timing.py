"""How the benchmarks time a call: wall and CPU time, the machine's load, a competitor.

This machine has two cores that other work shares, so a wall time alone says little: every
timing records beside it the CPU time of this process (all its threads, ``time.process_time``)
and the machine's load, both the 1-minute load average and the number of tasks runnable at
that instant (``/proc/loadavg``, this process's own thread excluded), sampled before each
run. :func:`competitor` starts a single-threaded busy loop beside the timings, the load a
benchmark should withstand; it is stopped, by its own process id, when the block ends.
"""

import contextlib
import os
import statistics
import subprocess
import sys
import time
import tracemalloc

import numpy as np

__all__ = [
    "SLOW_SECONDS",
    "competitor",
    "load",
    "measure",
    "pair_summary",
    "quartiles",
    "replace_section",
]

#: Stop repeating a call once its runs have taken this long in total.
SLOW_SECONDS = 60.0


def load():
    """The machine's load now: ``(load_1min, runnable)``.

    ``runnable`` counts the tasks runnable at this instant (the fourth field of
    ``/proc/loadavg``) less this process's calling thread; NaN where there is no such file.

    Returns
    -------
    (float, float)
    """
    one_minute = os.getloadavg()[0]
    try:
        with open("/proc/loadavg") as stream:
            running = float(stream.read().split()[3].split("/")[0]) - 1
    except (OSError, IndexError, ValueError):
        running = float("nan")
    return one_minute, running


def quartiles(values):
    """Median and interquartile range of ``values``: ``(median, q1, q3)``."""
    q1, median, q3 = np.percentile(values, [25, 50, 75])
    return float(median), float(q1), float(q3)


def pair_summary(pairs, first, second):
    """Medians and ratios of alternated pairs of runs, as the benchmarks' table columns.

    ``pairs`` holds ``(a, b)``, each run ``(wall s, CPU s, (1-minute load, runnable), ...)``;
    ``first`` and ``second`` name ``a`` and ``b`` in the columns. The ratios are ``b / a``
    pair by pair (both runs of a pair saw the same load): median and quartiles of wall and
    CPU time; the load is the median over every run.
    """
    loads = [run[2] for pair in pairs for run in pair]
    ratio = quartiles([b[0] / a[0] for a, b in pairs])
    cpu_ratio = quartiles([b[1] / a[1] for a, b in pairs])
    medians = {}
    for name, index in ((first, 0), (second, 1)):
        medians[f"{name}_seconds"] = float(np.median([pair[index][0] for pair in pairs]))
        medians[f"{name}_cpu_seconds"] = float(np.median([pair[index][1] for pair in pairs]))
    return dict(
        pairs=len(pairs),
        **medians,
        ratio=ratio[0],
        ratio_q1=ratio[1],
        ratio_q3=ratio[2],
        cpu_ratio=cpu_ratio[0],
        cpu_ratio_q1=cpu_ratio[1],
        cpu_ratio_q3=cpu_ratio[2],
        load_1min=float(np.median([one for one, _ in loads])),
        runnable=float(np.median([now for _, now in loads])),
    )


def measure(run, repeats, trace_memory=True):
    """Time ``run()``: wall and CPU time, load, and the peak memory it traces.

    Parameters
    ----------
    run : callable
        Called with no arguments.
    repeats : int
        At most this many timed runs (fewer once they took :data:`SLOW_SECONDS`).
    trace_memory : bool
        Also run once more under ``tracemalloc`` for the peak memory the call allocates.

    Returns
    -------
    dict
        ``seconds`` (median wall time), ``q1_seconds``, ``q3_seconds`` (its interquartile
        range), ``cpu_seconds`` (median CPU time of this process), ``runs``,
        ``load_1min`` and ``runnable`` (medians of :func:`load` before each run) and
        ``peak_bytes`` (NaN without ``trace_memory``).
    """
    walls, cpus, loads = [], [], []
    while len(walls) < repeats and sum(walls) < SLOW_SECONDS:
        loads.append(load())
        cpu, start = time.process_time(), time.perf_counter()
        run()
        walls.append(time.perf_counter() - start)
        cpus.append(time.process_time() - cpu)
    peak = float("nan")
    if trace_memory:
        tracemalloc.start()
        try:
            before = tracemalloc.get_traced_memory()[0]
            tracemalloc.reset_peak()
            run()
            peak = tracemalloc.get_traced_memory()[1] - before
        finally:
            tracemalloc.stop()
    seconds, q1, q3 = quartiles(walls)
    return dict(
        seconds=seconds,
        q1_seconds=q1,
        q3_seconds=q3,
        cpu_seconds=statistics.median(cpus),
        runs=len(walls),
        load_1min=statistics.median(one for one, _ in loads),
        runnable=statistics.median(now for _, now in loads),
        peak_bytes=peak,
    )


@contextlib.contextmanager
def competitor(active=True):
    """A single-threaded busy loop in another process while the block runs.

    Parameters
    ----------
    active : bool
        False: nothing is started (so that callers need no second code path).

    Yields
    ------
    subprocess.Popen or None
    """
    if not active:
        yield None
        return
    process = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.5)  # let it start spinning before the first timing
        yield process
    finally:
        process.kill()
        process.wait()


def replace_section(text, heading, section):
    """``text`` (a markdown file) with its section under ``heading`` replaced by ``section``.

    A section runs from its ``## `` heading to the next one; one that is absent is added at
    the end. ``section`` starts with its heading; an empty one removes the section.

    Examples
    --------
    >>> text = "# t\\n\\n## A\\n\\nold\\n\\n## B\\n\\nkeep\\n"
    >>> print(replace_section(text, "## A", "## A\\n\\nnew\\n"))
    # t
    <BLANKLINE>
    ## A
    <BLANKLINE>
    new
    <BLANKLINE>
    ## B
    <BLANKLINE>
    keep
    <BLANKLINE>
    """
    lines = text.splitlines(keepends=True)
    starts = [i for i, line in enumerate(lines) if line.startswith("## ")]
    before, after = text, ""
    for i in starts:
        if lines[i].rstrip("\n") == heading:
            end = next((j for j in starts if j > i), len(lines))
            before, after = "".join(lines[:i]), "".join(lines[end:])
            break
    pieces = (before.rstrip("\n"), section.rstrip("\n"), after.rstrip("\n"))
    return "\n\n".join(piece for piece in pieces if piece) + "\n"
