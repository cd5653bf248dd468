"""The v2 decision rules on hand-made tables whose verdicts are known by construction."""

import numpy as np
import pandas as pd
import pytest

from validation.reproduce.rules_v2 import (
    deep_excess,
    evaluate_v2,
    rule_v2_f1,
    rule_v2_f2,
    rule_v2_f3,
    rule_v2_f4,
    rule_v2_f5,
    rule_v2_f6,
)
from validation.reproduce.settings import EXPONENTS, NOISE_LEVELS, TUNED_PRIOR, VERDICTS

SEEDS = 4
TRUE_RATIO = 0.25


def rows(snr, ep, pm, scores, exponent=0.5, smoother="none", **columns):
    """One row per seed; both peak errors equal the score; columns broadcast or per seed."""
    n = len(scores)
    values = dict(
        deep_detected=True,
        superficial_detected=True,
        deep_region_db=0.0,
        deep_region_at_superficial_peak_db=-3.0,
        deep_corr=0.5,
        superficial_corr=0.5,
        log_likelihood=0.0,
        deep_max_at_deep_peak=1.0,
        deep_max_at_superficial_peak=0.5,
    )
    values.update(columns)
    values = {k: list(v) if np.ndim(v) else [v] * n for k, v in values.items()}
    ratio = np.array(values["deep_max_at_superficial_peak"]) / values["deep_max_at_deep_peak"]
    values.setdefault("echo", list(ratio - TRUE_RATIO))
    return pd.DataFrame(
        dict(
            snr_db=snr,
            ep_snr_db=ep,
            pm_snr_db=pm,
            exponent=exponent,
            smoother=smoother,
            seed=range(n),
            deep_error_mm=scores,
            superficial_error_mm=scores,
            **values,
        )
    )


def corners(snr, means, per_seed=None, **columns):
    """The tuning 2 x 2 at one level; ``means`` (EP, PM) -> mean, seeds spread by +-1.5."""
    offsets = np.array([-1.5, -0.5, 0.5, 1.5])
    frames = []
    for key, mean in means.items():
        scores = per_seed[key] if per_seed and key in per_seed else mean + offsets
        frames.append(rows(snr, *key, list(scores), **columns))
    return pd.concat(frames, ignore_index=True)


def means(m00, m20_0, m0_20, m20_20):
    return {(0.0, 0.0): m00, (20.0, 0.0): m20_0, (0.0, 20.0): m0_20, (20.0, 20.0): m20_20}


def verdicts(criteria):
    return [ok for _, ok in criteria]


class TestF1:
    def test_a_margin_beyond_one_se_holds(self):
        table = corners(10.0, means(10, 40, 20, 50))
        finding = rule_v2_f1(table)
        assert verdicts(finding.criteria) == [True, True] and finding.verdict == "reproduced"

    def test_a_difference_within_one_se_is_a_tie(self):
        # paired differences (EP 20, PM 0) - (EP 0, PM 20): +3, -2, +2, -1 -> mean 0.5, SE 1.19
        per_seed = {(20.0, 0.0): [30, 25, 32, 27], (0.0, 20.0): [27, 27, 30, 28]}
        table = corners(10.0, means(10, 28.5, 28, 50), per_seed)
        finding = rule_v2_f1(table)
        assert verdicts(finding.criteria) == [True, False] and finding.verdict == "partly"
        assert "tie within one SE" in finding.measured

    def test_v1_would_have_counted_the_tie(self):
        from validation.reproduce.rules import rule_f1

        per_seed = {(20.0, 0.0): [30, 25, 32, 27], (0.0, 20.0): [27, 27, 30, 28]}
        table = corners(10.0, means(10, 28.5, 28, 50), per_seed)
        assert rule_f1(table).verdict == "reproduced"


class TestF2:
    def table(self, at_20):
        return pd.concat([corners(10.0, means(20, 80, 60, 90)), corners(20.0, at_20)])

    def test_smaller_relative_spread_holds(self):
        # 10 dB: (90 - 20) / 62.5 = 1.12; 20 dB: (24 - 10) / 15.5 = 0.90
        finding = rule_v2_f2(self.table(means(10, 14, 14, 24)))
        assert verdicts(finding.criteria) == [True, True]

    def test_a_smaller_absolute_but_larger_relative_spread_does_not_hold(self):
        # 20 dB absolute spread 55 < 70 at 10 dB, relative (60 - 5) / 28.75 = 1.91 > 1.12
        finding = rule_v2_f2(self.table(means(5, 25, 25, 60)))
        assert verdicts(finding.criteria) == [True, False] and finding.verdict == "partly"

        from validation.reproduce.rules import rule_f2

        assert rule_f2(self.table(means(5, 25, 25, 60))).verdict == "reproduced"


class TestF3:
    def test_three_measures_each_judged(self):
        table = corners(30.0, means(10, 12, 14, 20))  # score: (0, 0) best
        corr = {(20.0, 0.0): 0.9}  # correlation: (EP 20, PM 0) best
        loglik = {(0.0, 20.0): 5.0}  # log-likelihood: (EP 0, PM 20) best
        table["deep_corr"] = [
            corr.get((ep, pm), 0.5)
            for ep, pm in zip(table.ep_snr_db, table.pm_snr_db, strict=True)
        ]
        table["log_likelihood"] = [
            loglik.get((ep, pm), 0.0)
            for ep, pm in zip(table.ep_snr_db, table.pm_snr_db, strict=True)
        ]
        finding = rule_v2_f3(table)
        assert verdicts(finding.criteria) == [False, True, True]
        assert finding.verdict == "partly"

    def test_none_is_not_reproduced(self):
        assert rule_v2_f3(corners(30.0, means(10, 12, 14, 20))).verdict == "not reproduced"


def control_of(table, deep_at_superficial_peak):
    """The superficial-only control of ``table``: only the deep region at 2.5 ms matters."""
    return table.assign(deep_max_at_superficial_peak=deep_at_superficial_peak)


class TestExcess:
    def test_the_control_is_subtracted_and_the_truth_too(self):
        run = rows(10.0, 0.0, 0.0, [1.0, 1.0], deep_max_at_superficial_peak=[0.9, 0.6])
        joined = deep_excess(run, control_of(run, [0.4, 0.4]), 10.0, 0.0, 0.0, 0.5, "none")
        np.testing.assert_allclose(joined["excess"], [0.9 - 0.4 - 0.25, 0.6 - 0.4 - 0.25])
        np.testing.assert_allclose(joined["spread_share"], [0.4 / 0.9, 0.4 / 0.6])

    def test_a_missing_control_seed_is_named(self):
        run = rows(10.0, 0.0, 0.0, [1.0, 1.0])
        with pytest.raises(ValueError, match=r"the control lacks seeds \[1\]"):
            deep_excess(run, run.iloc[:1], 10.0, 0.0, 0.0, 0.5, "none")


class TestF4:
    def tables(self, deep_at_25, control_at_25):
        frames = [corners(snr, means(10, 40, 20, 50)) for snr in NOISE_LEVELS]
        table = pd.concat(frames, ignore_index=True)
        best = (table["ep_snr_db"] == 0) & (table["pm_snr_db"] == 0)
        table.loc[best, "deep_max_at_superficial_peak"] = deep_at_25
        table["echo"] = table["deep_max_at_superficial_peak"] - TRUE_RATIO
        return table, {"superficial": control_of(table, control_at_25)}

    def test_an_echo_that_is_the_superficial_spread_is_not_present(self):
        # v1 sees a large echo (0.9 - 0.25); the control holds 0.8 of it: excess -0.15
        table, controls = self.tables(0.9, 0.8)
        assert rule_v2_f4(table, controls).verdict == "not reproduced"
        from validation.reproduce.rules import rule_f4

        assert rule_f4(table).verdict == "reproduced"

    def test_an_echo_beyond_the_spread_is_present(self):
        table, controls = self.tables(0.9, 0.2)
        finding = rule_v2_f4(table, controls)
        assert finding.verdict == "reproduced" and "deep excess 0.450" in finding.measured


class TestF5AndF6:
    def table(self, excess_15, separated_excess):
        ep, pm = TUNED_PRIOR
        frames = []
        scores = {1.0: 30.0, 1.25: 10.0, 1.5: 25.0, 0.5: 5.0}
        for snr in NOISE_LEVELS:
            for exponent in EXPONENTS:
                frames.append(rows(snr, ep, pm, [50.0] * SEEDS, exponent, deep_region_db=-2.0))
                at_25 = 0.25 + (excess_15 if exponent == 1.5 else separated_excess)
                frames.append(
                    rows(
                        snr,
                        ep,
                        pm,
                        [scores[exponent]] * SEEDS,
                        exponent,
                        "rts-standardized",
                        deep_region_db=-5.0,
                        deep_detected=[True, True, True, exponent != 1.0],
                        deep_max_at_superficial_peak=at_25 + 0.3,  # 0.3: the spread
                    )
                )
        table = pd.concat(frames, ignore_index=True)
        # without smoothing the deep region holds 0.5 beyond the spread: never separated
        plain = table["smoother"] == "none"
        table.loc[plain, "deep_max_at_superficial_peak"] = 0.25 + 0.5 + 0.3
        table["echo"] = table["deep_max_at_superficial_peak"] - TRUE_RATIO
        return table, {"superficial": control_of(table, 0.3)}

    def test_overemphasis_and_separation_measured_beyond_the_spread(self):
        table, controls = self.table(excess_15=0.2, separated_excess=-0.05)
        f5 = rule_v2_f5(table, controls)
        assert verdicts(f5.criteria) == [True, True, False, True]
        assert rule_v2_f6(table, controls).verdict == "reproduced"

    def test_no_separation_when_the_deep_region_exceeds_the_truth(self):
        table, controls = self.table(excess_15=-0.1, separated_excess=0.1)
        assert verdicts(rule_v2_f5(table, controls).criteria)[3] is False
        assert rule_v2_f6(table, controls).verdict == "not reproduced"


def test_evaluate_v2_gives_six_findings():
    f5, controls = TestF5AndF6().table(0.2, -0.05)
    frames = [corners(snr, means(10, 40, 20, 50)) for snr in NOISE_LEVELS] + [f5]
    table = pd.concat(frames, ignore_index=True).drop_duplicates(
        ["snr_db", "ep_snr_db", "pm_snr_db", "exponent", "smoother", "seed"]
    )
    controls = {"superficial": control_of(table, 0.3), "deep": table}
    findings = evaluate_v2(table, controls)
    assert [f.number for f in findings] == [1, 2, 3, 4, 5, 6]
    assert all(f.verdict in VERDICTS for f in findings)
    assert "deep-only echo" in findings[3].measured
