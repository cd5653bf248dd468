"""`compare`: the exact outputs agree, each known mistake is named, noise alone is not.

The implementations under test are tests/independent_skf.py: an SKF written from
docs/model.md alone, which can make each catalogued mistake and compute in float32.
"""

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from independent_skf import run_case
from scipy.io import savemat

from skf_ref import InputError, compare
from skf_ref.cli import main
from skf_ref.conformance import FLOAT32_TOLERANCE, TOLERANCE, cases, export
from skf_ref.conformance._cases import OUTPUTS
from skf_ref.conformance._distances import NEARER
from skf_ref.conformance._mistakes import SUSPECTS

ENV = os.environ | {"PYTHONPATH": str(Path(__file__).resolve().parents[1])}
CASES = {case.name: case for case in cases()}
# Every suspect must move some output by at least this much on every case it applies to,
# so that it can never be confused with rounding (TOLERANCE is 1e-6, float32's 1e-4).
MISTAKE_SIZE = 1e-3
# Noise 100 times the tolerance: their numbers disagree, yet are far from every mistake.
NOISE = 100 * TOLERANCE
APPLICABLE = [
    (name, suspect.name)
    for name, case in CASES.items()
    for suspect in SUSPECTS
    if suspect.compute(case) is not None
]
# The mistakes no case can tell apart, where the case makes them the same computation:
# with alpha = 1, the exponent on the square root of w_t is w_t ** -0.5.
SAME_AT_EXPONENT_1 = {"exponent_on_square_root", "exponent_fixed_at_half"}


def _relative(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / np.max(np.abs(b))


def _suspect(name):
    return next(suspect for suspect in SUSPECTS if suspect.name == name)


def _long_csv(path, outputs, number="{!r}", encoding="utf-8"):
    """Their outputs as the long table of skf_ref.conformance._their_outputs."""
    with open(path, "w", newline="", encoding=encoding) as stream:
        writer = csv.writer(stream)
        writer.writerow(["output", "source", "step", "value"])
        for name, value in outputs.items():
            if np.ndim(value) == 0:
                writer.writerow([name, "", "", number.format(float(value))])
                continue
            for (s, t), entry in np.ndenumerate(value):
                writer.writerow([name, s + 1, t + 1, number.format(float(entry))])
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


@pytest.mark.parametrize("fmt", ["npz", "mat", "mat73", "csv", "csv with a byte order mark"])
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
    else:  # Excel and Windows editors start UTF-8 text with a byte order mark
        _long_csv(path, theirs, encoding="utf-8-sig" if "mark" in fmt else "utf-8")
    result = compare(exported / "free_orientation.mat", path)
    assert result.agrees, result.report()
    assert result.ignored == (["extra"] if fmt == "npz" else [])


@pytest.mark.parametrize("name, suspect", APPLICABLE)
def test_each_catalogued_mistake_moves_an_output_far_beyond_rounding(name, suspect):
    case = CASES[name]
    theirs = _suspect(suspect).compute(case)
    if suspect != "transposed":  # the others keep the layout: their size is in the values
        assert max(_relative(theirs[k], case.expected[k]) for k in OUTPUTS) >= MISTAKE_SIZE
    assert suspect in compare(case, theirs).diagnosis  # the catalogue names itself


def test_an_independent_implementation_agrees_with_every_case():
    for name, case in CASES.items():
        result = compare(case, run_case(case))
        assert result.agrees, result.report()
        assert max(row["largest_difference"] for row in result.rows) < 1e-10, name


@pytest.mark.parametrize("suspect", [suspect.name for suspect in SUSPECTS])
def test_an_implementation_making_each_mistake_fails_and_hears_its_name(suspect):
    named_alone = []
    for name, case in CASES.items():
        theirs = run_case(case, mistake=suspect)
        if theirs is None:  # the mistake cannot happen in this case
            continue
        result = compare(case, theirs)
        assert not result.agrees and result.exit_status == 1, (name, result.report())
        if result.diagnosis:  # never the wrong name
            assert suspect in result.diagnosis, (name, result.report())
            assert set(result.diagnosis) <= {suspect} | SAME_AT_EXPONENT_1, (
                name,
                result.diagnosis,
            )
        if result.diagnosis == [suspect]:
            named_alone.append(name)
            assert f"Likely cause: {suspect}" in result.report()
    assert named_alone, f"no case names {suspect} alone"


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
    assert not result.agrees and result.diagnosis == [] and result.closest is None
    report = result.report()
    assert "No known mistake reproduces or explains these outputs" in report
    assert "none is suggested" in report and "Nearest known mistake" not in report
    assert "if your implementation computes in float32, it agrees to float32" in report
    for row in result.rows:  # the log-likelihood over its terms' sizes: smaller
        assert row["largest_difference"] <= NOISE
        assert TOLERANCE < row["largest_difference"] or row["output"] == "log_likelihood"
    assert {row["first_step"] for row in result.rows} <= {1, None}
    found = result.first_divergence  # the first output of step 1 that noise moved
    assert found["step"] == 1 and found["quantity"] in ("filtered_state", "weights")


def test_closest_only_when_a_mistake_explains_the_numbers_better():
    case = CASES["priors_toolbox"]  # the other mistakes are all far from this one
    mistaken = _suspect("exponent_dropped").compute(case)

    def between(fraction):  # their numbers, a fraction of the way to the mistake
        return {k: case.expected[k] + fraction * (mistaken[k] - case.expected[k]) for k in OUTPUTS}

    # NEARER times nearer than the expected outputs on every output that differs: explained
    near = compare(case, between(1 - 0.5 / NEARER))
    assert near.diagnosis == [] and near.closest == "exponent_dropped"
    assert near.difference == pytest.approx((1 - 0.5 / NEARER) * _distance(case, mistaken))
    assert "Nearest known mistake: exponent_dropped, off by" in near.report()
    # nine tenths of the way is nearer, but no explanation
    far = compare(case, between(0.9))
    assert far.closest is None and "Nearest" not in far.report()
    assert far.to_dict()["closest"] is None and near.to_dict()["closest"] == "exponent_dropped"


def _distance(case, outputs):
    return max(_relative(outputs[k], case.expected[k]) for k in OUTPUTS)


# --- precision --------------------------------------------------------------------------------


@pytest.mark.parametrize("name", CASES)
def test_a_float32_implementation_is_told_it_agrees_to_float32_precision(name):
    case = CASES[name]
    result = compare(case, run_case(case, dtype=np.float32))
    if name == "ill_conditioned":  # this one needs double precision, and says so
        assert not result.agrees and result.precision.numbers == "float32"
        assert "run in double precision" in result.hint
        return
    if result.agrees:  # float32 is within 1e-6 on several well-conditioned cases
        assert result.hint is None
    else:
        assert result.precision.numbers == "float32" and result.diagnosis == []
        assert "It agrees to float32 precision: use --tolerance 1e-4." in result.report()
        assert "No known mistake" not in result.report()  # the precision explains it
    assert compare(case, run_case(case, dtype=np.float32), tolerance=FLOAT32_TOLERANCE).agrees


def test_a_float32_implementation_making_a_mistake_still_hears_its_name():
    case = CASES["priors_toolbox"]  # float32 rounding reaches 1.4e-5 here
    result = compare(case, run_case(case, mistake="exponent_dropped", dtype=np.float32))
    assert result.diagnosis == ["exponent_dropped"], result.report()
    assert result.precision.tolerance == FLOAT32_TOLERANCE


def test_outputs_printed_with_six_digits_are_told_so(tmp_path):
    case = CASES["transition"]
    path = _long_csv(tmp_path / "mine.csv", case.expected, "{:.6g}")
    result = compare(case, path)
    assert not result.agrees and result.precision.numbers == "6 significant digits"
    assert "are the rounding of printing 6 digits" in result.hint
    assert "Print 17 significant digits (%.17g) to compare at 1e-6, or use --tolerance 1e-5" in (
        result.hint
    )
    assert compare(case, path, tolerance=1e-5).agrees
    mistaken = _long_csv(
        tmp_path / "bad.csv", _suspect("transition_ignored").compute(case), "{:.6g}"
    )
    assert compare(case, mistaken).diagnosis == ["transition_ignored"]


# --- shapes -----------------------------------------------------------------------------------


def test_a_transposed_output_is_named_as_such():
    case = CASES["original_skf"]
    result = compare(case, {"z": case.expected["z"].T, "x": case.expected["x"]})
    (z_row, x_row) = result.rows
    assert (z_row["layout"], z_row["verdict"], z_row["largest_difference"]) == (
        "transposed",
        "disagrees",
        0.0,
    )
    assert x_row["verdict"] == "agrees" and result.exit_status == 1
    assert "Transposed: z given as (n_times, n_sources)" in result.report()
    assert result.diagnosis == []  # the mistake transposes every output; here x is right
    every = compare(case, {"z": case.expected["z"].T, "x": case.expected["x"].T})
    assert every.diagnosis == ["transposed"]


def test_a_transposed_output_of_the_square_case_is_found_by_its_values():
    case = CASES["square"]
    result = compare(case, run_case(case, mistake="transposed"))
    assert [row["layout"] for row in result.rows] == ["as expected"] * len(OUTPUTS)
    assert result.diagnosis == ["transposed"], result.report()


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
    assert repr(result) == "<Comparison | case original_skf, 1 variables, disagrees>"


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
        ("output,source,step,value\nz,1,1,\xe9\n", r"not UTF-8 text \(byte 31\); save"),
    ],
)
def test_unusable_csv_names_the_line(tmp_path, content, match):
    path = tmp_path / "mine.csv"
    path.write_bytes(content.encode("latin-1"))
    with pytest.raises(InputError, match=match):
        compare(CASES["original_skf"], path)


@pytest.mark.parametrize("fmt", ["npz", "mat"])
def test_a_changed_copy_of_a_pinned_case_is_refused(tmp_path, exported, fmt):
    from skf_ref.conformance import write_case
    from skf_ref.conformance._cases import Case

    case = CASES["square"]
    expected = {**case.expected, "z": 2 * case.expected["z"]}
    changed = Case(**{**vars(case), "expected": expected})
    path = write_case(changed, tmp_path / f"square.{fmt}")  # same name, same version
    with pytest.raises(InputError, match=rf"square.{fmt} says it is case 'square' of confor"):
        compare(path, {"z": expected["z"]})
    assert compare(exported / f"square.{fmt}", {"z": case.expected["z"]}).agrees
    renamed = Case(**{**vars(changed), "name": "my_square"})  # a case of one's own
    assert compare(write_case(renamed, tmp_path / f"mine.{fmt}"), {"z": expected["z"]}).agrees


@pytest.mark.parametrize("where", ["mapping", "npz", "mat"])
def test_complex_outputs_are_refused_not_cast(tmp_path, where):
    case = CASES["original_skf"]
    z = case.expected["z"]
    theirs = {"z": z + 1j * z, "log_likelihood": case.expected["log_likelihood"]}
    if where == "npz":
        np.savez(tmp_path / "mine.npz", **theirs)
        theirs = tmp_path / "mine.npz"
    elif where == "mat":
        savemat(tmp_path / "mine.mat", theirs)
        theirs = tmp_path / "mine.mat"
    with pytest.raises(InputError, match=r"z is complex \(largest imaginary part .*\): an SKF"):
        compare(case, theirs)
    assert compare(case, {"z": z + 0j}).agrees  # an imaginary part of zero is no part
    with pytest.raises(InputError, match=r"log_likelihood is complex"):
        compare(case, {"log_likelihood": case.expected["log_likelihood"] + 1j})


def test_only_the_outputs_of_their_file_are_read(tmp_path, exported):
    import tracemalloc

    case = CASES["original_skf"]
    unused = np.zeros(8_000_000)  # 64 MB, a few kB compressed
    np.savez_compressed(tmp_path / "mine.npz", **case.expected, notes=unused)
    tracemalloc.start()
    try:
        result = compare(exported / "original_skf.npz", tmp_path / "mine.npz")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert result.agrees and result.ignored == ["notes"]
    assert peak < unused.nbytes / 16, peak


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
    (["compare", "{case}", "{nothing}", "--json", "{case}"], "must end in .json, got '.npz'"),
    (["compare", "{case}", "{nothing}", "--json", "{to_case}"], "is the input CASE_FILE"),
    (["compare", "{case}", "{nothing}", "--json", "{to_theirs}"], "is the input THEIRS"),
    (["compare", "{case}", "{nothing}", "--json", "nodir/r.json"], "nodir/r.json: the folder"),
    (["compare", "{case}", "{nothing}", "--json", "r.txt"], "must end in .json, got '.txt'"),
    (["compare", "{case}", "{nothing}", "--json", "."], "--json must be a file name"),
    (["compare", "{doubled}", "{nothing}"], "is not the suite's file (its sha256 differs"),
    (["compare", "{not_archive}", "{nothing}"], "not_archive.npz: not an .npz archive"),
    (["compare", "{case}", "{not_archive}"], "not_archive.npz: not an .npz archive"),
    (["compare", "{case}", "{nothing}"], "holds none of the outputs"),
    (["compare", "{case}", "missing.npz"], "missing.npz: no such file"),
    (["compare", "{case}", "{wrong_shape}", "--tolerance", "0"], "--tolerance: must be > 0"),
    (["compare", "{case}"], "required: THEIRS"),
    (["compare", "{case}", "{nothing}", "--json", "r.json"], "holds none of the outputs"),
    (["compare", "{bad_smoother}", "{nothing}"], "smoother must be one of [None, "),
    (["compare", "{case}", "{wrong_shape}"], "z must have shape (4, 7) (n_sources, n_times)"),
]


def _arguments(arguments, folder, exported):
    """The arguments with {case}, {wrong_shape}, {nothing} and {bad_smoother} made files."""
    np.savez(folder / "wrong_shape.npz", z=np.ones((4, 6)))
    np.savez(folder / "nothing.npz", y=np.ones((4, 7)))
    case = dict(np.load(exported / "original_skf.npz")) | {"smoother": np.array("rts")}
    np.savez(folder / "bad_smoother.npz", **case)
    doubled = dict(np.load(exported / "original_skf.npz")) | {"z": 2 * case["z"]}
    np.savez(folder / "doubled.npz", **doubled)  # the same name and version, z doubled
    (folder / "not_archive.npz").write_text("a text file named .npz")
    paths = {"case": exported / "original_skf.npz"}
    names = ("wrong_shape", "nothing", "bad_smoother", "doubled", "not_archive")
    paths |= {name: folder / f"{name}.npz" for name in names}
    for link, target in (("to_case", paths["case"]), ("to_theirs", paths["nothing"])):
        paths[link] = folder / f"{link}.json"  # a report name that leads to an input
        paths[link].symlink_to(target)
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
    assert "pickle" not in err and ".skf-tmp" not in err
    assert sorted(tmp_path.iterdir()) == before  # nothing left behind, no input replaced
    assert all(path.stat().st_size > 0 for path in before)


@pytest.mark.slow
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


def test_command_line_a_transposed_output_exits_1(tmp_path, capsys, exported):
    np.savez(tmp_path / "mine.npz", z=CASES["original_skf"].expected["z"].T)
    assert main(["compare", str(exported / "original_skf.npz"), str(tmp_path / "mine.npz")]) == 1
    out = capsys.readouterr().out
    assert "disagrees (transposed)" in out and "Likely cause: transposed" in out


@pytest.mark.slow
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
