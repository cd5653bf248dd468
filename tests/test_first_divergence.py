"""compare with intermediates: the first divergence, its JSON, and suspects only by the rule."""

import json

import numpy as np
import pytest

from skf_ref import InputError, compare
from skf_ref.cli import main
from skf_ref.conformance import cases
from skf_ref.conformance._cases import OUTPUTS
from skf_ref.conformance._expected import expected_variables
from skf_ref.conformance._intermediates import QUANTITIES
from skf_ref.conformance._mistakes import SUSPECTS

CASES = {case.name: case for case in cases()}


def _everything(case):
    """The case's outputs and intermediates, as a correct implementation gives them."""
    expected, _ = expected_variables(case)
    return {name: np.array(value) for name, value in expected.items()}


@pytest.mark.parametrize("name", ["original_skf", "transition", "general_model"])
def test_a_correct_implementation_with_its_intermediates_agrees(name):
    case = CASES[name]
    result = compare(case, _everything(case))
    assert result.agrees and result.first_divergence is None and not result.ignored
    assert len(result.rows) > len(OUTPUTS)  # the intermediates have rows of their own
    as_json = json.loads(json.dumps(result.to_dict()))
    assert as_json["first_divergence"] is None
    assert isinstance(as_json["difference"], float) and as_json["difference"] < 1e-12


@pytest.mark.parametrize(
    "variable, quantity", [("P_pred", "prediction"), ("S", "innovation_covariance")]
)
def test_a_wrong_intermediate_is_named_with_its_equation_step_and_row(variable, quantity):
    case = CASES["transition"]  # rts-state: the smoother's quantities come later
    given = _everything(case)
    given[variable][1, 1, 2] *= 1.001  # step 3, row 2 (an entry of the diagonal)
    given["K"][:, :, 4] *= 1.01  # and a later one, which must not be the one named
    result = compare(case, given)
    found = result.first_divergence
    assert not result.agrees and found["quantity"] == quantity
    assert (found["output"], found["step"], found["source"]) == (variable, 3, 2)
    assert found["equation"].startswith("docs/model.md §2")
    assert found["not_given"] == []
    assert f"First divergence: {quantity} ({variable}) at step 3, row 2" in result.report()
    assert "the mistake is in " + variable + " itself" in result.report()


def test_outputs_alone_name_the_first_output_and_step_that_leaves_the_tolerance():
    case = CASES["original_skf"]
    given = {name: np.array(case.expected[name]) for name in OUTPUTS}
    given["z_filtered"][3, 5] += 1e-3 * np.max(np.abs(case.expected["z_filtered"]))
    given["x_filtered"][0, 6] *= 1.01  # later: step 7
    found = compare(case, given).first_divergence
    assert (found["quantity"], found["step"], found["source"]) == ("standardized", 6, 4)
    assert set(found) >= {"quantity", "equation", "step", "source"}
    assert found["quantity"] in QUANTITIES
    assert "P_pred" in found["not_given"] and "x_filtered" not in found["not_given"]


def test_a_covariance_given_by_its_diagonal_is_reported_so(tmp_path):
    case = CASES["full_noise_cov"]  # rts-state
    given = {name: case.expected[name] for name in OUTPUTS}
    given["P_filt"] = np.diagonal(_everything(case)["P_filt"], axis1=0, axis2=1).T.copy()
    given["G"] = np.zeros(3)
    with pytest.raises(InputError, match=r"their outputs: G must have shape \(5, 5, 6\)"):
        compare(case, given)
    del given["G"]
    assert compare(case, given).to_frame().loc["P_filt", "layout"] == "diagonal"
    np.savez(tmp_path / "mine.npz", **given)  # from a file too
    assert compare(case, tmp_path / "mine.npz").to_frame().loc["P_filt", "layout"] == "diagonal"


def test_an_intermediate_the_case_does_not_define_is_ignored():
    case = CASES["original_skf"]  # no smoother: no smoother gain
    given = {name: case.expected[name] for name in OUTPUTS} | {"G": np.zeros(3), "extra": 1}
    result = compare(case, given)
    assert result.agrees and result.ignored == ["G", "extra"]
    assert "Not outputs or intermediates of this case, ignored: G, extra." in result.report()


def test_a_log_likelihood_only_mistake_suggests_no_mistake_of_the_outputs():
    case = CASES["priors_toolbox"]  # its log-likelihood -0.43; its terms near 125
    for name, suspect in ((s.name, s) for s in SUSPECTS):
        outputs = suspect.compute(case)
        if outputs is None:
            continue
        given = {k: case.expected[k] for k in OUTPUTS}
        given["log_likelihood"] = outputs["log_likelihood"]  # only its log-likelihood
        result = compare(case, given)
        if result.agrees:
            continue
        assert result.first_divergence["quantity"] == "log_likelihood", name
        assert result.diagnosis == [] and result.closest is None, name
        assert "none is suggested" in result.report()


def test_the_json_names_the_first_divergence(tmp_path, capsys):
    main(["conformance", "export", str(tmp_path / "cases"), "--format", "npz"])
    case_file = tmp_path / "cases" / "average_reference.npz"
    case = CASES["average_reference"]
    given = _everything(case)
    given["w"][:, 3] *= 1.1  # the raw weights at step 4
    np.savez(tmp_path / "mine.npz", **given)
    report = tmp_path / "r.json"
    assert (
        main(["compare", str(case_file), str(tmp_path / "mine.npz"), "--json", str(report)]) == 1
    )
    found = json.loads((tmp_path / "r.json").read_text())["first_divergence"]
    assert (found["quantity"], found["step"]) == ("weights", 4)
    assert "First divergence: weights (w) at step 4" in capsys.readouterr().out


def test_the_float32_hint_gives_what_float32_reaches_by_algorithm():
    from independent_skf import run_case

    case = CASES["priors_toolbox"]  # float32 rounding reaches 1e-5 here
    result = compare(case, run_case(case, dtype=np.float32))
    assert not result.agrees and result.first_divergence is None  # float32 explains it
    assert "3e-6 in covariance form" in result.hint and "8e-5 in information form" in result.hint
