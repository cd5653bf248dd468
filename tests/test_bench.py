"""The benchmark script runs every path and reports what the memory guard refuses.

No timing is asserted here: performance targets live in validation/bench.py's output.
"""

import ast
from pathlib import Path

import pandas as pd
import pytest

from validation import bench, problem

# 50 positions: the filterpy and dense paths' (n, n) covariances stay small (a fast test)
TINY = (150, 32, 4)


@pytest.mark.slow
def test_every_path_runs_at_a_tiny_size(tmp_path):
    table = bench.benchmark(sizes=[TINY], repeats=1, progress=lambda line: None)
    assert list(table["path"]) == list(bench.PATHS)
    assert (table["status"] == "ok").all()
    assert (table["seconds"] > 0).all() and (table["peak_mib"] > 0).all()
    text = bench.to_markdown(table)
    assert text.count("\n") == 2 + len(bench.PATHS)


def test_paths_past_the_memory_guard_are_reported_not_run(monkeypatch):
    from skf_ref._utils import memory

    monkeypatch.setattr(memory, "available_memory", lambda: 2**20)
    table = bench.benchmark(
        sizes=[TINY], paths=("dense", "spectral"), repeats=1, progress=lambda line: None
    )
    dense, spectral = table.itertuples()
    assert dense.status == "not runnable" and "GiB for its covariances" in dense.note
    assert spectral.status == "ok"
    assert "not runnable" in bench.to_markdown(table)


@pytest.mark.parametrize(
    "argv",
    [
        ["--size", "300,32"],
        ["--paths", "gpu"],
        ["--repeats", "0"],
        ["--blas-threads", "0"],
        ["--blas-threads", "two"],
        ["--bogus"],
    ],
)
def test_bad_arguments_exit_2(argv, capsys):
    assert bench.main(argv) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_blas_threads_option_is_parsed():
    assert bench.parse_args([]).blas_threads is None
    args = bench.parse_args(["--blas-threads", "1", "--size", "300,32,4", "--paths", "spectral"])
    assert args.blas_threads == 1
    assert args.sizes == [(300, 32, 4)] and args.paths == ["spectral"]
    with pytest.raises(ValueError, match="--blas-threads must be at least 1, got 0"):
        bench.parse_args(["--blas-threads", "0"])
    with pytest.raises(ValueError, match="invalid int value"):
        bench.parse_args(["--blas-threads", "two"])


def test_blas_threads_are_recorded_beside_every_timing(tmp_path, capsys):
    out = tmp_path / "bench"
    argv = ["--blas-threads", "1", "--size", "300,32,4", "--paths", "spectral,mne-sloreta"]
    assert bench.main([*argv, "--repeats", "1", "--out", str(out)]) == 0
    table = pd.read_csv(out / "results.csv")
    assert table["blas_limit"].astype(str).eq("1").all()
    assert (table["blas_threads"] == 1).all()
    assert table["blas"].str.contains(r"\(1 thread\)").all()
    text = (out / "results.md").read_text()
    assert "BLAS (threadpoolctl, while timing):" in text
    assert "limited to 1 by `--blas-threads 1`" in text
    assert "| BLAS threads |" in text
    # the limit applies to the run only
    assert problem.blas_columns()["blas_limit"] == "none"


def test_unlimited_run_records_the_libraries_own_threads():
    table = bench.benchmark(
        sizes=[TINY], paths=("spectral",), repeats=1, progress=lambda line: None
    )
    (row,) = table.itertuples()
    assert row.blas_limit == "none" and row.blas_threads >= 1
    assert "not limited" in bench.report(table)


def test_the_make_row_times_make_inverse_operator(monkeypatch):
    import mne.minimum_norm

    calls = []
    make = mne.minimum_norm.make_inverse_operator
    monkeypatch.setattr(
        mne.minimum_norm,
        "make_inverse_operator",
        lambda *args, **kwargs: calls.append(1) or make(*args, **kwargs),
    )
    tiny = problem.make_problem(*TINY)
    for path, made_per_run in (("mne-sloreta", 0), ("mne-sloreta+make", 1)):
        calls.clear()
        run = bench._runner(tiny, path)
        made_before = len(calls)
        run()
        run()
        assert len(calls) - made_before == 2 * made_per_run, path


@pytest.mark.slow
def test_long_recording_reports_time_memory_and_the_disk(tmp_path):
    from validation import long_recording

    row = long_recording.measure(size=(300, 16, 400), folder=tmp_path)
    assert row["gib_written"] == pytest.approx(8 * 300 * 400 / 2**30)
    assert row["seconds"] > 0 and 0 < row["peak_rss_gib"] < 4
    assert row["cpu_seconds"] > 0 and 0 < row["steady"] <= 400 and row["load_1min"] >= 0
    assert row["sequential_mib_s"] > 0 and row["fraction_of_disk"] > 0
    assert not list(tmp_path.iterdir())  # the store and the raw file are removed
    assert "Long recording" in long_recording.to_markdown(row)


def test_long_recording_section_replaces_the_old_one(tmp_path):
    # the bench writes the table and this section; run again, the section is replaced and
    # the table kept
    from validation import long_recording

    row = dict(
        n_sources=1,
        n_channels=2,
        n_times=3,
        seconds=1.0,
        cpu_seconds=1.5,
        speedup=160.8,
        steady=2,
        load_1min=0.5,
        runnable=0.0,
        peak_rss_gib=1.0,
        gib_written=1.0,
        throughput_mib_s=1.0,
        sequential_mib_s=2.0,
        fraction_of_disk=0.5,
        blas_threads=2,
    )
    first = long_recording.save(row, tmp_path, "# table\n\nrows\n")
    again = long_recording.save(dict(row, seconds=9.0), tmp_path, first)
    assert again.startswith("# table\n\nrows\n") and again.count(long_recording.HEADING) == 1
    assert "| 9.0 | 1.5 | 0.50 / 0 |" in again and (tmp_path / "long_recording.csv").exists()


def test_every_timing_records_cpu_time_and_load():
    from validation import timing

    timed = timing.measure(lambda: sum(range(10_000)), repeats=3)
    assert timed["runs"] == 3 and timed["q1_seconds"] <= timed["seconds"] <= timed["q3_seconds"]
    assert timed["cpu_seconds"] > 0 and timed["load_1min"] >= 0 and timed["runnable"] >= 0
    assert timed["peak_bytes"] >= 0


def test_the_competitor_runs_only_inside_its_block():
    from validation import timing

    with timing.competitor() as process:
        assert process.poll() is None  # spinning
    assert process.poll() is not None  # stopped when the block ends
    with timing.competitor(active=False) as nothing:
        assert nothing is None


def test_floor_comparison_at_a_tiny_size(monkeypatch, tmp_path):
    from validation import floor

    monkeypatch.setattr(floor, "SIZE", (300, 32, 20))
    argv = ["--no-table", "--floor", "--repeats", "2", "--out", str(tmp_path)]
    (tmp_path / "results.md").write_text("# Benchmarks\n\n## Every path\n\nkept\n")
    assert bench.main(argv) == 0
    rows = pd.read_csv(tmp_path / "floor.csv")
    assert list(rows["condition"]) == ["quiet", "competitor"] and (rows["pairs"] == 2).all()
    assert (rows["ratio"] > 0).all() and (rows["floor_svd_seconds"] > 0).all()
    assert (rows["cpu_ratio_q1"] <= rows["cpu_ratio_q3"]).all()
    text = (tmp_path / "results.md").read_text()
    assert "## Every path\n\nkept\n" in text and text.count(floor.HEADING) == 1
    assert "| competitor |" in text and "<= 1.15" in text and "<= 1.5" in text


def test_replace_section_adds_replaces_and_keeps():
    from validation.timing import replace_section

    text = replace_section("# B\n", "## One", "## One\n\na\n")
    text = replace_section(text, "## Two", "## Two\n\nb\n")
    text = replace_section(text, "## One", "## One\n\nc\n")
    assert text == "# B\n\n## One\n\nc\n\n## Two\n\nb\n"


def _validation_imports(name):
    """The ``validation`` modules a validation script imports, at any depth."""
    path = Path(__file__).resolve().parents[1] / "validation" / f"{name}.py"
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module == "validation":
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("validation."):
            found.add(node.module.split(".")[1])
    return found


def test_bench_and_floor_share_a_module_and_do_not_import_each_other():
    assert "floor" in _validation_imports("bench") and "problem" in _validation_imports("bench")
    assert "bench" not in _validation_imports("floor")
    assert "problem" in _validation_imports("floor")
    assert not _validation_imports("problem") & {"bench", "floor"}
