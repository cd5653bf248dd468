"""Child processes driven by what they print: a signal is sent when the child has printed the
line that shows it reached the point under test, never after a fixed sleep (which a busy
machine outruns)."""

import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ENV = os.environ | {"PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
#: How long a child may take to reach the line (imports on a busy machine included).
DEADLINE_S = 300


def start(script, *arguments, cwd=None):
    """``python -c script arguments`` in a session of its own (as a terminal's job), its
    standard output and error read as text."""
    return subprocess.Popen(
        [sys.executable, "-c", script, *map(str, arguments)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
        cwd=cwd,
        start_new_session=True,
    )


def wait_for_line(process, marker, deadline_s=DEADLINE_S):
    """Read the child's standard output line by line until one starts with ``marker``;
    returns the lines read. Fails (and kills the child) if it ends or the deadline passes
    first."""
    lines, end = [], time.monotonic() + deadline_s
    while True:
        remaining = end - time.monotonic()
        ready, _, _ = select.select([process.stdout], [], [], max(remaining, 0))
        if not ready:
            process.kill()
            raise AssertionError(f"no line {marker!r} within {deadline_s} s; got {lines}")
        line = process.stdout.readline()
        if not line:
            err = process.communicate()[1]
            raise AssertionError(f"ended ({process.returncode}) before {marker!r}: {err}")
        lines.append(line.rstrip("\n"))
        if line.startswith(marker):
            return lines


def ctrl_c(process, timeout=120):
    """Ctrl-C as a terminal sends it, to every process of the job; returns (status, stdout,
    stderr) once the child has ended."""
    os.killpg(process.pid, signal.SIGINT)
    out, err = process.communicate(timeout=timeout)
    return process.returncode, out, err
