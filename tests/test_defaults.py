"""The package's defaults are the setting the evidence study v3's rule chose, on every route.

The rule (validation/reproduce/PREREGISTRATION.md, section 6) chose on the choice set and
wrote its choice to ``validation/report/default.json``; these tests keep the package's
defaults and the recorded choice tied together: the MNE routes, the command line and the
demo (which know the sampling rate) default to it. ``skf_ref.reconstruct`` on bare arrays is
the reference function: it keeps the filter alone and the paper's column form, and takes the
priors themselves.
"""

import inspect
import json
from pathlib import Path

import skf_ref
from skf_ref.cli import build_parser
from skf_ref.method._priors import DEFAULT_EP_SNR_DB, DEFAULT_TIME_CONSTANT_MS
from skf_ref.study._demo import run_demo

CHOICE = Path(__file__).resolve().parent.parent / "validation" / "report" / "default.json"
ROUTES = (skf_ref.apply_skf, skf_ref.apply_skf_epochs, skf_ref.apply_skf_raw)


def _default(function, name):
    return inspect.signature(function).parameters[name].default


def _commands():
    return build_parser()._subparsers._group_actions[0].choices


def test_the_recommended_setting_is_the_rules_choice():
    chosen = json.loads(CHOICE.read_text())
    assert dict(skf_ref.RECOMMENDED_SETTING) == {
        "exponent": chosen["exponent"],
        "smoother": None if chosen["smoother"] == "none" else chosen["smoother"],
    }
    assert chosen["standardize"] == "position"
    assert chosen["dynamics"] == "AR auto" and DEFAULT_TIME_CONSTANT_MS == "auto"


def test_every_route_that_knows_the_rate_defaults_to_it():
    for function in (*ROUTES, skf_ref.SKFOperator.reconstruct, run_demo):
        got = {k: _default(function, k) for k in ("exponent", "smoother")}
        assert got == dict(skf_ref.RECOMMENDED_SETTING), function.__qualname__
    for command in ("demo", "reconstruct"):
        exponent, smoother = (
            _commands()[command].get_default(k) for k in ("exponent", "smoother")
        )
        smoother = None if smoother == "none" else smoother
        assert (exponent, smoother) == tuple(skf_ref.RECOMMENDED_SETTING.values()), command


def test_the_priors_default_to_the_ar1_prior_chosen_by_the_data_where_the_rate_is_known():
    # make_skf_operator (and apply_skf without an operator): ep_snr_db and time_constant_ms
    # not given -> the AR(1) prior, time constant "auto"; an EP-SNR given -> the walk
    assert _default(skf_ref.make_skf_operator, "ep_snr_db") is None
    assert _default(skf_ref.make_skf_operator, "time_constant_ms") is None
    assert _default(skf_ref.make_skf_operator, "pm_snr_db") == 0.0
    assert _default(run_demo, "ep_snr_db") is None and _default(run_demo, "pm_snr_db") == 0.0
    assert _default(run_demo, "time_constant_ms") == "auto"
    for command in ("demo", "reconstruct"):  # None: chosen at parse time, by the route
        priors = [_commands()[command].get_default(k) for k in ("pm_snr_db", "ep_snr_db")]
        assert priors == [0.0, None], command


def test_the_command_line_takes_the_ar1_prior_where_the_rate_is_known(tmp_path):
    import numpy as np

    from skf_ref.cli._reconstruct import _route

    np.save(tmp_path / "L.npy", np.eye(3))
    np.save(tmp_path / "Y.npy", np.eye(3))
    parser = build_parser()
    common = ["reconstruct", "--noise-std", "1e-6", "--out", str(tmp_path / "out.npz")]
    arrays = [*common, "--leadfield", str(tmp_path / "L.npy"), "--data", str(tmp_path / "Y.npy")]
    args = parser.parse_args(arrays)
    _route(args)
    assert args.ep_snr_db == DEFAULT_EP_SNR_DB and args.time_constant_ms is None
    args = parser.parse_args([*arrays, "--sfreq", "500"])
    _route(args)
    assert args.time_constant_ms == DEFAULT_TIME_CONSTANT_MS and args.ep_snr_db is None


def test_arrays_keep_the_reference_form():
    assert _default(skf_ref.reconstruct, "standardize") == "column"
    assert _default(skf_ref.reconstruct, "smoother") is None
    assert _default(run_demo, "standardize") == "position"
    for function in (*ROUTES, skf_ref.SKFOperator.reconstruct):  # the operator decides:
        assert _default(function, "standardize") is None, function.__qualname__
    assert _commands()["demo"].get_default("standardize") == "position"
