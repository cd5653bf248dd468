"""Suite version 4: version 3's cases and two of the stationary AR(1) prior; 3 stays as it was."""

import hashlib
import json

import numpy as np
import pytest
from independent_skf import run_case

from skf_ref import ar1_priors, compare
from skf_ref.cli import main
from skf_ref.conformance import CONFORMANCE_VERSION, cases, export, verify
from skf_ref.conformance._suite import SUITES, manifest

CASES = {case.name: case for case in cases()}
AR1 = ("ar1_prior", "ar1_prior_smoothed")
#: sha256 of suite_v3/manifest.json as skf_ref 0.4 pinned it: it lists every v3 file's sha256,
#: so the same manifest and the files' checks below pin every byte of version 3.
V3_MANIFEST = "4588516043149abfd714298b0ad6534f4df64e74cefcdb207c397ca0b1ffc357"


def _sha256(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_the_suite_is_version_4_version_3s_cases_and_two_ar1_cases():
    assert CONFORMANCE_VERSION == 4 and manifest()["conformance_version"] == 4
    v3 = [entry["name"] for entry in manifest(suite=3)["cases"]]
    assert list(CASES) == [*v3, *AR1]  # version 3's cases, in order, then the new ones
    assert all(c.conformance_version == 4 for c in CASES.values())
    # the convention of version 3: the manifest and each file name the skf_ref that computed it
    # each suite records the skf_ref that computed it; a release never rewrites it
    assert (manifest()["skf_ref_version"], manifest(suite=3)["skf_ref_version"]) == (
        "0.4.0",
        "0.3.0",
    )
    assert {c.skf_ref_version for c in CASES.values()} == {manifest()["skf_ref_version"]}
    assert {"time_constant_ms", "sfreq"} <= set(CASES["ar1_prior"].extras)
    assert sorted(SUITES) == [2, 3, 4]


def test_version_3s_cases_are_the_same_in_version_4():
    for old in cases(suite=3):
        new = CASES[old.name]
        assert (new.description, new.exercises, new.tolerance) == (
            old.description,
            old.exercises,
            old.tolerance,
        )
        for part in ("inputs", "expected", "extras", "intermediates"):
            a, b = getattr(new, part), getattr(old, part)
            assert a.keys() == b.keys(), (old.name, part)
            for key, value in a.items():
                if isinstance(value, str | None):
                    assert value == b[key]
                else:
                    np.testing.assert_array_equal(value, b[key], err_msg=f"{old.name} {key}")


@pytest.mark.parametrize("command_line", [False, True])
def test_suite_3_is_exported_byte_for_byte(tmp_path, command_line, capsys):
    folder = tmp_path / "v3"
    if command_line:
        assert main(["conformance", "export", str(folder), "--suite", "3"]) == 0
        assert "(conformance suite version 3, computed by skf_ref 0.3.0)" in (
            capsys.readouterr().err
        )
    else:
        export(folder, suite=3)
    assert _sha256(folder / "manifest.json") == V3_MANIFEST
    for entry in json.loads((folder / "manifest.json").read_text())["cases"]:
        for name, digest in entry["files"].items():
            assert _sha256(folder / name) == digest, name
            assert (folder / name).read_bytes() == (SUITES[3] / name).read_bytes()
    assert verify(folder, suite=3) == [] and "manifest.json" in verify(folder)
    assert not (folder / "ar1_prior.npz").exists()


def test_the_command_line_exports_version_4_by_default(tmp_path, capsys):
    assert main(["conformance", "export", str(tmp_path), "--format", "npz"]) == 0
    assert "conformance suite version 4" in capsys.readouterr().err
    assert (tmp_path / "ar1_prior.npz").is_file() and verify(tmp_path) == []
    assert json.loads((tmp_path / "manifest.json").read_text())["conformance_version"] == 4


@pytest.mark.parametrize("name", AR1)
def test_the_ar1_cases_hold_the_prior_they_say(name):
    case = CASES[name]
    extras, inputs = case.extras, case.inputs
    assert extras["convention"] == "gain" and inputs["noise_cov"] == extras["noise_std"] ** 2
    theta0, q, rho = ar1_priors(
        inputs["L"],
        extras["noise_std"],
        extras["pm_snr_db"],
        extras["time_constant_ms"],
        extras["sfreq"],
    )
    assert (inputs["theta0"], inputs["q"], inputs["transition"]) == (theta0, q, rho)
    assert 0 < rho < 1 and rho**2 * theta0 + q == pytest.approx(theta0, rel=1e-15)
    assert f"transition {rho:g}" in case.exercises


@pytest.mark.parametrize("name", AR1)
def test_an_outsider_passes_the_ar1_cases_and_a_random_walk_fails_them(name):
    case = CASES[name]
    assert compare(case, run_case(case)).agrees  # written from docs/model.md alone
    walk = compare(case, case.reconstruct(transition=1.0))  # the AR(1) prior's A left out
    assert not walk.agrees and walk.first_divergence["step"] is not None
