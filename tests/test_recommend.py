"""The rule that picks the recommended SKF setting (validation/reproduce/recommend.py)."""

import json
from pathlib import Path

import pandas as pd

from validation.reproduce.recommend import MIN_AUC, auc, recommend

COLUMNS = ["exponent", "smoother", "snr_db", "deep_auc", "superficial_auc", "error_mm"]
LEVELS = (10.0, 20.0, 30.0)
REPORT = Path(__file__).resolve().parent.parent / "validation" / "report"


def _table(candidates):
    """candidates: (exponent, smoother, deep AUC, superficial AUC, error) at every level."""
    rows = [(e, s, d, u, err, lvl) for e, s, d, u, err in candidates for lvl in LEVELS]
    table = pd.DataFrame(rows, columns=[*COLUMNS[:2], *COLUMNS[3:], "snr_db"])
    return table[COLUMNS]


def test_auc_counts_ties_half_and_handles_minus_infinity():
    assert auc([1.0, 2.0], [0.0, -float("inf")]) == 1.0
    assert auc([0.0], [0.0]) == 0.5
    assert auc([-float("inf")], [-float("inf"), 1.0]) == 0.25


def test_smallest_error_among_admissible():
    table = _table(
        [
            (0.5, "none", 0.95, 0.95, 12.0),
            (1.0, "none", 0.95, 0.99, 8.0),
            (1.25, "rts-standardized", 0.3, 1.0, 2.0),  # best error, not admissible
        ]
    )
    assert recommend(table) == ({"exponent": 1.0, "smoother": None}, True)


def test_the_bar_reads_20_and_30_db_only():
    table = _table([(1.0, "none", 0.95, 0.95, 8.0), (0.5, "none", 0.95, 0.95, 10.0)])
    table.loc[(table["exponent"] == 1.0) & (table["snr_db"] == 10.0), "deep_auc"] = 0.1
    assert recommend(table)[0] == {"exponent": 1.0, "smoother": None}
    table.loc[(table["exponent"] == 1.0) & (table["snr_db"] == 30.0), "deep_auc"] = MIN_AUC - 1e-9
    assert recommend(table)[0] == {"exponent": 0.5, "smoother": None}


def test_ties_go_to_auc_then_simplicity():
    tied = [(1.0, "rts-state", 0.95, 0.95, 5.0), (0.5, "none", 0.95, 0.95, 5.5)]
    assert recommend(_table(tied))[0] == {"exponent": 0.5, "smoother": None}
    better_auc = [(1.0, "rts-state", 0.99, 0.95, 5.0), (0.5, "none", 0.95, 0.95, 5.5)]
    assert recommend(_table(better_auc))[0] == {"exponent": 1.0, "smoother": "rts-state"}


def test_none_admissible_takes_the_best_worse_auc():
    table = _table([(0.5, "none", 0.8, 0.95, 9.0), (1.5, "rts-state", 0.6, 0.99, 1.0)])
    assert recommend(table) == ({"exponent": 0.5, "smoother": None}, False)


def test_package_default_is_the_reports_recommendation():
    import skf_ref

    recorded = json.loads((REPORT / "recommendation.json").read_text())
    assert recorded["setting"] == dict(skf_ref.RECOMMENDED_SETTING)


def test_every_entry_point_defaults_to_the_recommended_setting():
    import inspect

    import skf_ref
    from skf_ref.cli import build_parser
    from skf_ref.study.demo import run_demo

    for function in (skf_ref.reconstruct, skf_ref.apply_skf, run_demo):
        defaults = inspect.signature(function).parameters
        assert {k: defaults[k].default for k in ("exponent", "smoother")} == dict(
            skf_ref.RECOMMENDED_SETTING
        ), function.__name__
    commands = build_parser()._subparsers._group_actions[0].choices
    for command in ("demo", "reconstruct"):
        exponent, smoother = (commands[command].get_default(k) for k in ("exponent", "smoother"))
        smoother = None if smoother == "none" else smoother
        assert (exponent, smoother) == tuple(skf_ref.RECOMMENDED_SETTING.values()), command


def test_the_routes_that_know_the_orientations_default_to_the_rules_standardization():
    # The rule's setting (validation/report/REPORT.md): position standardization, EP-SNR and
    # PM-SNR 0 dB. An array does not say which columns form a position: reconstruct keeps
    # "column" there; every MNE route takes n_orient from the forward and the rule's form.
    import inspect

    import skf_ref
    from skf_ref.cli import build_parser
    from skf_ref.study.demo import run_demo

    def default(function, name):
        return inspect.signature(function).parameters[name].default

    assert default(skf_ref.reconstruct, "standardize") == "column"
    assert default(run_demo, "standardize") == "position"
    routes = (skf_ref.apply_skf, skf_ref.apply_skf_epochs, skf_ref.apply_skf_raw)
    for function in (*routes, skf_ref.SKFOperator.reconstruct):  # the operator decides:
        assert default(function, "standardize") is None, function.__qualname__
    # EP-SNR not given (None): the random walk at DEFAULT_EP_SNR_DB, 0 dB (a time constant
    # given instead is the AR(1) prior)
    from skf_ref.method._priors import DEFAULT_EP_SNR_DB

    assert default(skf_ref.make_skf_operator, "ep_snr_db") is None and DEFAULT_EP_SNR_DB == 0.0
    assert default(skf_ref.make_skf_operator, "time_constant_ms") is None
    assert default(skf_ref.make_skf_operator, "pm_snr_db") == 0.0
    assert default(run_demo, "ep_snr_db") == 0.0 and default(run_demo, "pm_snr_db") == 0.0
    commands = build_parser()._subparsers._group_actions[0].choices
    for command, ep in (("demo", 0.0), ("reconstruct", None)):  # None: 0 dB, as above
        priors = [commands[command].get_default(k) for k in ("pm_snr_db", "ep_snr_db")]
        assert priors == [0.0, ep], command
    assert commands["demo"].get_default("standardize") == "position"
