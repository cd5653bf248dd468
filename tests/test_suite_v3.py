"""Suite version 3: its new cases do what they say, and version 2 is still exported as it was.

Version 3 stays in the package, pinned, beside version 4 (tests/test_suite_v4.py): these
tests read its own files.
"""

import hashlib
import json

import numpy as np
import pytest
from independent_skf import run_case, skf

from skf_ref import InputError, compare
from skf_ref.cli import main
from skf_ref.conformance import CONFORMANCE_VERSION, cases, export, read_case, verify
from skf_ref.conformance._suite import SUITES, manifest

CASES = {case.name: case for case in cases(suite=3)}
#: sha256 of suite_v2/manifest.json as skf_ref 0.3 pinned it: it lists every v2 file's sha256,
#: so the same manifest and the files' checks below pin every byte of version 2.
V2_MANIFEST = "1e360a7083d647d7cf151620534e215daf07f158c21bc0199e6427685d8856b8"


def _sha256(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_suite_3_has_seventeen_cases():
    assert CONFORMANCE_VERSION > 3 and manifest(suite=3)["conformance_version"] == 3
    assert len(CASES) == 17 and all(c.conformance_version == 3 for c in CASES.values())
    assert {"standardize", "n_orient"} <= set(manifest(suite=3)["inputs"])
    v2 = [entry["name"] for entry in manifest(suite=2)["cases"]]
    assert list(CASES)[: len(v2)] == v2  # version 3 keeps version 2's cases, in order


@pytest.mark.parametrize("command_line", [False, True])
def test_suite_2_is_exported_byte_for_byte(tmp_path, command_line, capsys):
    folder = tmp_path / "v2"
    if command_line:
        assert main(["conformance", "export", str(folder), "--suite", "2"]) == 0
        assert "(conformance suite version 2, computed by skf_ref 0.3.0)" in (
            capsys.readouterr().err
        )
    else:
        export(folder, suite=2)
    assert _sha256(folder / "manifest.json") == V2_MANIFEST
    pinned = json.loads((folder / "manifest.json").read_text())
    for entry in pinned["cases"]:
        for name, digest in entry["files"].items():
            assert _sha256(folder / name) == digest, name
            assert (folder / name).read_bytes() == (SUITES[2] / name).read_bytes()
    assert verify(folder, suite=2) == [] and "manifest.json" in verify(folder)
    assert not (folder / "position.npz").exists()


def test_a_version_2_case_file_is_still_read_and_compared(tmp_path):
    export(tmp_path, formats=["npz"], suite=2)
    case = read_case(tmp_path / "original_skf.npz")
    assert case.conformance_version == 2
    assert (case.inputs["standardize"], case.inputs["n_orient"]) == ("column", 1)
    assert compare(tmp_path / "original_skf.npz", case.reconstruct()).agrees
    changed = dict(np.load(tmp_path / "original_skf.npz"))
    changed["z"] = changed["z"] * 1.01  # a pinned case of version 2, altered
    np.savez(tmp_path / "altered.npz", **changed)
    with pytest.raises(InputError, match="case 'original_skf' of conformance suite version 2"):
        compare(tmp_path / "altered.npz", case.reconstruct())


def test_an_unknown_suite_version_is_refused(tmp_path):
    with pytest.raises(InputError, match=r"suite must be one of \[2, 3, 4\], got 1"):
        export(tmp_path, suite=1)


def test_the_position_case_needs_each_position_as_a_whole():
    case = CASES["position"]
    assert (case.inputs["standardize"], case.inputs["n_orient"]) == ("position", 3)
    assert case.shape[0] % 3 == 0
    # oblique sources: the data are explained by moments with no orientation near an axis
    assert compare(case, run_case(case)).agrees
    p, eye = case.inputs, np.eye(case.shape[0])
    R = p["noise_cov"] * np.eye(len(p["L"]))
    matrices = (eye, p["q"] * eye, p["theta0"] * eye)
    by_column = skf(p["L"], p["Y"], R, *matrices, p["exponent"], p["smoother"])
    result = compare(case, by_column)
    assert not result.agrees
    assert result.first_divergence["quantity"] == "weights"  # the block weights, step 1
    assert result.first_divergence["step"] == 1


def test_the_smoothed_weights_case_differs_from_the_other_smoothers():
    case = CASES["smoothed_weights"]
    assert case.inputs["smoother"] == "rts-smoothed-weights"
    assert case.inputs["exponent"] not in (0.5, 1.0)
    for other in ("rts-state", "rts-standardized"):
        result = compare(case, case.reconstruct(smoother=other))
        assert not result.agrees and result.first_divergence["step"] is not None


def test_a_transposed_y_shows_only_in_the_outputs_of_channels_as_steps():
    case = CASES["channels_as_steps"]
    m, T = case.inputs["Y"].shape
    assert m == T and case.shape[0] != T
    others = [c for name, c in CASES.items() if name != "channels_as_steps"]
    assert all(c.inputs["Y"].shape[0] != c.inputs["Y"].shape[1] for c in others)
    result = compare(case, case.reconstruct(Y=case.inputs["Y"].T))  # the shape cannot tell
    assert not result.agrees and result.first_divergence["step"] == 1


def _toolbox_prediction(case):
    """The toolbox's condition: A skipped when diagonal with some diagonal entry exactly 1."""
    A = case.inputs["transition"]
    A = A * np.eye(case.shape[0]) if np.ndim(A) == 0 else A
    skipped = np.array_equal(A, np.diag(np.diag(A))) and np.any(np.diag(A) == 1)
    return case.reconstruct(transition=1.0) if skipped else case.reconstruct()


def test_the_toolbox_condition_on_a_is_seen_on_one_side_only():
    below = CASES["diagonal_transition_below_one"]
    A = below.inputs["transition"]
    assert np.array_equal(A, np.diag(np.diag(A))) and not np.any(np.diag(A) == 1)
    assert compare(below, _toolbox_prediction(below)).agrees  # the toolbox uses A here
    result = compare(
        CASES["diagonal_transition"], _toolbox_prediction(CASES["diagonal_transition"])
    )
    assert not result.agrees and result.diagnosis == ["transition_ignored"]
    assert result.first_divergence["quantity"] == "filtered_state"  # x_{1|1}: x_pred is 0


def test_a_case_file_with_a_wrong_n_orient_is_refused(tmp_path):
    variables = dict(np.load(SUITES[3] / "position.npz"))
    variables["n_orient"] = np.array(2)
    np.savez(tmp_path / "bad.npz", **variables)
    with pytest.raises(InputError, match=r"bad.npz: n_orient must be 1 or 3 and divide"):
        read_case(tmp_path / "bad.npz")


def test_the_short_cases_carry_their_expected_intermediates():
    from skf_ref.conformance._expected import expected_intermediates

    for name, case in CASES.items():
        if case.shape[1] > 50:
            assert case.intermediates == {}, name
            continue
        fresh = expected_intermediates(case)
        assert set(case.intermediates) == set(fresh) - {"theta0", "q"}, name
        # pinned on one machine, recomputed here with another BLAS kernel or LAPACK maybe:
        # these 7-step problems keep 1e-12 on every kernel tried (Haswell, Sandybridge,
        # SkylakeX, and scipy 1.10's older LAPACK); an ill-conditioned one (S_t of condition
        # 1.5e6) a hundred ulps times the condition
        condition = max(np.linalg.cond(S) for S in np.moveaxis(fresh["S"], -1, 0))
        rtol = max(1e-12, 100 * np.finfo(float).eps * condition)
        for key, value in case.intermediates.items():  # pinned; the package agrees
            # relative to the quantities each is computed from: P_{t|t} = P_{t|t-1} - K S K^T
            # cancels (to 1/170 of P_{t|t-1} in priors_toolbox_clamped), so its error is
            # eps times P_{t|t-1}'s scale, not its own
            sources = [fresh[key], fresh["P_pred"]] if key == "P_filt" else [fresh[key]]
            scale = max(np.max(np.abs(a)) for a in sources) or 1.0
            assert np.max(np.abs(value - fresh[key])) <= rtol * scale, (name, key)
    mat = read_case(SUITES[3] / "position.mat")  # MATLAB's file holds the same
    assert mat.intermediates["P_pred"].shape == (9, 9, 7)
    np.testing.assert_array_equal(mat.intermediates["K"], CASES["position"].intermediates["K"])
