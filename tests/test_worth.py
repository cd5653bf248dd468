"""The study of the SKF's worth, v2 (validation/reproduce/worth): statistics, the rule, and
the exact responses of a linear method on a random model.

``tests/test_worth_study.py`` checks the same sums on a head, against the methods run on the
study's own data sets.
"""

import numpy as np
import pandas as pd
import pytest

from validation.reproduce.worth import design, intervals, rule
from validation.reproduce.worth.design import SNRS, SKFSetting, Static
from validation.reproduce.worth.linear import noise_parts, signal_parts, skf_window
from validation.reproduce.worth.skf import Prepared

#: Sums of exact responses against the method run on the data: rounding only.
SUM_RTOL = 1e-9


@pytest.fixture(scope="module")
def model():
    rng = np.random.default_rng(7)
    L = rng.standard_normal((6, 12 * 3))
    return L - L.mean(axis=0), rng


@pytest.mark.parametrize("smoother", ["none", "rts-standardized", "rts-state"])
def test_responses_add_up_to_the_skf_on_any_data(model, smoother):
    L, rng = model
    setting = SKFSetting(1.25, smoother, "column", 0.0, 0.0)
    n_times = 7
    prepared = Prepared(L, setting.priors, n_times)
    wave = np.hanning(n_times + 2)[1:-1]
    samples, near = (2, 4), np.arange(6)

    def outputs(Y):
        return prepared.z(Y, setting)

    at, near_part = signal_parts(outputs, {"s": wave}, samples, near, L.shape[0])
    pool = rng.standard_normal((2, L.shape[0], n_times))
    noise_at, noise_near = noise_parts(outputs, pool, samples, near)
    g = rng.standard_normal(L.shape[0])
    direct = outputs(np.outer(g, wave) + pool[1])
    for t in samples:
        summed = at["s", t] @ g + noise_at[t][:, 1]
        assert np.allclose(summed, direct[:, t], rtol=SUM_RTOL, atol=SUM_RTOL * abs(direct).max())
    summed = near_part["s"] @ g + noise_near[:, :, 1]
    assert np.allclose(summed, direct[near].T, rtol=SUM_RTOL, atol=SUM_RTOL * abs(direct).max())


def test_the_window_is_the_filters_impulse_response_and_sums_to_one(model):
    L, rng = model
    prepared = Prepared(L, (0.0, 0.0), 9)
    u = rng.standard_normal(L.shape[0])
    h = skf_window(prepared, u, smooths=False)
    assert np.allclose(h.sum(axis=1), 1.0)
    assert np.allclose(np.triu(h, 1), 0.0, atol=1e-12)  # the filter does not see the future
    assert (np.diag(h) > 0).all()
    smoothed = skf_window(prepared, u, smooths=True)
    assert np.allclose(smoothed.sum(axis=1), 1.0)
    assert np.abs(np.triu(smoothed, 1)).max() > 1e-3  # the smoother does


# --------------------------------------------------------------------------- statistics


def test_clopper_pearson_is_exact_at_the_ends():
    low, high = intervals.clopper_pearson(0, 10)
    assert low == 0.0 and high == pytest.approx(1 - 0.025 ** (1 / 10))
    low, high = intervals.clopper_pearson(10, 10)
    assert high == 1.0 and low == pytest.approx(0.025 ** (1 / 10))


def test_newcombes_interval_is_informative_at_the_ceiling_and_mirrors():
    area, low, high = intervals.newcombe_auc(np.arange(20.0) + 100, np.arange(20.0))
    assert area == 1.0 and high == 1.0 and 0.8 < low < 1.0
    rng = np.random.default_rng(0)
    a, b = rng.normal(1, 1, 30), rng.normal(0, 1, 40)
    area, low, high = intervals.newcombe_auc(a, b)
    mirrored = intervals.newcombe_auc(b, a)
    assert mirrored == pytest.approx((1 - area, 1 - high, 1 - low))
    assert low < area < high


def test_the_auc_counts_ties_half():
    assert intervals.auc([1.0, 2.0], [0.0, -np.inf]) == 1.0
    assert intervals.auc([0.0], [0.0]) == 0.5


def test_the_median_interval_holds_the_median_with_its_coverage():
    from scipy.stats import binom

    x = np.arange(1.0, 69.0)
    median, low, high = intervals.median_interval(x)
    k = int(low)
    assert median == 34.5 and high == 69 - k
    assert 1 - 2 * binom.cdf(k - 1, 68, 0.5) >= 0.95
    assert 1 - 2 * binom.cdf(k, 68, 0.5) < 0.95


def test_holm_adjusts_step_down_and_keeps_order():
    p = np.array([0.04, 0.001, 0.03, 0.5])
    assert np.allclose(intervals.holm(p), [0.09, 0.004, 0.09, 0.5])


# --------------------------------------------------------------------------- the rule


def _inputs(th30=8.0, in_thal=0.9, tpr20=0.9, error=10.0):
    values = {key: error for key in rule._ERRORS}  # noqa: SLF001
    values["lone_thalamic_error", 30.0] = th30
    values["lone_thalamic_own", 30.0] = in_thal
    values.update({("true_1", s): tpr20 for s in SNRS})
    return values


def test_the_rule_takes_the_lowest_error_among_those_meeting_every_criterion():
    a = SKFSetting(0.5, "none", "column", 20.0, 0.0)
    b = SKFSetting(1.25, "rts-standardized", "column", 20.0, 0.0)
    c = SKFSetting(0.5, "rts-state", "column", 0.0, 0.0)
    reference = _inputs(error=12.0)
    chosen, met_all, table = rule.choose_default(
        {a: _inputs(error=11.0), b: _inputs(th30=30.0, error=9.0), c: _inputs(error=9.5)},
        reference,
    )
    assert chosen == c and met_all
    assert not table.set_index("setting").loc[b, "r1"]


def test_rule_ties_within_1_mm_go_to_detection_then_simplicity():
    plain = SKFSetting(0.5, "none", "column", 20.0, 0.0)
    smoothed = SKFSetting(0.5, "rts-state", "column", 20.0, 0.0)
    reference = _inputs(error=20.0)
    chosen, _, _ = rule.choose_default(
        {smoothed: _inputs(error=10.0), plain: _inputs(error=10.9)}, reference
    )
    assert chosen == plain
    chosen, _, _ = rule.choose_default(
        {smoothed: _inputs(error=10.0, tpr20=0.95), plain: _inputs(error=10.9)}, reference
    )
    assert chosen == smoothed


def test_without_a_candidate_meeting_all_the_rule_takes_the_most_met():
    a = SKFSetting(0.5, "none", "column", 20.0, 0.0)
    b = SKFSetting(1.0, "none", "column", 20.0, 0.0)
    reference = _inputs(error=0.5)  # R3 fails for both
    chosen, met_all, _ = rule.choose_default(
        {a: _inputs(tpr20=0.5, error=6.0), b: _inputs(error=30.0)}, reference
    )
    assert chosen == b and not met_all


def test_criteria_name_every_error_beyond_elorettas_margin():
    values, reference = _inputs(error=10.0), _inputs(error=10.0)
    values["deep_error", 20.0] = 15.0 + 1e-9
    judged = rule.criteria(values, reference)
    assert judged.met == (True, True, False)
    assert [key for key, _, _ in judged.worse] == [("deep_error", 20.0)]


def test_the_candidates_are_the_64_settings_and_the_package_runs_each():
    from validation.reproduce.worth.skf import Prepared

    everything = design.candidates()
    assert len(everything) == 64 == len({s.key for s in everything})
    assert set(design.NAMED.values()) <= set(everything)
    rng = np.random.default_rng(34)
    L = rng.standard_normal((8, 12))  # 4 positions x 3 orientations
    Y = rng.standard_normal((8, 5))
    for priors in design.CANDIDATE_PRIORS:
        prepared = Prepared(L, priors, 5)
        for setting in (s for s in everything if s.priors == priors):
            z = prepared.z(Y, setting)
            assert z.shape == (12, 5) and np.isfinite(z).all(), setting.label


def test_static_methods_keys_and_labels_are_distinct():
    keys = {Static(m, r).key for m in design.STATIC_METHODS for r in design.LAMBDA2}
    assert len(keys) == 8


def test_summaries_calibrate_on_the_nulls_and_count_above():
    from validation.reproduce.worth.summary import summarize, thresholds

    nulls = pd.DataFrame(
        dict(kind=["noise"] * 20 + ["cortical"] * 20, index=list(range(40)), snr_db=20.0,
             level=np.r_[np.arange(20.0), np.arange(20.0) * 2], ratio_db=0.0)
    )  # fmt: skip
    levels = thresholds(nulls)
    assert levels == {20.0: 38.0}
    configs = pd.DataFrame(
        dict(config=range(4), snr_db=20.0, moment=1.0, level=[10.0, 38.0, 39.0, 50.0],
             ratio_db=0.0, deep_error_mm=5.0, superficial_error_mm=6.0, deep_r=0.5)
    )  # fmt: skip
    summary = summarize(dict(nulls=nulls, configurations=configs), levels).set_index("quantity")
    assert summary.loc["true_1", "value"] == 0.5
    assert summary.loc["false_cortical", "value"] == 0.0


def test_the_rule_s_text_says_the_defaults_must_follow_priors_not_the_package_s():
    from types import SimpleNamespace

    from validation.reproduce.worth.design import SKFSetting
    from validation.reproduce.worth.text_rule import PACKAGE_PRIORS, rule_text

    other = 20.0 if PACKAGE_PRIORS[0] != 20.0 else 0.0
    for ep, follows in ((other, True), (PACKAGE_PRIORS[0], False)):
        setting = SKFSetting(0.5, "none", "position", ep, PACKAGE_PRIORS[1])
        table = pd.DataFrame(dict(setting=[setting], met=[3], mean_error_mm=[8.6],
                                  mean_true=[1.0], r1=[True], r2=[True], r3=[True]))  # fmt: skip
        text = rule_text(SimpleNamespace(rule=(setting, True, table)))
        expected = f"are not the package's default priors (EP {PACKAGE_PRIORS[0]:g} / PM"
        assert (expected in text) == follows
