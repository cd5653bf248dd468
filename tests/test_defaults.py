"""The package's defaults are the setting the study's rule chose, on every entry point.

The rule and its verdict are history now (validation/archive/report-v2/: the worth study v1's
``recommendation.json``, the worth study v2's ``REPORT.md``, "The default, by a rule committed
first"); these tests keep the package's defaults, and the recorded choice, tied together.
"""

import json
from pathlib import Path

ARCHIVE = Path(__file__).resolve().parent.parent / "validation" / "archive" / "report-v2"


def test_package_default_is_the_reports_recommendation():
    import skf_ref

    recorded = json.loads((ARCHIVE / "recommendation.json").read_text())
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
    # The rule's setting (validation/archive/report-v2/REPORT.md): position standardization,
    # EP-SNR and PM-SNR 0 dB. An array does not say which columns form a position:
    # reconstruct keeps "column" there; every MNE route takes n_orient from the forward and
    # the rule's form.
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
    # the demo knows its sampling rate: the AR(1) prior, its time constant chosen by the data
    from skf_ref.method._priors import DEFAULT_TIME_CONSTANT_MS

    assert default(run_demo, "ep_snr_db") is None and default(run_demo, "pm_snr_db") == 0.0
    assert default(run_demo, "time_constant_ms") == DEFAULT_TIME_CONSTANT_MS == "auto"
    commands = build_parser()._subparsers._group_actions[0].choices
    for command, ep in (("demo", None), ("reconstruct", None)):  # None: as above
        priors = [commands[command].get_default(k) for k in ("pm_snr_db", "ep_snr_db")]
        assert priors == [0.0, ep], command
    assert commands["demo"].get_default("standardize") == "position"
