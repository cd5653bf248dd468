"""Conformance cases: small, fixed, byte-identical files whose answers every path gives."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat

import skf_ref
from skf_ref.cli import main
from skf_ref.conformance import (
    CONFORMANCE_VERSION,
    FORMATS,
    INPUTS,
    OUTPUTS,
    TOLERANCE,
    cases,
    export,
    read_case,
)

ENV = os.environ | {"PYTHONPATH": str(Path(__file__).resolve().parents[1])}
CASES = {case.name: case for case in cases()}
# The package's paths differ from the dense one by rounding only: about 1e-14 on these small,
# well-conditioned cases. 1e-8 is validation/crosscheck.py's bound on larger ones; an
# algebraic slip shows at 1e-3 or more (tests/test_compare.py, MISTAKE_SIZE).
PATHS_RTOL = 1e-8


def _relative(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / np.max(np.abs(b))


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cases")
    export(folder)
    return folder


# --- the cases --------------------------------------------------------------------------------


def test_the_cases_cover_what_the_issue_asks():
    tags = {tag for case in CASES.values() for tag in case.exercises}
    wanted = {"fixed orientation", "scalar noise covariance", "full noise covariance"}
    wanted |= {f"exponent {alpha}" for alpha in ("0.5", "1", "1.25", "1.5")}
    wanted |= {"no smoothing", "rts-standardized", "rts-state", "transition 0.8"}
    wanted |= {"average-referenced, rank-deficient lead field", "transition matrix"}
    assert wanted <= tags
    assert any(tag.startswith("free orientation") for tag in tags)
    conventions = {case.extras.get("convention") for case in CASES.values()}
    assert conventions == {None, "gain", "toolbox"}
    for case in CASES.values():
        m, n = case.inputs["L"].shape
        assert m <= 6 and n <= 9 and case.shape[1] == 7 and n != 7  # small; n != n_times
    referenced = CASES["average_reference"].inputs["L"]
    assert np.linalg.matrix_rank(referenced) == referenced.shape[0] - 1


def test_the_toolbox_cases_scale_the_data_and_clamp():
    for name in ("priors_toolbox", "priors_toolbox_clamped"):
        case = CASES[name]
        scale = case.extras["data_scale"]
        assert scale == np.max(np.abs(case.extras["Y_unscaled"]))
        np.testing.assert_array_equal(case.inputs["Y"], case.extras["Y_unscaled"] / scale)
        assert np.max(np.abs(case.inputs["Y"])) == 1.0
    clamped = CASES["priors_toolbox_clamped"].extras
    assert -20 * np.log10(clamped["noise_std"]) - 1 < clamped["pm_snr_db"]  # the clamp acts
    for case in CASES.values():
        if "convention" in case.extras:
            e = case.extras
            theta0, q = skf_ref.priors_from_snr(
                case.inputs["L"],
                e["noise_std"],
                e["pm_snr_db"],
                e["ep_snr_db"],
                7,
                e["convention"],
            )
            assert (case.inputs["theta0"], case.inputs["q"]) == (theta0, q)


@pytest.mark.parametrize("name", CASES)
def test_expected_outputs_agree_with_every_path(name):
    case = CASES[name]
    methods = ["dense", "filterpy"]
    if case.reconstruct("dense").settings["transition"] != "matrix":
        methods.append("spectral")
    for method in methods:
        rec = case.reconstruct(method)
        assert rec.method == method
        for output in OUTPUTS:
            difference = _relative(getattr(rec, output), case.expected[output])
            assert difference <= PATHS_RTOL, (method, output, difference)


def test_the_spectral_path_runs_on_every_isotropic_case():
    spectral = [name for name, case in CASES.items() if np.ndim(case.inputs["transition"]) == 0]
    assert len(spectral) == len(CASES) - 1  # all but the general model


# --- the files --------------------------------------------------------------------------------


def test_export_is_byte_identical_from_run_to_run(tmp_path, exported):
    written = export(tmp_path / "again", formats=["mat", "npz", "mat"])
    assert len(written) == 2 * len(CASES) + 1
    names = sorted(path.name for path in written)
    assert names == sorted(path.name for path in exported.iterdir())
    for path in written:
        assert path.read_bytes() == (exported / path.name).read_bytes(), path.name


def test_export_is_byte_identical_in_another_process(tmp_path, exported):
    # another interpreter with another hash seed: no dates, no dict-order or set-order effects
    command = [sys.executable, "-m", "skf_ref.cli", "conformance", "export", "again", "--quiet"]
    env = ENV | {"PYTHONHASHSEED": "12345"}
    result = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, timeout=120)
    assert result.returncode == 0, result.stderr
    again = sorted((tmp_path / "again").iterdir())
    assert [path.name for path in again] == sorted(path.name for path in exported.iterdir())
    for path in again:
        assert path.read_bytes() == (exported / path.name).read_bytes(), path.name


def test_manifest(exported):
    manifest = json.loads((exported / "manifest.json").read_text())
    assert manifest["conformance_version"] == CONFORMANCE_VERSION
    assert manifest["skf_ref_version"] == skf_ref.__version__
    assert manifest["tolerance"] == TOLERANCE
    assert [case["name"] for case in manifest["cases"]] == list(CASES)
    for entry in manifest["cases"]:
        assert entry["files"] == [f"{entry['name']}.npz", f"{entry['name']}.mat"]
        assert entry["exercises"] == list(CASES[entry["name"]].exercises)
        assert all((exported / name).is_file() for name in entry["files"])


@pytest.mark.parametrize("fmt", FORMATS)
def test_case_files_read_back_exactly(exported, fmt):
    for name, case in CASES.items():
        read = read_case(exported / f"{name}.{fmt}")
        assert (read.name, read.exercises, read.tolerance) == (name, case.exercises, TOLERANCE)
        assert read.extras.keys() == case.extras.keys()
        for key, value in [*case.inputs.items(), *case.expected.items(), *case.extras.items()]:
            got = {**read.inputs, **read.expected, **read.extras}[key]
            assert type(got) is type(value), (name, key)
            np.testing.assert_array_equal(got, value, err_msg=f"{name} {key}")


def test_mat_files_are_matlab_v5_in_mne_layout(exported):
    raw = loadmat(exported / "full_noise_cov.mat")  # no squeezing: what MATLAB sees
    assert raw["__header__"].startswith(b"MATLAB 5.0 MAT-file") and raw["__version__"] == "1.0"
    assert raw["L"].shape == (6, 5) and raw["Y"].shape == (6, 7) and raw["z"].shape == (5, 7)
    assert raw["noise_cov"].shape == (6, 6) and raw["theta0"].shape == (1, 1)
    assert list(raw["smoother"]) == ["rts-state"]
    assert list(loadmat(exported / "original_skf.mat")["smoother"]) == ["none"]
    npz = np.load(exported / "original_skf.npz", allow_pickle=False)
    assert set(INPUTS) | set(OUTPUTS) <= set(npz.files) and str(npz["smoother"]) == "none"


# --- the command line -------------------------------------------------------------------------


def test_command_line_export(tmp_path, capsys):
    folder = tmp_path / "cases"
    assert main(["conformance", "export", str(folder), "--format", "npz"]) == 0
    assert f"wrote {len(CASES)} case files and manifest.json" in capsys.readouterr().err
    assert len(list(folder.glob("*.npz"))) == len(CASES) and not list(folder.glob("*.mat"))
    assert json.loads((folder / "manifest.json").read_text())["cases"][0]["files"] == [
        "original_skf.npz"
    ]


def test_the_parser_knows_the_formats():
    from skf_ref.cli import conformance

    assert conformance._FORMATS == FORMATS


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["conformance", "export", "out", "--format", "xlsx"], "argument --format: invalid"),
        (["conformance", "export", "a_file"], "File exists"),
        (["conformance", "export"], "required: DIR"),
        (["conformance"], "required: ACTION"),
    ],
)
def test_command_line_errors_are_one_line_and_exit_2(
    tmp_path, monkeypatch, capsys, arguments, message
):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a_file").write_text("not a folder")
    assert main(arguments) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("skf-ref: error:") and message in err
    assert sorted(path.name for path in tmp_path.iterdir()) == ["a_file"]  # nothing written


def test_console_error_through_a_subprocess(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "skf_ref.cli", "conformance", "export", "out", "--format", "csv"],
        capture_output=True,
        text=True,
        env=ENV,
        cwd=tmp_path,
        timeout=120,
    )
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.count("\n") == 1 and "argument --format: invalid" in result.stderr
    assert not list(tmp_path.iterdir())
