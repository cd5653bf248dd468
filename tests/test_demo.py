"""The demo as a library function (:func:`skf_ref.study._demo.run_demo`): what the CLI calls."""

import contextlib
import io
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import skf_ref
from skf_ref.study._demo import COLUMNS, DATA, DETECTION_COLUMNS, OUTPUTS, RENAMED, run_demo

COMMITTED = Path(__file__).resolve().parents[1] / "validation" / "demo"

SMALL = dict(head="sphere", source_space="volume", n_positions=500)


@pytest.fixture(scope="module")
def quiet_run():
    """The small demo run quietly, and what it wrote to standard error meanwhile."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        result = run_demo(**SMALL, verbose=False)
    return result, err.getvalue()


@pytest.fixture(scope="module")
def demo(quiet_run):
    return quiet_run[0]


def test_three_methods_on_the_data_with_and_without_the_deep_source(demo):
    assert set(demo.estimates) == {(m, d) for m in demo.methods for d in DATA}
    assert set(demo.reconstructions) == {(m, d) for m in ("skf", "paper") for d in DATA}
    for amplitude in demo.estimates.values():
        assert amplitude.shape == (demo.head.n_positions, 41) and (amplitude >= 0).all()
    # the control is the same noise without the deep source's field
    present, absent = demo.simulations["present"], demo.simulations["deep absent"]
    noise = present.Y - present.Y_clean
    np.testing.assert_allclose(
        absent.Y - absent.Y_clean, noise, rtol=0, atol=1e-12 * present.sigma
    )
    assert absent.sources == ("superficial",) and present.sigma == absent.sigma
    assert list(demo.metrics.columns) == [f"{m}, {d}" for m in demo.methods for d in DATA]


def test_no_metric_called_detected_but_the_calibrated_one(demo):
    # Issue 41: "deep_detected" (the deep region within 6 dB of the maximum) was True in the
    # deep-absent columns too; only the calibrated detection answers "was it detected".
    assert list(demo.metrics.index) == [name for name, *_ in COLUMNS]
    assert not set(RENAMED) & set(demo.metrics.index)
    assert all(isinstance(v, bool) for v in demo.metrics.loc["deep_within_6db"])
    names = [name for name, *_ in (*COLUMNS, *DETECTION_COLUMNS)]
    assert [n for n in names if "detected" in n] == ["deep_detected_calibrated"]


def test_the_committed_demo_has_the_metrics_the_demo_writes():
    table = pd.read_csv(COMMITTED / "metrics.csv", index_col=0)
    assert list(table.index) == [name for name, *_ in (*COLUMNS, *DETECTION_COLUMNS)]
    columns = pd.read_csv(COMMITTED / "metrics_columns.csv", keep_default_na=False)
    assert [tuple(row) for row in columns.itertuples(index=False)] == [
        *COLUMNS,
        *DETECTION_COLUMNS,
    ]


def test_the_settings_are_the_recommended_and_the_papers(demo):
    skf, paper = demo.reconstructions["skf", "present"], demo.reconstructions["paper", "present"]
    assert (skf.exponent, skf.smoother) == tuple(skf_ref.RECOMMENDED_SETTING.values())
    assert (paper.exponent, paper.smoother) == tuple(skf_ref.PAPER_SETTING.values())
    assert demo.settings["theta0"] == skf.theta0 and demo.settings["q"] == skf.q


def test_the_first_skf_runs_the_ar1_prior_its_time_constant_chosen_by_the_data(demo):
    # the package's default (the evidence study v3's rule): PM-SNR 0 dB and the stationary
    # AR(1) prior, tau chosen by the marginal likelihood at the simulation's 10 kHz
    from skf_ref.method._priors import DEFAULT_TIME_CONSTANT_MS

    settings, skf = demo.settings, demo.reconstructions["skf", "present"]
    assert settings["evolution_prior"] == "ar1" and settings["sfreq"] == 10000.0
    assert settings["time_constant_ms"] == DEFAULT_TIME_CONSTANT_MS == "auto"
    assert settings["pm_snr_db"] == settings["tuned_pm_snr_db"] == 0.0
    tau = settings["tuned_time_constant_ms"]
    rho = np.exp(-1e3 / settings["sfreq"] / tau)
    assert skf.transition == pytest.approx(rho, rel=1e-12) and 0 < rho < 1
    assert settings["transition"] == skf.transition
    assert skf.q == pytest.approx((1 - rho**2) * skf.theta0, rel=1e-9)  # stationary
    for data in DATA:  # the control runs at the priors chosen on the data with both sources
        rec = demo.reconstructions["skf", data]
        assert (rec.theta0, rec.q, rec.transition) == (skf.theta0, skf.q, skf.transition)
    # the paper's setting keeps the paper's priors: PM-SNR 0 dB, the random walk at 20 dB
    paper = demo.reconstructions["paper", "present"]
    assert (settings["paper_pm_snr_db"], settings["paper_ep_snr_db"]) == (0.0, 20.0)
    assert paper.transition == 1.0 and paper.theta0 == pytest.approx(skf.theta0, rel=1e-12)
    assert paper.q == pytest.approx(100 * paper.theta0 / 41, rel=1e-12)  # 10**(20/10) theta0/K


def test_the_calibration_runs_the_model_the_demo_runs(demo):
    # the thresholds' null runs go through the same SKFs, transition included
    from skf_ref.study._demo import _methods

    priors = (demo.settings["theta0"], demo.settings["q"], demo.settings["transition"])
    setting = {k: demo.settings[k] for k in ("exponent", "smoother", "standardize")}
    runs = {"skf": (priors, {**setting, "n_orient": 3})}
    present = demo.simulations["present"]
    skf = _methods(demo.head, present, runs, sloreta=None)["skf"]
    np.testing.assert_array_equal(skf(present.Y), demo.estimates["skf", "present"])


def test_ep_snr_db_runs_the_papers_random_walk_instead():
    walk = run_demo(**SMALL, ep_snr_db=0.0, verbose=False)
    skf, settings = walk.reconstructions["skf", "present"], walk.settings
    assert settings["evolution_prior"] == "random walk" and skf.transition == 1.0
    assert settings["time_constant_ms"] is None and not settings["priors_chosen_by_the_data"]
    assert skf.q == pytest.approx(skf.theta0 / 41, rel=1e-12)  # EP-SNR 0 dB: theta0 / K


@pytest.mark.slow
def test_nothing_is_written_without_a_folder_and_everything_with_one(demo, tmp_path):
    from skf_ref.study._demo import write

    write(demo, tmp_path / "new")
    assert sorted(p.name for p in (tmp_path / "new").iterdir()) == sorted(OUTPUTS)


def test_progress_goes_to_the_log_unless_quiet(quiet_run, capfd):
    assert quiet_run[1] == ""  # the fixture's run, quiet
    run_demo(**SMALL, verbose=True)
    err = capfd.readouterr().err
    assert "head: 4-shell sphere, volume grid" in err and "SKF and sLORETA:" in err


def test_bad_input_names_the_parameter_before_any_work(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(skf_ref.InputError, match="out must be a folder"):
        run_demo(tmp_path / "file" / "sub", **SMALL)
    with pytest.raises(skf_ref.InputError, match="head must be one of"):
        run_demo(head="fem")
    with pytest.raises(skf_ref.InputError, match="n_positions sizes the sphere's volume grid"):
        run_demo(head="sphere", n_positions=500)
    with pytest.raises(skf_ref.InputError, match="verbose must be"):
        run_demo(**SMALL, verbose="loud")
    with pytest.raises(skf_ref.InputError, match="give ep_snr_db .* or time_constant_ms .*"):
        run_demo(tmp_path / "out", **SMALL, ep_snr_db=20.0, time_constant_ms=30.0)
    with pytest.raises(skf_ref.InputError, match="time_constant_ms must be > 0"):
        run_demo(tmp_path / "out", **SMALL, time_constant_ms=0)
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_on_cortex_and_thalamus_detection_is_the_level_against_a_calibrated_threshold(tmp_path):
    from skf_ref.study._detection import thalamic_level
    from skf_ref.study._sources import position_structures

    demo = run_demo(tmp_path / "out", head="sphere", source_space="anatomical", verbose=False)
    thalamus = position_structures(demo.head) == "thalamus"
    peak = int(demo.simulations["present"].truth.peak_indices[0])
    for (key, data), amplitude in demo.estimates.items():
        column = demo.metrics[f"{key}, {data}"]
        level = float(thalamic_level(amplitude[:, peak], thalamus))
        assert column["thalamic_level"] == pytest.approx(level, rel=1e-12)
        assert column["detection_threshold"] > 0
        assert column["deep_detected_calibrated"] == (level > column["detection_threshold"])
    columns = (tmp_path / "out" / "metrics_columns.csv").read_text()
    assert "deep_detected_calibrated" in columns and "comparison.png" in OUTPUTS
