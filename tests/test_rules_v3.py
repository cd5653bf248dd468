"""The v3 decision rules on hand-made tables whose verdicts are known by construction.

Only the columns a rule reads matter; every other column keeps a neutral value. The deep
region's maximum at the deep peak is 1 throughout, so the deep excess of a run is
``D(2.5) - S(2.5) - 0.25`` with ``D`` from the run and ``S`` from the superficial-only control.
"""

from itertools import product

import numpy as np
import pandas as pd
import pytest

from validation.reproduce.rules_v2 import evaluate_v2
from validation.reproduce.rules_v3 import (
    UNDETERMINED,
    VERDICTS_V3,
    between,
    evaluate_v3,
    rule_v3_f4,
    rule_v3_f6,
    verdict_v3,
)
from validation.reproduce.settings import (
    CORNERS,
    EXPONENTS,
    NOISE_LEVELS,
    SMOOTHED,
    TUNED_PRIOR,
    TUNING,
)

SEEDS = 4
TRUE_RATIO = 0.25
#: Per-seed offsets that keep a bound's mean where it is set but give it a spread (SE > 0).
WOBBLE = np.array([-0.01, 0.0, 0.0, 0.01])


def rows(snr, ep, pm, exponent, smoother, score=20.0, **columns):
    """One setting's runs, one per seed; ``columns`` broadcast or given per seed."""
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
        max_at_superficial_peak=1.0,
    )
    values.update(columns)
    values = {k: np.broadcast_to(v, SEEDS).tolist() for k, v in values.items()}
    ratio = np.divide(values["deep_max_at_superficial_peak"], values["deep_max_at_deep_peak"])
    values.setdefault("echo", list(ratio - TRUE_RATIO))
    return pd.DataFrame(
        dict(
            snr_db=snr,
            ep_snr_db=ep,
            pm_snr_db=pm,
            exponent=exponent,
            smoother=smoother,
            seed=range(SEEDS),
            deep_error_mm=score,
            superficial_error_mm=score,
            **values,
        )
    )


def _set(table, where, **columns):
    """``table`` with ``columns`` set on the rows where ``where`` (a boolean mask) holds."""
    table = table.copy()
    for column, value in columns.items():
        table.loc[where, column] = value
    return table


def _setting(table, snr, ep, pm, exponent, smoother):
    return (
        (table["snr_db"] == snr)
        & (table["ep_snr_db"] == ep)
        & (table["pm_snr_db"] == pm)
        & (table["exponent"] == exponent)
        & (table["smoother"] == smoother)
    )


def verdicts(criteria):
    return [ok for _, ok in criteria]


@pytest.mark.parametrize(
    ("lower", "upper", "expected"),
    [(True, True, True), (False, False, False), (True, False, None), (False, True, None)],
)
def test_a_level_is_undetermined_where_the_bounds_disagree(lower, upper, expected):
    assert between(lower, upper) is expected


@pytest.mark.parametrize(
    ("levels", "expected"),
    [
        ([True, True, True], "reproduced"),
        ([True, False, False], "partly"),
        ([False, False, False], "not reproduced"),
        ([True, False, None], "partly"),  # partly whichever way the undetermined level goes
        ([True, True, None], UNDETERMINED),  # reproduced or partly
        ([False, False, None], UNDETERMINED),  # partly or not reproduced
        ([None, None, None], UNDETERMINED),
    ],
)
def test_levels_combine_into_a_verdict(levels, expected):
    assert verdict_v3(levels) == expected


class TestF4:
    """The echo at each level's best tuning cell (EP 0, PM 0 here), on both bounds."""

    def tables(self, bounds):
        """``bounds``: per noise level, (lower bound present, upper bound present)."""
        frames = [
            rows(snr, ep, pm, *TUNING, score=10.0 if (ep, pm) == (0.0, 0.0) else 30.0)
            for snr in NOISE_LEVELS
            for ep, pm in CORNERS
        ]
        table = pd.concat(frames, ignore_index=True)
        superficial, deep = table.copy(), table.copy()
        for snr, (lower, upper) in bounds.items():
            at = _setting(table, snr, 0.0, 0.0, *TUNING)
            # deep excess = 0.5 - S(2.5) - 0.25: +0.15 present, -0.2 absent
            superficial = _set(
                superficial, at, deep_max_at_superficial_peak=(0.1 if lower else 0.45) + WOBBLE
            )
            deep = _set(deep, at, echo=(0.2 if upper else -0.1) + WOBBLE)
        return table, {"superficial": superficial, "deep": deep}

    def judge(self, bounds):
        return rule_v3_f4(*self.tables(bounds))

    def test_both_bounds_present_at_every_level_is_reproduced(self):
        finding = self.judge({snr: (True, True) for snr in NOISE_LEVELS})
        assert finding.verdict == "reproduced" and all(verdicts(finding.criteria))

    def test_both_bounds_absent_at_every_level_is_not_reproduced(self):
        finding = self.judge({snr: (False, False) for snr in NOISE_LEVELS})
        assert finding.verdict == "not reproduced" and not any(verdicts(finding.criteria))

    def test_only_the_upper_bound_present_is_undetermined(self):
        # the committed report's case: the deep-only control shows an echo, the excess does not
        finding = self.judge({snr: (False, True) for snr in NOISE_LEVELS})
        assert finding.verdict == UNDETERMINED
        assert verdicts(finding.criteria) == [False, True] * 3
        assert finding.measured.count("undetermined between the bounds") == 3
        assert "lower bound, deep excess -0.200" in finding.measured
        assert "upper bound, deep-only echo 0.200" in finding.measured

    def test_the_lower_bound_binds_on_its_own(self):
        finding = self.judge({10.0: (False, True), 20.0: (True, True), 30.0: (True, True)})
        assert verdicts(finding.criteria)[0] is False and finding.verdict == UNDETERMINED

    def test_the_upper_bound_binds_on_its_own(self):
        finding = self.judge({10.0: (True, False), 20.0: (True, True), 30.0: (True, True)})
        assert verdicts(finding.criteria)[1] is False and finding.verdict == UNDETERMINED

    def test_a_level_present_and_one_absent_is_partly_whatever_the_third(self):
        finding = self.judge({10.0: (True, True), 20.0: (False, False), 30.0: (False, True)})
        assert finding.verdict == "partly"

    def test_a_missing_deep_only_seed_is_named(self):
        table, controls = self.tables({snr: (True, True) for snr in NOISE_LEVELS})
        controls["deep"] = controls["deep"][controls["deep"]["seed"] != 2]
        with pytest.raises(ValueError, match=r"the deep-only control lacks seeds \[2\]"):
            rule_v3_f4(table, controls)


class TestF6:
    """EP 20, PM 0, exponent 1.25: rts-standardized against no smoothing at each level."""

    def tables(self, levels):
        """``levels``: per noise level, a dict of what holds smoothed.

        Keys: ``lower`` (smoothing lowers the deep excess), ``upper`` (it lowers the deep-only
        echo), ``detected`` (both sources detected) and ``alone_low`` (the deep source alone
        more than 6 dB below the maximum at 2.5 ms); each True unless given.
        """
        ep, pm = TUNED_PRIOR
        exponent, smoother = SMOOTHED
        frames = [
            rows(snr, ep, pm, exponent, label)
            for snr in NOISE_LEVELS
            for label in (smoother, "none")
        ]
        table = pd.concat(frames, ignore_index=True)
        # the spread S(2.5) = 0.3 everywhere; no smoothing: excess 0.6 - 0.3 - 0.25 = 0.05,
        # deep-only echo 0.1, the deep source alone at 2.5 ms 0.2 of the maximum (-14 dB)
        table = _set(table, table["smoother"] == "none", deep_max_at_superficial_peak=0.6)
        table["echo"] = table["deep_max_at_superficial_peak"] - TRUE_RATIO
        superficial = table.assign(deep_max_at_superficial_peak=0.3)
        deep = table.assign(echo=0.1, deep_max_at_superficial_peak=0.2)
        for snr, spec in levels.items():
            holds = dict(dict(lower=True, upper=True, detected=True, alone_low=True), **spec)
            at = _setting(table, snr, ep, pm, exponent, smoother)
            d25 = (0.5 if holds["lower"] else 0.7) + WOBBLE  # excess -0.05 or +0.15
            table = _set(table, at, deep_max_at_superficial_peak=d25, echo=d25 - TRUE_RATIO)
            table = _set(table, at, deep_detected=holds["detected"])
            deep = _set(
                deep,
                at,
                echo=0.0 if holds["upper"] else 0.2,
                deep_max_at_superficial_peak=0.2 if holds["alone_low"] else 0.8,  # -14, -1.9 dB
            )
        return table, {"superficial": superficial, "deep": deep}

    def judge(self, levels):
        return rule_v3_f6(*self.tables(levels))

    def test_suppressed_and_separated_at_every_level_is_reproduced(self):
        finding = self.judge({snr: {} for snr in NOISE_LEVELS})
        assert finding.verdict == "reproduced" and all(verdicts(finding.criteria))
        assert "deep excess in 4/4 seeds" in finding.measured
        assert "separated smoothed in 4/4 seeds" in finding.measured

    def test_neither_bound_lowered_is_not_reproduced(self):
        finding = self.judge({snr: dict(lower=False, upper=False) for snr in NOISE_LEVELS})
        assert finding.verdict == "not reproduced"
        assert verdicts(finding.criteria) == [False, False, True] * 3

    def test_the_lower_bound_alone_lowered_is_undetermined(self):
        finding = self.judge({snr: dict(upper=False) for snr in NOISE_LEVELS})
        assert finding.verdict == UNDETERMINED
        assert verdicts(finding.criteria) == [True, False, True] * 3
        assert finding.measured.count("undetermined between the bounds") == 3

    def test_the_upper_bound_alone_lowered_is_undetermined(self):
        finding = self.judge({snr: dict(lower=False) for snr in NOISE_LEVELS})
        assert finding.verdict == UNDETERMINED
        assert verdicts(finding.criteria) == [False, True, True] * 3

    def test_detection_binds_separation(self):
        finding = self.judge({10.0: dict(detected=False), 20.0: {}, 30.0: {}})
        assert verdicts(finding.criteria)[:3] == [True, True, False]
        assert finding.verdict == "partly"

    def test_the_deep_source_alone_within_6_db_binds_separation(self):
        finding = self.judge({10.0: {}, 20.0: dict(alone_low=False), 30.0: {}})
        assert verdicts(finding.criteria)[3:6] == [True, True, False]
        assert finding.verdict == "partly"

    def test_a_failed_separation_outweighs_disagreeing_bounds(self):
        finding = self.judge({snr: dict(upper=False, detected=False) for snr in NOISE_LEVELS})
        assert finding.verdict == "not reproduced"

    def test_the_seeds_must_pair(self):
        table, controls = self.tables({snr: {} for snr in NOISE_LEVELS})
        drop = (table["smoother"] == "none") & (table["seed"] == 3)
        with pytest.raises(ValueError, match="F6 pairs seeds"):
            rule_v3_f6(table[~drop], controls)


def test_evaluate_v3_is_v2_but_for_f4_and_f6():
    frames = [
        rows(snr, e, p, exponent, smoother, score=10.0 if (e, p) == (0.0, 0.0) else 30.0)
        for snr, (e, p), exponent, smoother in product(
            NOISE_LEVELS, CORNERS, EXPONENTS, ("none", SMOOTHED[1])
        )
    ]
    table = pd.concat(frames, ignore_index=True)
    controls = {
        "superficial": table.assign(deep_max_at_superficial_peak=0.3),
        "deep": table.assign(deep_max_at_superficial_peak=0.2),
    }
    v2, v3 = evaluate_v2(table, controls), evaluate_v3(table, controls)
    assert [f.number for f in v3] == [1, 2, 3, 4, 5, 6]
    assert all(f.verdict in VERDICTS_V3 for f in v3)
    for index in (0, 1, 2, 4):
        assert v3[index] == v2[index]
    assert "upper bound, deep-only echo" in v3[3].measured
    assert "deep source alone at 2.5 ms" in v3[5].measured
