"""The evidence study v3 (validation/reproduce): its designs, metrics and rule."""

import numpy as np
import pandas as pd
import pytest

from validation.reproduce import measure, rule
from validation.reproduce.design import (
    CANDIDATES,
    DESIGNS,
    PAPER,
    PREVIOUS,
    Setting,
    named,
)


def test_designs_peak_where_the_preregistration_says():
    d1, erp, ten = DESIGNS["D1"], DESIGNS["ERP"], DESIGNS["10Hz"]
    w = d1.waveforms()
    assert d1.times[d1.peak(w["deep"])] == pytest.approx(1.5e-3)
    assert d1.times[d1.peak(w["cortical"])] == pytest.approx(2.5e-3)
    w = erp.waveforms()
    assert erp.times[erp.peak(w["deep"])] == pytest.approx(0.100)
    assert erp.times[erp.peak(w["cortical"])] == pytest.approx(0.130)
    assert erp.n_times == 201 and erp.times[-1] == pytest.approx(0.350)
    w = ten.waveforms()
    lag = ten.peak(w["cortical"]) - ten.peak(w["deep"])
    assert abs(lag / ten.sfreq - 0.025) <= 1 / ten.sfreq  # a quarter period, to a sample
    assert np.all(w["deep"][ten.times < 0] == 0) and np.all(w["deep"][ten.times > 0.3] == 0)


def test_candidates_are_the_48_of_the_preregistration():
    assert len(set(CANDIDATES)) == 48
    assert PREVIOUS in CANDIDATES and PAPER not in CANDIDATES  # the paper's exponent is 1.25
    assert Setting("AR 30 ms", "position", "none").prior() == ("ar", 30.0)
    assert Setting("walk EP 20", "column", "none").prior() == ("walk", 20.0)
    n = named(Setting("AR 30 ms", "position", "none"))
    assert n["N4"] == Setting("AR auto", "position", "none")
    assert named(Setting("AR auto", "column", "none"))["N4"].dynamics == "AR 30 ms"


def _geometry():
    positions = np.array([[0.0, 0, 0], [0.01, 0, 0], [0.05, 0, 0], [-0.05, 0, 0]])
    return measure.Geometry(
        positions,
        thalamus=np.array([True, True, False, False]),
        left=np.array([False, False, False, True]),
        right=np.array([False, False, True, False]),
    )


def test_pair_metrics_on_a_map_with_a_known_answer():
    geometry, design = _geometry(), DESIGNS["ERP"]
    waves = design.waveforms()
    t_deep, t_cort = design.peak(waves["deep"]), design.peak(waves["cortical"])
    A = np.zeros((4, design.n_times))
    A[1] = np.abs(waves["deep"])  # the thalamic map peaks 10 mm from the source, on time
    A[2, t_cort] = 5.0  # the cortical source found exactly
    deep, cortical = np.array([0.0, 0, 0]), np.array([0.05, 0, 0])
    m = measure.pair(A, geometry, design, deep, cortical, (1.0, 1.0))
    assert m["deep error"] == pytest.approx(10.0)
    assert m["superficial error"] == pytest.approx(0.0)
    assert m["latency"] == 0.0 and m["r"] == pytest.approx(1.0)
    assert m["S"] == pytest.approx(1.0)
    # at the deep peak only position 1 holds mass; the truth's mass is mostly the deep source
    w = np.abs([waves["deep"][t_deep], waves["cortical"][t_deep]])
    expected = (w[0] * 10.0 + w[1] * 40.0) / w.sum()
    assert m["EMD"] == pytest.approx(expected)


def test_latency_counts_milliseconds():
    geometry, design = _geometry(), DESIGNS["ERP"]
    waves = design.waveforms()
    A = np.zeros((4, design.n_times))
    A[0] = np.roll(np.abs(waves["deep"]), 10)  # 10 samples late at 500 Hz
    m = measure.pair(A, geometry, design, np.zeros(3), np.array([0.05, 0, 0]), (1.0, 1.0))
    assert m["latency"] == pytest.approx(20.0)


def test_two_cortical_errors_stay_in_their_hemisphere():
    geometry, design = _geometry(), DESIGNS["2cortical"]
    A = np.zeros((4, design.n_times))
    A[0] = 9.0  # the thalamus's maximum is no hemisphere's
    A[2], A[3] = 1.0, 2.0
    m = measure.two(A, geometry, design, np.array([-0.05, 0, 0]), np.array([0.04, 0, 0]))
    assert m["left error"] == pytest.approx(0.0) and m["right error"] == pytest.approx(10.0)


def _summary(values):
    """A choice summary: (design, method) -> metrics, from ``{method: (deep error, ...)}``."""
    rows = []
    for method, (deep, detection) in values.items():
        for design in ("D1", "ERP"):
            rows.append(dict(design=design, method=method, **{
                "deep error": deep, "superficial error": 5.0, "EMD": 50.0,
                "detection": detection, "r": 0.8, "latency": 0.0,
            }))  # fmt: skip
    return pd.DataFrame(rows).set_index(["design", "method"])


def test_rule_prefers_meeting_every_design_to_a_smaller_error():
    good = Setting("AR 30 ms", "position", "none")
    sharp = Setting("walk EP 0", "column", "none")
    refs = {m: (10.0, 1.0) for m in rule.REFERENCES}
    summary = _summary({**refs, good.label: (14.0, 0.95), sharp.label: (2.0, 0.5)})
    default, table = rule.choose(summary, [sharp, good])
    assert default == good  # sharp is more precise but misses detection by > 10 points
    assert table.iloc[0]["designs_met"] == 2 and table.iloc[1]["designs_met"] == 0
    summary = _summary({**refs, good.label: (16.0, 0.95), sharp.label: (2.0, 0.5)})
    default, table = rule.choose(summary, [sharp, good])  # 16 > 10 + 5: neither meets
    assert default == sharp and table.iloc[0]["designs_met"] == 0


def test_rule_breaks_ties_by_simplicity():
    a = Setting("walk EP 0", "column", "none")
    b = Setting("AR 10 ms", "position", "rts-state")
    refs = {m: (10.0, 1.0) for m in rule.REFERENCES}
    summary = _summary({**refs, a.label: (10.0, 1.0), b.label: (10.0, 1.0)})
    assert rule.choose(summary, [b, a])[0] == a


def test_thresholds_are_the_larger_q95_of_the_choice_nulls():
    rows = pd.DataFrame(
        dict(set="choice", condition="c", design="D1", method="m",
             kind=["noise null"] * 20 + ["cortical null"] * 20,
             S=np.r_[np.arange(20.0), np.arange(20.0) / 2])
    )  # fmt: skip
    limits = rule.thresholds(rows)
    assert limits.loc[("m", "c", "D1")] == 19.0  # "higher" q95 of 0..19 is 19


@pytest.mark.slow
def test_quick_study_runs_and_resumes(tmp_path):
    from validation.reproduce.__main__ import main

    out, work = tmp_path / "report", tmp_path / "work"
    assert main(["--quick", "--out", str(out), "--work", str(work)]) == 0
    assert (out / "REPORT.md").read_text().startswith("# What the SKF is worth, v3")
    cells = sorted((work / "cells").glob("*.csv"))
    stamps = [c.stat().st_mtime_ns for c in cells]
    assert main(["--quick", "--out", str(out), "--work", str(work)]) == 0
    assert [c.stat().st_mtime_ns for c in cells] == stamps  # nothing recomputed
