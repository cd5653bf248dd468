"""`compare`: the exact outputs agree, each known mistake is named, noise alone is not."""

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

from skf_ref import InputError, compare
from skf_ref.cli import main
from skf_ref.conformance import OUTPUTS, TOLERANCE, cases, export
from skf_ref.conformance.mistakes import SUSPECTS

ENV = os.environ | {"PYTHONPATH": str(Path(__file__).resolve().parents[1])}
CASES = {case.name: case for case in cases()}
# Every suspect must move some output by at least this much on every case it applies to,
# so that it can never be confused with rounding (TOLERANCE is 1e-6).
MISTAKE_SIZE = 1e-3
# Noise 100 times the tolerance: their numbers disagree, yet are far from every mistake.
NOISE = 100 * TOLERANCE
APPLICABLE = [
    (name, suspect.name)
    for name, case in CASES.items()
    for suspect in SUSPECTS
    if suspect.compute(case) is not None
]


def _relative(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / np.max(np.abs(b))


def _suspect(name):
    return next(suspect for suspect in SUSPECTS if suspect.name == name)


def _long_csv(path, outputs):
    """Their outputs as the long table of skf_ref.conformance.compare."""
    with open(path, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["output", "source", "step", "value"])
        for name, value in outputs.items():
            if np.ndim(value) == 0:
                writer.writerow([name, "", "", repr(float(value))])
                continue
            for (s, t), entry in np.ndenumerate(value):
                writer.writerow([name, s + 1, t + 1, repr(float(entry))])
    return path


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cases")
    export(folder)
    return folder


@pytest.mark.parametrize("name", CASES)
def test_the_exact_outputs_agree(name):
    result = compare(CASES[name], CASES[name].expected)
    assert result.agrees and result.exit_status == 0
    assert result.diagnosis == [] and result.suspects == []
    assert [row["output"] for row in result.rows] == list(OUTPUTS)


@pytest.mark.parametrize("fmt", ["npz", "mat", "mat73", "csv"])
def test_their_files_in_every_format(tmp_path, exported, fmt):
    case = CASES["free_orientation"]
    theirs = {name: getattr(case.reconstruct("filterpy"), name) for name in OUTPUTS}
    path = tmp_path / f"mine.{fmt[:3]}"
    if fmt == "npz":
        np.savez(path, **theirs, extra=np.ones(2))
    elif fmt == "mat":
        savemat(path, theirs)
    elif fmt == "mat73":
        from test_io import _v73

        _v73(path, **{k: v for k, v in theirs.items() if k != "log_likelihood"})
    else:
        _long_csv(path, theirs)
    result = compare(exported / "free_orientation.mat", path)
    assert result.agrees, result.report()
    assert result.ignored == (["extra"] if fmt == "npz" else [])


@pytest.mark.parametrize("name, suspect", APPLICABLE)
def test_each_mistake_is_diagnosed_as_itself(name, suspect):
    case = CASES[name]
    theirs = _suspect(suspect).compute(case)
    if suspect != "transposed":  # the others keep the layout: their size is in the values
        assert max(_relative(theirs[k], case.expected[k]) for k in OUTPUTS) >= MISTAKE_SIZE
    result = compare(case, theirs)
    assert not result.agrees and result.exit_status == 1
    assert result.diagnosis == [suspect], result.report()
    assert f"Likely cause: {suspect}" in result.report()


def test_every_suspect_is_tried_on_some_case():
    assert {suspect for _, suspect in APPLICABLE} == {suspect.name for suspect in SUSPECTS}


@pytest.mark.parametrize("name", CASES)
def test_noise_alone_is_not_diagnosed(name):
    case = CASES[name]
    rng = np.random.default_rng(0)
    theirs = {}
    for key, value in case.expected.items():  # each entry off by 0.5 to 1 times NOISE
        size = rng.uniform(0.5, 1, np.shape(value)) * rng.choice([-1, 1], np.shape(value))
        theirs[key] = value + NOISE * np.max(np.abs(value)) * size
    result = compare(case, theirs)
    assert not result.agrees and result.diagnosis == []
    assert "No known mistake reproduces these numbers." in result.report()
    for row in result.rows:
        assert TOLERANCE < row["largest_difference"] <= NOISE
    assert {row["first_step"] for row in result.rows} <= {1, None}


def test_a_late_difference_is_found_at_its_step():
    case = CASES["transition"]
    z = np.array(case.expected["z"])
    z[2, 4:] *= 1.01
    result = compare(case, {"z": z, "x": case.expected["x"]})
    (z_row, x_row) = result.rows
    assert (z_row["first_step"], z_row["verdict"]) == (5, "disagrees")
    assert (x_row["first_step"], x_row["verdict"]) == (None, "agrees")
    assert result.diagnosis == []


def test_the_result_as_a_table_and_a_dict():
    case = CASES["original_skf"]
    result = compare(case, {"weights": case.expected["weights"].T}, tolerance=1e-4)
    frame = result.to_frame()
    assert list(frame.index) == ["weights"] and frame.loc["weights", "layout"] == "transposed"
    as_dict = result.to_dict()
    assert as_dict["diagnosis"] == ["transposed"] and as_dict["tolerance"] == 1e-4
    json.dumps(as_dict)  # plain values
    assert repr(result) == "<Comparison | case original_skf, 1 outputs, disagrees>"


@pytest.mark.parametrize(
    "theirs, match",
    [
        ({"Z": 1.0}, r"holds none of the outputs z, z_filtered, .*; it holds \['Z'\]"),
        (
            {"z": np.ones((4, 6))},
            r"z must have shape \(4, 7\) \(n_sources, n_times\), got \(4, 6\)",
        ),
        ({"x": np.ones(28)}, r"x must have shape \(4, 7\) \(n_sources, n_times\), got \(28,\)"),
        ({"log_likelihood": [1.0, 2.0]}, r"log_likelihood must be one number, got \(2,\)"),
        ({"z": "text"}, r"z must be numbers, got 'text' \(str\)"),
        (3.0, r"theirs must be a file, a mapping or a Reconstruction"),
    ],
)
def test_unusable_outputs_name_the_key_and_the_shape(theirs, match):
    with pytest.raises(InputError, match=match):
        compare(CASES["original_skf"], theirs)


@pytest.mark.parametrize(
    "content, match",
    [
        ("z,source,step,value\n", r"the first line must be output,source,step,value"),
        ("output,source,step,value\nz,0,1,2.0\n", r"line 2: source and step count from 1"),
        ("output,source,step,value\nz,1,1,x\n", r"line 2: expected an output name"),
        ("output,source,step,value\nz,1,1,1\nz,1,1,1\n", r"line 3: z \(1, 1\) appears twice"),
        ("output,source,step,value\nz,1,1,1\nz,2,2,1\n", r"z has 2 values for sources 1..2"),
        ("output,source,step,value\nz,1,1\n", r"line 2: expected 4 fields, got 3"),
    ],
)
def test_unusable_csv_names_the_line(tmp_path, content, match):
    path = tmp_path / "mine.csv"
    path.write_text(content)
    with pytest.raises(InputError, match=match):
        compare(CASES["original_skf"], path)


def test_a_file_that_is_not_a_case(tmp_path, exported):
    np.savez(tmp_path / "not.npz", z=np.ones((4, 7)))
    with pytest.raises(InputError, match=r"not.npz: not a conformance case: no variable 'case'"):
        compare(tmp_path / "not.npz", exported / "original_skf.npz")


# --- the command line -------------------------------------------------------------------------


def test_command_line_compare(tmp_path, capsys):
    folder = tmp_path / "cases"
    export(folder, ["npz"])
    case = CASES["average_reference"]
    good, bad = tmp_path / "good.npz", tmp_path / "bad.mat"
    np.savez(good, **case.expected)
    savemat(bad, _suspect("missing_average_reference").compute(case))
    capsys.readouterr()
    assert main(["compare", str(folder / "average_reference.npz"), str(good)]) == 0
    assert "AGREES" in capsys.readouterr().out
    report = tmp_path / "report.json"
    arguments = ["compare", str(folder / "average_reference.npz"), str(bad), "--json"]
    assert main([*arguments, str(report)]) == 1
    assert "Likely cause: missing_average_reference" in capsys.readouterr().out
    assert json.loads(report.read_text())["diagnosis"] == ["missing_average_reference"]


ERRORS = [
    (["compare", "{case}", "{wrong_shape}"], "z must have shape (4, 7) (n_sources, n_times)"),
    (["compare", "{case}", "{nothing}"], "holds none of the outputs"),
    (["compare", "{case}", "missing.npz"], "missing.npz: no such file"),
    (["compare", "{case}", "{wrong_shape}", "--tolerance", "0"], "--tolerance: must be > 0"),
    (["compare", "{case}"], "required: THEIRS"),
    (["compare", "{case}", "{nothing}", "--json", "r.json"], "holds none of the outputs"),
]


def _arguments(arguments, folder, exported):
    """The arguments with {case}, {wrong_shape} and {nothing} made into files."""
    np.savez(folder / "wrong_shape.npz", z=np.ones((4, 6)))
    np.savez(folder / "nothing.npz", y=np.ones((4, 7)))
    paths = {"case": exported / "original_skf.npz"}
    paths |= {name: folder / f"{name}.npz" for name in ("wrong_shape", "nothing")}
    return [argument.format(**paths) for argument in arguments]


@pytest.mark.parametrize("arguments, message", ERRORS)
def test_command_line_errors_are_one_line_and_exit_2(
    tmp_path, monkeypatch, capsys, exported, arguments, message
):
    monkeypatch.chdir(tmp_path)
    arguments = _arguments(arguments, tmp_path, exported)
    before = sorted(tmp_path.iterdir())
    assert main(arguments) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("skf-ref: error:") and message in err
    assert sorted(tmp_path.iterdir()) == before  # nothing left behind


@pytest.mark.parametrize("arguments, message", ERRORS[:1])
def test_console_errors_through_a_subprocess(tmp_path, exported, arguments, message):
    arguments = _arguments(arguments, tmp_path, exported)
    before = sorted(tmp_path.iterdir())
    result = subprocess.run(
        [sys.executable, "-m", "skf_ref.cli", *arguments],
        capture_output=True,
        text=True,
        env=ENV,
        cwd=tmp_path,
        timeout=120,
    )
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("skf-ref: error:")
    assert message in result.stderr and "Traceback" not in result.stderr
    assert sorted(tmp_path.iterdir()) == before  # nothing left behind


def test_console_exit_status_1_when_something_disagrees(tmp_path, exported):
    case = CASES["priors_gain"]
    savemat(tmp_path / "mine.mat", _suspect("other_convention").compute(case))
    result = subprocess.run(
        [sys.executable, "-m", "skf_ref.cli", "compare", str(exported / "priors_gain.mat")]
        + [str(tmp_path / "mine.mat")],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=120,
    )
    assert result.returncode == 1 and result.stderr == ""
    assert "Likely cause: other_convention" in result.stdout


def _first_column(text, header):
    """The first column of the markdown table whose header starts with ``| header |``."""
    lines = text[text.index(f"| {header} |") :].splitlines()[2:]
    rows = [line for line in lines[: next(i for i, x in enumerate(lines) if not x.strip())]]
    return [row.split("|")[1].strip().strip("`") for row in rows]


def test_the_documentation_lists_every_case_and_every_suspect():
    text = (Path(__file__).resolve().parents[1] / "docs" / "conformance.md").read_text()
    assert _first_column(text, "case") == list(CASES)
    assert _first_column(text, "suspect") == [suspect.name for suspect in SUSPECTS]
