"""The ``skf-ref`` command line: the demo end to end, one-line errors, interruptions."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from skf_ref.cli import main

SMALL = ["--positions", "500", "--quiet"]  # a small head model: seconds, not a minute
ENV = os.environ | {"PYTHONPATH": str(Path(__file__).resolve().parents[1])}


@pytest.fixture(scope="module")
def demo_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    assert main(["demo", "--out", str(out), *SMALL]) == 0
    return out


def test_demo_writes_figures_arrays_and_metrics(demo_dir, capsys):
    names = sorted(p.name for p in demo_dir.iterdir())
    assert names == [
        "average_reconstruction_filtered.png",
        "average_reconstruction_smoothed.png",
        "metrics.csv",
        "reconstruction.npz",
        "time_courses_filtered.png",
        "time_courses_smoothed.png",
    ]
    for png in demo_dir.glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    arrays = np.load(demo_dir / "reconstruction.npz")
    n_sources, n_times = arrays["z_filtered"].shape
    assert n_sources == 3 * len(arrays["positions"]) and n_times == 41
    assert not np.array_equal(arrays["z_filtered"], arrays["z_smoothed"])
    table = pd.read_csv(demo_dir / "metrics.csv", index_col=0)
    assert list(table.columns) == ["filtered", "smoothed"]
    assert "deep_error_mm" in table.index and "separation" in table.index


def test_demo_prints_the_metrics_table(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), *SMALL, "--snr-db", "20"]) == 0
    printed = capsys.readouterr().out
    assert "data SNR 20 dB" in printed and "superficial_error_mm" in printed


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["demo", "--snr-db", "nan"], "snr_db"),
        (["demo", "--exponent", "-1"], "exponent must be >= 0"),
        (["demo", "--montage", "nope"], "montage"),
        (["demo", "--positions", "10"], "n_positions"),
        (["demo", "--smoother", "kalman"], "invalid choice"),
        (["sweep", "--out", "x.csv", "--smoother", "none", "--exponent"], "expected at least one"),
        (["sweep", "--out", "x.csv", "--seeds", "0"], "grid['seed'] is empty"),
        (["frobnicate"], "invalid choice"),
    ],
)
def test_errors_print_one_line_and_exit_2(tmp_path, monkeypatch, capsys, arguments, message):
    monkeypatch.chdir(tmp_path)
    if arguments[0] == "demo":
        arguments = [*arguments, "--out", str(tmp_path / "out"), "--quiet"]
    assert main(arguments) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("skf-ref: error:") and message in err
    assert not (tmp_path / "x.csv").exists()
    assert not any((tmp_path / "out").glob("*")) if (tmp_path / "out").exists() else True


def test_console_script_entry_point_runs_without_traceback(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "skf_ref.cli", "demo", "--snr-db", "inf", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        env=ENV,
    )
    assert result.returncode == 2
    assert "Traceback" not in result.stderr and result.stderr.count("\n") == 1


def test_ctrl_c_stops_a_sweep_cleanly_and_it_resumes(tmp_path):
    out = tmp_path / "sweep.csv"
    command = [sys.executable, "-m", "skf_ref.cli", "sweep", "--out", str(out), "--quiet"]
    command += ["--positions", "500", "--seeds", "4"]
    process = subprocess.Popen(command, env=ENV, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while process.poll() is None and time.monotonic() < deadline:
        if out.exists() and out.read_bytes().count(b"\n") > 30:
            break
        time.sleep(0.01)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert "rerun to resume" in err and "Traceback" not in err
    partial = pd.read_csv(out)
    assert 0 < len(partial) < 576
    assert main(["sweep", "--out", str(out), "--positions", "500", "--seeds", "4", "--quiet"]) == 0
    table = pd.read_csv(out)
    assert len(table) == 576  # 3 x 2 x 2 x 4 x 3 x 4
