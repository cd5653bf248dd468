"""The ``skf-ref`` command line: the demo end to end, one-line errors, interruptions."""

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from processes import DEADLINE_S, ctrl_c, start

import skf_ref
from skf_ref.cli import main

# a small sphere head model: seconds, not a minute (and never MNE's testing dataset)
SMALL = ["--positions", "500", "--quiet", "--head", "sphere", "--source-space", "volume"]
ENV = os.environ | {"PYTHONPATH": str(Path(__file__).resolve().parents[1])}


@pytest.fixture(scope="module")
def demo_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    assert main(["demo", "--out", str(out), *SMALL]) == 0
    return out


@pytest.mark.slow
def test_demo_writes_figures_arrays_and_metrics(demo_dir, capsys):
    from skf_ref.study._demo import OUTPUTS

    assert sorted(p.name for p in demo_dir.iterdir()) == sorted(OUTPUTS)
    for png in demo_dir.glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    arrays = np.load(demo_dir / "reconstruction.npz")
    n_sources, n_times = arrays["z_skf"].shape
    assert n_sources == 3 * len(arrays["positions"]) and n_times == 41
    assert arrays["amplitude_sloreta_deep_absent"].shape == (len(arrays["positions"]), 41)
    assert not np.array_equal(arrays["z_skf"], arrays["z_paper"])
    assert not np.array_equal(arrays["Y"], arrays["Y_deep_absent"])
    table = pd.read_csv(demo_dir / "metrics.csv", index_col=0)
    methods = ("skf", "paper", "sLORETA")
    assert list(table.columns) == [
        f"{m}, {d}" for m in methods for d in ("present", "deep absent")
    ]
    columns = pd.read_csv(demo_dir / "metrics_columns.csv", index_col=0)
    assert list(columns.index) == list(table.index)  # every metric explained
    assert set(columns["unit"]) >= {"mm", "dB", "bool"}
    settings = json.loads((demo_dir / "settings.json").read_text())
    # one position count, the grid's own, everywhere it is recorded
    assert settings["n_positions"] == len(arrays["positions"])
    assert settings["positions_requested"] == 500
    assert settings["machine"]["versions"]["skf_ref"] == skf_ref.__version__
    assert settings["machine"]["blas"] and settings["seed"] == 0
    assert settings["head_kind"] == "sphere" and settings["source_space"] == "volume"
    # the recommended setting by default, the paper's beside it
    assert {k: settings[k] for k in ("exponent", "smoother")} == skf_ref.RECOMMENDED_SETTING
    assert settings["paper_setting"] == dict(skf_ref.PAPER_SETTING)
    # the AR(1) prior, its time constant chosen by the data, recorded with its transition
    assert settings["evolution_prior"] == "ar1" and settings["time_constant_ms"] == "auto"
    tau, rho = settings["tuned_time_constant_ms"], settings["transition"]
    assert rho == pytest.approx(np.exp(-1e3 / settings["sfreq"] / tau), rel=1e-12)


@pytest.mark.slow
def test_demo_prints_the_metrics_table(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), *SMALL, "--snr-db", "20"]) == 0
    printed = capsys.readouterr().out
    # which prior each SKF ran: the AR(1) prior chosen by the data, the paper's own priors
    first, paper = printed.split("\n")[1].split("; the paper's setting ")
    assert first.startswith("SNR 20 dB; first SKF: PM-SNR 0 dB, the AR(1) prior with time ")
    assert " ms (chosen by the data in 1..1000 ms" in first
    assert paper.startswith("at its own priors: PM-SNR 0 dB, the random walk at EP-SNR 20 dB;")
    assert "; 480 positions (biosemi64)" in paper
    assert "superficial_error_mm" in printed
    for label in ("exponent 0.5, rts-smoothed-weights", "(paper)", "sLORETA", "deep absent"):
        assert label in printed, label


@pytest.mark.slow
def test_demo_ep_snr_db_runs_the_random_walk(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), *SMALL, "--ep-snr-db", "0"]) == 0
    printed = capsys.readouterr().out
    assert "first SKF: PM-SNR 0 dB, the random walk at EP-SNR 0 dB;" in printed
    settings = json.loads((tmp_path / "settings.json").read_text())
    assert settings["evolution_prior"] == "random walk" and settings["transition"] == 1.0


@pytest.mark.slow
def test_demo_runs_the_chosen_setting_beside_the_papers(tmp_path, capsys):
    arguments = ["--exponent", "1", "--smoother", "rts-state"]
    assert main(["demo", "--out", str(tmp_path), *SMALL, *arguments]) == 0
    assert "SKF, exponent 1, rts-state, position, present" in capsys.readouterr().out
    settings = json.loads((tmp_path / "settings.json").read_text())
    assert (settings["exponent"], settings["smoother"]) == (1.0, "rts-state")


@pytest.mark.slow
def test_demo_says_which_head_it_used(tmp_path, monkeypatch, capsys):
    import mne

    monkeypatch.setattr(mne.datasets.testing, "data_path", lambda **kwargs: tmp_path / "none")
    assert main(["demo", "--out", str(tmp_path), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "head: sphere" in printed and "--mne-testing-data DIR" in printed
    settings = json.loads((tmp_path / "settings.json").read_text())
    # without the dataset: the sphere, with the paper's kind of source space by default
    assert settings["head_kind"] == "sphere" and settings["source_space"] == "anatomical"
    assert settings["positions_requested"] is None
    again = ["demo", "--out", str(tmp_path), "--overwrite", "--head", "realistic", "--quiet"]
    assert main(again) == 2
    assert "--head: head='realistic' needs MNE's testing dataset" in capsys.readouterr().err


def test_bare_command_prints_help_and_version(capsys):
    assert main([]) == 0
    assert "COMMAND" in capsys.readouterr().out
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"skf-ref {skf_ref.__version__}"


@pytest.mark.parametrize("command", ["demo", "sweep"])
def test_every_option_shows_its_default(command, capsys):
    assert main([command, "--help"]) == 0
    text = capsys.readouterr().out
    options = [line.split()[0] for line in text.splitlines() if line.startswith("  --")]
    no_default = ["--out"] if command == "sweep" else ["--overwrite"]
    flags = {"--help", "--quiet", *no_default}
    for option in set(options) - flags:
        block = text[text.index(f"  {option}") :].split("\n  -")[0]
        assert "(default:" in " ".join(block.split()), option


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["demo", "--snr-db", "nan"], "argument --snr-db: must be finite, got nan"),
        (["demo", "--snr-db", "-inf"], "argument --snr-db: must be finite, got -inf"),
        (["demo", "--snr-db", "7000"], "argument --snr-db: must be within +-300 dB"),
        (["demo", "--exponent", "-1"], "argument --exponent: must be >= 0"),
        (["demo", "--montage", "nope"], "montage"),
        (["demo", "--positions", "10"], "argument --positions: must be >= 420, got 10"),
        (["demo", "--positions", "2.5"], "argument --positions: must be an integer"),
        (["demo", "--positions", "500"], "--positions: n_positions sizes the sphere's volume"),
        (["demo", "--seed", "-1"], "argument --seed: must be >= 0, got -1"),
        (["demo", "--smoother", "kalman"], "invalid choice"),
        (["demo", "--time-constant-ms", "0"], "argument --time-constant-ms: must be > 0"),
        (
            ["demo", "--ep-snr-db", "20", "--time-constant-ms", "30"],
            "argument --time-constant-ms: give --ep-snr-db (the paper's random walk) or "
            "--time-constant-ms (the stationary AR(1) prior), not both",
        ),
        (["demo", "--mne-testing-data", "."], "--mne-testing-data: testing_data must be MNE's"),
        (["demo", "--head", "sphere", "--mne-testing-data", "."], "not used with --head sphere"),
        (["sweep", "--out", "x.csv", "--smoother", "none", "--exponent"], "expected at least one"),
        (["sweep", "--out", "x.csv", "--seeds", "0"], "argument --seeds: must be >= 1"),
        (["sweep", "--out", "x.xlsx"], "argument --out: must end in .csv or .parquet"),
        (["sweep", "--out", "x.csv", "--jobs", "0"], "argument --jobs"),
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


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["demo", "--montage", "foo"], "--montage: montage must be the name of an MNE built-in"),
        (["demo", "--positions", "500"], "--positions: n_positions sizes the sphere's volume"),
        (["sweep", "--out", "x.csv", "--montage", "foo"], "argument --montage: montage must be"),
        (["sweep", "--out", "nodir/x.csv"], "argument --out: nodir/x.csv: the folder nodir"),
    ],
)
def test_an_error_is_the_only_line_even_without_quiet(tmp_path, monkeypatch, capsys,
                                                      arguments, message):  # fmt: skip
    monkeypatch.chdir(tmp_path)
    if arguments[0] == "demo":
        arguments = [*arguments, "--out", str(tmp_path / "out")]
    assert main(arguments) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and message in captured.err, captured.err
    assert captured.out == "" and not any(tmp_path.iterdir())


def test_console_script_entry_point_runs_without_traceback(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "skf_ref.cli", "demo", "--snr-db", "inf", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        env=ENV,
    )
    assert result.returncode == 2
    assert "Traceback" not in result.stderr and result.stderr.count("\n") == 1


@pytest.mark.slow  # a sweep on two workers, interrupted, then resumed: 20-30 s
def test_ctrl_c_stops_a_parallel_sweep_in_one_line_and_it_resumes(tmp_path):
    # Ctrl-C as a terminal sends it, to the sweep and its two workers, once rows are written:
    # one line (no joblib note, no worker's traceback), status 130, every finished row kept
    out = tmp_path / "sweep.csv"
    grid = ["--positions", "500", "--seeds", "2", "--snr-db", "20", "30"]
    script = "import sys; from skf_ref.cli import console; sys.argv[0] = 'skf-ref'; console()"
    process = start(script, "sweep", "--out", out, "--quiet", "--jobs", "2", *grid)
    deadline = time.monotonic() + DEADLINE_S
    while _lines(out) < 30 and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)  # polls the file the sweep writes: the signal waits for its rows
    status, _, err = ctrl_c(process)
    assert status == 130, err
    assert err == f"skf-ref: interrupted; finished rows are in {out}: rerun to resume\n"
    partial = pd.read_csv(out)
    assert 0 < len(partial) < 192
    assert main(["sweep", "--out", str(out), *grid, "--quiet"]) == 0
    table = pd.read_csv(out)
    assert len(table) == 192  # 2 SNRs x 2 EP x 2 PM x 4 exponents x 3 smoothers x 2 seeds


def _lines(path):
    return path.read_bytes().count(b"\n") if path.exists() else 0
