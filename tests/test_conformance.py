"""The conformance suite: pinned files with their checksums, the cases they hold, export."""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat

import skf_ref
from skf_ref import compare
from skf_ref.cli import main
from skf_ref.conformance import (
    CONFORMANCE_VERSION,
    FLOAT32_TOLERANCE,
    TOLERANCE,
    build,
    cases,
    export,
    manifest,
    read_case,
    verify,
    write_case,
)
from skf_ref.conformance._case_files import FORMATS
from skf_ref.conformance._cases import INPUTS, OUTPUTS, generate
from skf_ref.conformance._suite import RUNNERS, SUITE

CASES = {case.name: case for case in cases()}
# The package's paths differ from the pinned dense outputs by rounding only: about 1e-14 on
# the well-conditioned cases, 1e-11 on the ill-conditioned one. 1e-8 is
# validation/crosscheck.py's bound on larger problems; an algebraic slip shows at 1e-3 or
# more (tests/test_compare.py, MISTAKE_SIZE).
PATHS_RTOL = 1e-8
# Regenerating a case's inputs from its seed repeats the same arithmetic: equal to rounding
# (bit for bit on one machine; another BLAS may order a product differently).
INPUTS_RTOL = 1e-12
# No file of the suite is large: 10-40 kB for a short case, 60 kB for the 300-step one.
LARGEST_FILE = 60_000


def _relative(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / np.max(np.abs(b))


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cases")
    export(folder)
    return folder


# --- the pinned suite -------------------------------------------------------------------------


def test_the_pinned_files_match_their_manifest():
    pinned = manifest()
    assert pinned["conformance_version"] == CONFORMANCE_VERSION
    assert SUITE.name == f"suite_v{CONFORMANCE_VERSION}"
    listed = {name for entry in pinned["cases"] for name in entry["files"]}
    assert {path.name for path in SUITE.iterdir()} == listed | {"manifest.json"}
    assert len(listed) == len(FORMATS) * len(CASES)
    assert verify() == []  # every file's sha256 is the manifest's


def test_each_pinned_file_records_the_suite_and_the_version_that_computed_it():
    pinned = manifest()
    assert [entry["name"] for entry in pinned["cases"]] == list(CASES)
    for entry in pinned["cases"]:
        case = CASES[entry["name"]]
        assert case.conformance_version == CONFORMANCE_VERSION
        assert case.skf_ref_version == pinned["skf_ref_version"]
        assert case.tolerance == entry["tolerance"]
        assert (entry["n_sources"], entry["n_times"]) == case.shape
    assert (pinned["tolerance"], pinned["float32_tolerance"]) == (TOLERANCE, FLOAT32_TOLERANCE)


@pytest.mark.parametrize("name", CASES)
def test_the_package_has_not_drifted_from_the_pinned_outputs(name):
    # every path, on the pinned inputs, within the case's tolerance of the pinned outputs
    # (what a user's compare would say of it) and within rounding of them
    case = CASES[name]
    methods = ["dense", "filterpy"] + ["spectral"] * (np.ndim(case.inputs["transition"]) == 0)
    for method in methods:
        rec = case.reconstruct(method)
        assert rec.path == method
        assert compare(case, rec).agrees, (method, compare(case, rec).report())
        for output in OUTPUTS:
            difference = _relative(getattr(rec, output), case.expected[output])
            assert difference <= PATHS_RTOL, (method, output, difference)


def test_the_generators_still_make_the_pinned_suite():
    # a changed generator (a seed, a size, a description) is a new suite version
    fresh = generate()
    assert [case.name for case in fresh] == list(CASES)
    for new in fresh:
        old = CASES[new.name]
        about = ("description", "exercises", "tolerance")
        assert [getattr(new, key) for key in about] == [getattr(old, key) for key in about]
        assert new.extras.keys() == old.extras.keys()
        for key, value in [*new.inputs.items(), *new.extras.items()]:
            pinned = {**old.inputs, **old.extras}[key]
            if isinstance(value, str | None):
                assert value == pinned, (new.name, key)
            else:
                difference = np.max(np.abs(np.asarray(value) - pinned))
                assert difference <= INPUTS_RTOL * np.max(np.abs(pinned)), (new.name, key)
        assert compare(old, new.expected).agrees, new.name


def test_build_writes_the_same_bytes_each_time_and_the_pinned_manifest(tmp_path):
    first, again = build(tmp_path / "a", ["mat"]), build(tmp_path / "b", ["mat"])
    for path, other in zip(first, again, strict=True):
        assert path.read_bytes() == other.read_bytes(), path.name
    built = json.loads(first[-1].read_text())
    pinned = manifest()
    for entry in [*built["cases"], *pinned["cases"]]:
        entry.pop("files")
    assert built["cases"] == pinned["cases"]
    assert built.keys() == pinned.keys()


# --- the cases --------------------------------------------------------------------------------


def test_the_cases_cover_what_the_issues_ask():
    tags = {tag for case in CASES.values() for tag in case.exercises}
    wanted = {"fixed orientation", "scalar noise covariance", "full noise covariance"}
    wanted |= {f"exponent {alpha}" for alpha in ("0.5", "0.75", "1", "1.25", "1.5")}
    wanted |= {"no smoothing", "rts-standardized", "rts-state", "transition 0.8"}
    wanted |= {"average-referenced, rank-deficient lead field", "transition matrix"}
    wanted |= {"diagonal transition, not a multiple of the identity", "n_sources == n_times"}
    wanted |= {"long run to the steady state (300 steps)"}
    wanted |= {"ill-conditioned lead field (column norms spread over 1e6)"}
    assert wanted <= tags
    assert any(tag.startswith("free orientation") for tag in tags)
    conventions = {case.extras.get("convention") for case in CASES.values()}
    assert conventions == {None, "gain", "toolbox"}
    for smoother in (None, "rts-standardized", "rts-state"):  # each with alpha neither 0.5 nor 1
        exponents = {
            c.inputs["exponent"] for c in CASES.values() if c.inputs["smoother"] == smoother
        }
        assert exponents - {0.5, 1.0}, smoother
    referenced = CASES["average_reference"].inputs["L"]
    assert np.linalg.matrix_rank(referenced) == referenced.shape[0] - 1


def test_the_new_cases_are_what_they_say():
    A = CASES["diagonal_transition"].inputs["transition"]
    assert np.array_equal(A, np.diag(np.diag(A))) and len(set(np.diag(A))) > 1
    assert CASES["square"].shape[0] == CASES["square"].shape[1]
    others = [case for name, case in CASES.items() if name != "square"]
    assert all(case.shape[0] != case.shape[1] for case in others)  # transposes show there
    norms = np.linalg.norm(CASES["ill_conditioned"].inputs["L"], axis=0)
    assert norms.max() / norms.min() >= 1e6 * (1 - 1e-12)
    assert CASES["ill_conditioned"].tolerance == TOLERANCE


def test_the_long_case_reaches_the_steady_state():
    weights = CASES["steady_state"].expected["weights"]
    assert weights.shape[1] >= 200
    early = np.max(np.abs(weights[:, 5] - weights[:, -1]) / weights[:, -1])
    late = np.max(np.abs(weights[:, 50:] - weights[:, [-1]]) / weights[:, [-1]])
    assert early > 1e-4 and late < 1e-12  # it moves at first, then stays


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
        if "ep_snr_db" in case.extras:  # the AR(1) prior's cases: tests/test_suite_v4.py
            e = case.extras
            priors = skf_ref.priors_from_snr(
                case.inputs["L"],
                e["noise_std"],
                e["pm_snr_db"],
                e["ep_snr_db"],
                7,
                e["convention"],
            )
            for value, pinned in zip(
                priors, (case.inputs["theta0"], case.inputs["q"]), strict=True
            ):
                assert value == pytest.approx(pinned, rel=INPUTS_RTOL)


# --- the files --------------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", FORMATS)
def test_a_pinned_case_written_again_is_the_same_bytes(tmp_path, fmt):
    # the files hold no date and record the skf_ref that computed them, not the one running
    for name, case in CASES.items():
        path = write_case(case, tmp_path / f"{name}.{fmt}")
        assert path.read_bytes() == (SUITE / path.name).read_bytes(), path.name


def test_export_copies_the_pinned_files_byte_for_byte(exported):
    names = sorted(path.name for path in exported.iterdir())
    assert names == sorted([*(p.name for p in SUITE.iterdir()), "run_cases.m", "run_cases.py"])
    for path in exported.iterdir():
        source = (
            SUITE / path.name
            if path.suffix not in (".m", ".py")
            else RUNNERS[0].parent / path.name
        )
        assert path.read_bytes() == source.read_bytes(), path.name
    assert verify(exported) == []


def test_export_one_format_and_verify_a_changed_file(tmp_path):
    written = export(tmp_path, formats=["mat", "mat"])
    assert [path.suffix for path in written] == [".mat"] * len(CASES) + [".m", ".py", ".json"]
    assert verify(tmp_path) == []
    (tmp_path / "square.mat").write_bytes(b"not the suite's")
    (tmp_path / "transition.mat").unlink()
    assert verify(tmp_path) == ["square.mat", "transition.mat"]


@pytest.mark.parametrize("what", ["missing", "empty", "a file", "other files"])
def test_verify_refuses_a_folder_with_nothing_to_verify(tmp_path, what):
    directory = tmp_path / "cases"
    if what == "a file":
        directory.write_text("not a folder")
    elif what != "missing":
        directory.mkdir()
        if what == "other files":
            (directory / "notes.txt").write_text("mine")
            (directory / "manifest.json").write_text("{}")
    match = {
        "missing": "cases does not exist",
        "a file": "cases is a file, not a folder",
    }.get(what, "cases holds no file of the conformance suite")
    with pytest.raises(skf_ref.InputError, match=match):
        verify(directory)


def test_verify_names_a_changed_manifest(tmp_path):
    export(tmp_path, formats=["npz"])
    manifest_file = tmp_path / "manifest.json"
    manifest_file.write_text(manifest_file.read_text().replace('"tolerance": 1e-06', '"x": 1'))
    assert verify(tmp_path) == ["manifest.json"]


def test_export_keeps_a_runner_the_user_adapted(tmp_path, capsys):
    export(tmp_path, formats=["npz"])
    mine = tmp_path / "run_cases.py"
    mine.write_text(mine.read_text().replace("Replace with your SKF", "My own SKF"))
    edited = mine.read_bytes()
    with pytest.warns(UserWarning, match=r"run_cases.py differs from the runner .* kept as it"):
        written = export(tmp_path, formats=["npz"])
    assert mine.read_bytes() == edited
    shipped = tmp_path / "run_cases_shipped.py"
    assert shipped in written and shipped.read_bytes() == RUNNERS[1].read_bytes()
    # the shipped copy, unchanged, is refreshed; the unchanged MATLAB runner is replaced
    with pytest.warns(UserWarning, match="run_cases.py differs"):
        export(tmp_path, formats=["npz"])
    shipped.write_text("edited too")
    with pytest.raises(skf_ref.InputError, match=r"run_cases.py and .*run_cases_shipped.py both"):
        export(tmp_path, formats=["npz"])
    assert mine.read_bytes() == edited and shipped.read_text() == "edited too"
    # the command line says so in a note, after which the summary
    shipped.unlink()
    capsys.readouterr()
    assert main(["conformance", "export", str(tmp_path), "--format", "npz"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("skf-ref: note: ") and "kept as it is" in err[0]
    assert err[1].startswith("wrote ") and len(err) == 2


@pytest.mark.parametrize("name", ["../elsewhere/x", "/tmp/x", "a/b", "..", "", 3, None])
def test_the_python_runner_refuses_a_case_name_that_is_no_file_name(tmp_path, exported, name):
    import json
    import shutil

    folder = tmp_path / "cases"
    shutil.copytree(exported, folder)
    manifest_file = folder / "manifest.json"
    manifest = json.loads(manifest_file.read_text())
    manifest["cases"][1]["name"] = name
    manifest_file.write_text(json.dumps(manifest))
    runner = _python_runner()
    with pytest.raises(SystemExit, match="which is not a plain file name"):
        runner.run(folder, tmp_path / "out", runner.my_skf)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cases"]  # checked before any work


@pytest.mark.parametrize(
    "arguments, match", [(["csv"], "format must be one of"), ([], "at least one")]
)
def test_export_refuses_unknown_formats(tmp_path, arguments, match):
    with pytest.raises(skf_ref.InputError, match=match):
        export(tmp_path, formats=arguments)


def test_the_two_formats_hold_the_same_case():
    for name, case in CASES.items():
        read = read_case(SUITE / f"{name}.mat")
        assert (read.name, read.exercises, read.tolerance) == (
            name,
            case.exercises,
            case.tolerance,
        )
        assert (read.conformance_version, read.skf_ref_version) == (
            case.conformance_version,
            case.skf_ref_version,
        )
        assert read.extras.keys() == case.extras.keys()
        for key, value in [*case.inputs.items(), *case.expected.items(), *case.extras.items()]:
            got = {**read.inputs, **read.expected, **read.extras}[key]
            assert type(got) is type(value), (name, key)
            np.testing.assert_array_equal(got, value, err_msg=f"{name} {key}")


def test_the_files_are_small():
    sizes = {path.name: path.stat().st_size for path in SUITE.iterdir()}
    assert max(sizes.values()) <= LARGEST_FILE, sizes
    # version 3's short cases carry their expected intermediates (10-40 kB a file)
    assert sum(sizes.values()) <= 15 * LARGEST_FILE


def test_mat_files_are_matlab_v5_in_mne_layout():
    raw = loadmat(SUITE / "full_noise_cov.mat")  # no squeezing: what MATLAB sees
    assert raw["__header__"].startswith(b"MATLAB 5.0 MAT-file") and raw["__version__"] == "1.0"
    assert raw["L"].shape == (6, 5) and raw["Y"].shape == (6, 7) and raw["z"].shape == (5, 7)
    assert raw["noise_cov"].shape == (6, 6) and raw["theta0"].shape == (1, 1)
    assert list(raw["smoother"]) == ["rts-state"]
    assert list(loadmat(SUITE / "original_skf.mat")["smoother"]) == ["none"]
    npz = np.load(SUITE / "original_skf.npz", allow_pickle=False)
    assert set(INPUTS) | set(OUTPUTS) <= set(npz.files) and str(npz["smoother"]) == "none"


def test_a_case_file_with_an_unknown_smoother_is_refused(tmp_path):
    variables = dict(np.load(SUITE / "transition.npz")) | {"smoother": np.array("rts")}
    np.savez(tmp_path / "mine.npz", **variables)
    with pytest.raises(
        skf_ref.InputError, match=r"mine.npz: smoother must be one of .* got 'rts'"
    ):
        read_case(tmp_path / "mine.npz")


# --- the runners ------------------------------------------------------------------------------


def _python_runner():
    spec = importlib.util.spec_from_file_location("run_cases", RUNNERS[1])
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_python_runner_runs_another_implementation_and_compares(
    tmp_path, exported, monkeypatch, capsys
):
    monkeypatch.chdir(Path(__file__).parent)  # --skf independent_skf:skf imports from here
    runner = _python_runner()
    assert (
        runner.main([str(exported), str(tmp_path / "mine"), "--skf", "independent_skf:skf"]) == 0
    )
    out = capsys.readouterr().out
    assert out.count(" agrees") == len(CASES) and "DISAGREES" not in out
    saved = np.load(tmp_path / "mine" / "square.npz")
    assert sorted(saved.files) == sorted(OUTPUTS)


def test_the_python_runner_as_shipped_and_with_a_mistake(tmp_path, exported, capsys):
    runner = _python_runner()
    assert runner.main([str(exported), str(tmp_path / "own")]) == 0  # skf_ref's own SKF

    def half(L, Y, R, A, Q, P0, exponent, smoother):  # the exponent hard-wired to 0.5
        return runner.my_skf(L, Y, R, A, Q, P0, 0.5, smoother)

    done = runner.run(exported, tmp_path / "half", half)
    by_position = [c for c in CASES.values() if c.inputs["standardize"] == "position"]
    assert len(done) == len(CASES) - len(by_position)  # no standardize parameter: skipped
    assert "position                 skipped: it standardizes each position" in (
        capsys.readouterr().out
    )
    assert runner.compare_all(done[:3]) == 1  # three cases are enough to hear the name
    out = capsys.readouterr().out
    assert "original_skf             agrees" in out  # alpha is 0.5 there
    assert "average_reference        DISAGREES" in out
    assert "Likely cause: exponent_fixed_at_half" in out


def test_the_python_runner_saves_the_intermediates_its_function_returns(
    tmp_path, exported, capsys
):
    runner = _python_runner()

    def with_prediction(L, Y, R, A, Q, P0, exponent, smoother):  # P_pred, Q added twice at 2
        outputs = runner.my_skf(L, Y, R, A, Q, P0, exponent, smoother)
        P, P_pred = P0, []
        for t in range(Y.shape[1]):
            P_t = A @ P @ A.T + Q * (2 if t == 1 else 1)
            K = np.linalg.solve(L @ P_t @ L.T + R, L @ P_t).T
            P = P_t - K @ L @ P_t
            P_pred.append(P_t)
        return outputs | {"P_pred": np.stack(P_pred, axis=-1), "mine": 1.0}

    done = runner.run(exported, tmp_path / "mine", with_prediction)
    assert sorted(np.load(done[0][1]).files) == sorted([*OUTPUTS, "P_pred"])
    capsys.readouterr()
    assert runner.compare_all(done[:1]) == 1
    out = capsys.readouterr().out
    assert "First divergence: prediction (P_pred) at step 2" in out


# --- the command line -------------------------------------------------------------------------


def test_command_line_export(tmp_path, capsys):
    folder = tmp_path / "cases"
    assert main(["conformance", "export", str(folder), "--format", "npz"]) == 0
    err = capsys.readouterr().err
    assert f"wrote {len(CASES)} case files, the runners run_cases.m and run_cases.py" in err
    assert f"suite version {CONFORMANCE_VERSION}, computed by skf_ref" in err
    assert len(list(folder.glob("*.npz"))) == len(CASES) and not list(folder.glob("*.mat"))
    assert (folder / "manifest.json").read_bytes() == (SUITE / "manifest.json").read_bytes()


def test_the_parser_knows_the_formats():
    from skf_ref.cli import _conformance as conformance

    assert conformance._FORMATS == FORMATS


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["conformance", "export", "out", "--format", "xlsx"], "argument --format: invalid"),
        (["conformance", "export", "a_file"], "a_file is a file: give a folder"),
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
