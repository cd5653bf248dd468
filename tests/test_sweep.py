"""Sweeps: validation before work, shared-recursion batching, resume after a real kill."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from skf_ref import priors_from_snr, reconstruct
from skf_ref.study import _metrics as metrics
from skf_ref.study import _scenario as simulate
from skf_ref.study._sweep import (
    KEY,
    TornLineWarning,
    check_grid,
    paper_grid,
    read_results,
    run_group,
    run_sweep,
)

POSITIONS = 500  # the smallest grid that holds the scenario comfortably: fast tests


def small_grid(seeds=2):
    return dict(
        snr_db=[20.0],
        ep_snr_db=[0.0, 20.0],
        pm_snr_db=[0.0],
        exponent=[0.5, 1.25],
        smoother=[None, "rts-standardized"],
        seed=list(range(seeds)),
    )


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(exponent=[]), r"grid\['exponent'\] is empty"),
        (dict(smoother=["rts"]), r"smoother'\] values must be one of"),
        (dict(exponent=[0.5, -0.25]), r"grid\['exponent'\] values must be >= 0, got -0.25"),
        (dict(snr_db=[float("nan")]), r"grid\['snr_db'\] values must be finite"),
        (dict(seed=[0, 0]), r"grid\['seed'\] has repeated values"),
        (dict(seed=[1.5]), r"grid\['seed'\] values must be an integer, got 1.5"),
        (dict(alpha=[1.0]), r"unknown \['alpha'\]"),
    ],
)
def test_bad_grids_are_rejected_before_any_work(tmp_path, change, match):
    out = tmp_path / "results.csv"
    with pytest.raises(ValueError, match=match):
        run_sweep(small_grid() | change, out, verbose=False, n_positions=POSITIONS)
    assert not out.exists()


def test_missing_axis_and_wrong_type():
    grid = small_grid()
    del grid["seed"]
    with pytest.raises(ValueError, match=r"missing \['seed'\]"):
        check_grid(grid)
    with pytest.raises(TypeError, match="grid must be a mapping"):
        check_grid([("seed", [0])])


def test_batching_equals_running_seeds_one_by_one():
    runs = [(e, s, seed) for seed in (0, 1, 2) for e in (0.5, 1.25) for s in (None, "rts-state")]
    batched = run_group(20.0, 20.0, 0.0, runs, n_positions=POSITIONS)
    head = simulate.make_head_model(POSITIONS)
    scenario = simulate.p20n20_scenario()
    for (exponent, smoother, seed), row in zip(runs, batched, strict=True):
        sim = simulate.simulate(head, scenario, 20.0, seed)
        theta0, q = priors_from_snr(head.leadfield, sim.sigma, 0.0, 20.0, sim.Y.shape[1])
        rec = reconstruct(
            head.leadfield,
            sim.Y,
            noise_std=sim.sigma,
            theta0=theta0,
            q=q,
            exponent=exponent,
            smoother=smoother,
        )
        alone = metrics.summarize(rec, head, sim.truth)
        assert (row["exponent"], row["seed"]) == (exponent, seed)
        assert {k: row[k] for k in alone} == alone
        assert row["log_likelihood"] == rec.log_likelihood


def test_rows_are_tidy_and_a_rerun_adds_nothing(tmp_path):
    out = tmp_path / "results.csv"
    table = run_sweep(small_grid(), out, verbose=False, n_positions=POSITIONS)
    assert len(table) == 16
    assert set(table["smoother"]) == {"none", "rts-standardized"}
    for column in ("numpy_version", "mne_version", "deep_error_mm", "separation", "theta0"):
        assert column in table.columns
    before = out.read_bytes()
    again = run_sweep(small_grid(), out, verbose=False, n_positions=POSITIONS)
    assert out.read_bytes() == before and len(again) == 16
    # a larger grid adds only the new rows
    bigger = run_sweep(small_grid(seeds=3), out, verbose=False, n_positions=POSITIONS)
    assert len(bigger) == 24 and not bigger.duplicated(list(KEY)).any()


def test_torn_last_line_is_dropped_on_resume(tmp_path):
    out = tmp_path / "results.csv"
    run_sweep(small_grid(seeds=1), out, verbose=False, n_positions=POSITIONS)
    with open(out, "ab") as f:
        f.write(b"480,biosemi64,20.0,0.0")  # a row cut short by a power loss
    torn = out.read_bytes()
    assert len(read_results(out)) == 8
    assert out.read_bytes() == torn  # reading never writes
    with pytest.warns(TornLineWarning, match="torn last line"):
        table = run_sweep(small_grid(seeds=1), out, verbose=False, n_positions=POSITIONS)
    assert len(table) == 8 and out.read_bytes().endswith(b"\n")


# 72 runs, one per task, so that rows arrive one at a time: the kill comes once 11 rows are
# in the file (the header is a line), with about 60 runs still to go (each takes tens of ms:
# the test's poll, every 10 ms, lands the kill part-way even on a busy machine).
KILL_GRID = dict(
    snr_db=[10.0, 20.0, 30.0],
    ep_snr_db=[0.0, 20.0],
    pm_snr_db=[0.0],
    exponent=[0.5, 1.25],
    smoother=[None, "rts-standardized", "rts-state"],
    seed=[0, 1],
)
_KILLED_SWEEP = textwrap.dedent(
    """
    import json, sys
    from skf_ref.study._sweep import run_sweep
    grid = json.loads(sys.argv[2])
    run_sweep(grid, sys.argv[1], verbose=False, n_positions=int(sys.argv[3]), runs_per_task=1)
    """
)


def _lines(path):
    return path.read_bytes().count(b"\n") if path.exists() else 0


@pytest.mark.slow
def test_resume_after_the_process_is_killed(tmp_path):
    out = tmp_path / "results.csv"
    env = os.environ | {"PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    arguments = [str(out), json.dumps(KILL_GRID), str(POSITIONS)]
    process = subprocess.Popen([sys.executable, "-c", _KILLED_SWEEP, *arguments], env=env)
    deadline = time.monotonic() + 120
    parsed_sizes = []
    while _lines(out) < 12 and process.poll() is None and time.monotonic() < deadline:
        if out.exists():
            parsed_sizes.append(len(read_results(out)))  # parseable at every moment
        time.sleep(0.01)
    process.send_signal(signal.SIGKILL)
    process.wait()
    total = int(np.prod([len(v) for v in KILL_GRID.values()]))
    partial = read_results(out)
    assert 0 < len(partial) < total, "the sweep must be killed part-way for this test to count"
    assert parsed_sizes == sorted(parsed_sizes)
    # resumed in this process (parallel workers: test_stream's cluster, the CLI's --jobs 2)
    table = run_sweep(KILL_GRID, out, verbose=False, n_positions=POSITIONS)
    assert len(table) == total
    assert not table.duplicated(list(KEY)).any()
    pd.testing.assert_frame_equal(table.iloc[: len(partial)], partial)


def test_parquet_results_are_resumable(tmp_path):
    out = tmp_path / "results.parquet"
    run_sweep(small_grid(seeds=1), out, verbose=False, n_positions=POSITIONS)
    table = run_sweep(small_grid(seeds=2), out, verbose=False, n_positions=POSITIONS)
    assert len(table) == 16 and len(pd.read_parquet(out)) == 16
    assert not table.duplicated(list(KEY)).any()


def test_paper_grid_is_the_papers():
    grid = paper_grid()
    assert grid["snr_db"] == [10.0, 20.0, 30.0]
    assert grid["ep_snr_db"] == grid["pm_snr_db"] == [0.0, 20.0]
    assert grid["exponent"] == [0.5, 1.0, 1.25, 1.5]
    assert grid["seed"] == list(range(10))
    assert np.prod([len(v) for v in grid.values()]) == 1440
