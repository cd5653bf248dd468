"""``skf-ref reconstruct``: MNE files or arrays in, an estimate out; bad input in one line."""

import json
import os
import subprocess
import sys
from pathlib import Path

import mne
import numpy as np
import pytest

from skf_ref import apply_skf
from skf_ref.cli import main

ENV = os.environ | {"PYTHONPATH": str(Path(__file__).resolve().parents[1]), "MPLBACKEND": "Agg"}


@pytest.fixture(scope="module")
def files(tmp_path_factory, mne_setup):
    folder = tmp_path_factory.mktemp("reconstruct")
    epochs = mne_setup["make_epochs"](target=300, seed=6)
    evoked = epochs.average()
    mne.write_evokeds(folder / "e-ave.fif", evoked, verbose=False)
    mne.write_forward_solution(folder / "f-fwd.fif", mne_setup["forward"], verbose=False)
    cov = mne.compute_covariance(epochs, tmax=0, verbose=False)
    mne.write_cov(folder / "n-cov.fif", cov, verbose=False)
    np.save(folder / "L.npy", mne_setup["forward"]["sol"]["data"])
    np.save(folder / "L_short.npy", mne_setup["forward"]["sol"]["data"][:50])
    data = evoked.data.copy()
    np.save(folder / "Y.npy", data)
    data[0, 3] = np.nan
    np.save(folder / "Y_nan.npy", data)
    mastoid = evoked.copy().del_proj().set_eeg_reference(["P9", "P10"], verbose=False)
    mne.write_evokeds(folder / "m-ave.fif", mastoid, verbose=False)
    # made anew: MNE's rename_channels on a copy renames the original's projector too
    info = mne.create_info([f"X{name}" for name in evoked.ch_names], 1000.0, "eeg")
    renamed = mne.EvokedArray(evoked.data, info, verbose=False)
    mne.write_evokeds(folder / "r-ave.fif", renamed, verbose=False)
    return folder


@pytest.mark.slow  # over 10 s: CI runs it with the slow tests
def test_mne_route_writes_the_estimate_its_settings_and_a_figure(files, tmp_path):
    out = tmp_path / "est.stc"
    arguments = ["reconstruct", "--forward", str(files / "f-fwd.fif"), "--evoked"]
    arguments += [str(files / "e-ave.fif"), "--noise-cov", str(files / "n-cov.fif")]
    assert main([*arguments, "--out", str(out), "--plot", str(tmp_path / "e.png"), "--quiet"]) == 0
    written = mne.read_source_estimate(tmp_path / "est-vl.stc")
    evoked = mne.read_evokeds(files / "e-ave.fif", proj=False, verbose=False)[0]
    expected = apply_skf(evoked, mne_setup_forward(files), mne.read_cov(files / "n-cov.fif"))
    np.testing.assert_allclose(written.data, expected.data, rtol=1e-5)  # .stc is float32
    settings = json.loads((tmp_path / "est.stc.json").read_text())
    assert settings["route"] == "mne" and settings["exponent"] == 0.5
    assert settings["smoother"] == "rts-smoothed-weights" and "versions" in settings["machine"]
    # the rule's setting where the forward gives the orientations and the rate
    assert settings["standardize"] == "position" and settings["ep_snr_db"] is None
    assert 1.0 <= settings["time_constant_ms"] <= 1000.0
    assert (tmp_path / "e.png").read_bytes()[:4] == b"\x89PNG"


def mne_setup_forward(files):
    return mne.read_forward_solution(files / "f-fwd.fif", verbose=False)


def test_array_route_writes_arrays(files, tmp_path):
    out = tmp_path / "a.npz"
    arguments = ["reconstruct", "--leadfield", str(files / "L.npy"), "--data"]
    arguments += [str(files / "Y.npy"), "--noise-std", "1e-6", "--smoother", "rts-state"]
    assert main([*arguments, "--out", str(out), "--quiet"]) == 0
    saved = np.load(out)
    assert saved["z"].shape == (3762, 60) and str(saved["smoother"]) == "rts-state"
    # an array does not say which columns form a position: each column on its own
    assert str(saved["standardize"]) == "column"


def _cli(*arguments):
    return subprocess.run(
        [sys.executable, "-m", "skf_ref.cli", "reconstruct", *arguments],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=120,
    )


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--forward", "nofile-fwd.fif", "--evoked", "e-ave.fif"], "nofile-fwd.fif: no such file"),
        (["--leadfield", "L.npy", "--data", "Y.xyz"], "Y.xyz: no such file"),
        (["--forward", "L.npy", "--evoked", "e-ave.fif"], "L.npy is not an MNE -fwd.fif"),
        (["--forward", "f-fwd.fif", "--evoked", "r-ave.fif"], "no EEG channel is common"),
        (["--forward", "f-fwd.fif", "--evoked", "m-ave.fif"], "custom EEG reference other than"),
        (["--leadfield", "L.npy", "--data", "Y_nan.npy"], "Y_nan.npy contains NaN"),
        (["--leadfield", "L_short.npy", "--data", "Y.npy"], "--leadfield: 50 rows, but --data"),
        (
            ["--forward", "f-fwd.fif", "--evoked", "e-ave.fif", "--condition", "nine"],
            "no condition 'nine'",
        ),
        (["--forward", "f-fwd.fif"], "needs both --forward and --evoked"),
        (["--leadfield", "L.npy", "--data", "Y.npy", "--out", "x.stc"], "array route writes"),
    ],
)
def test_bad_input_is_one_line_and_leaves_no_file(cli, files, tmp_path, arguments, message):
    arguments = [str(files / a) if a.endswith((".fif", ".npy")) else a for a in arguments]
    noise = [] if "--noise-std" in arguments else ["--noise-std", "1e-6"]
    out = [] if "--out" in arguments else ["--out", str(tmp_path / "out.npz")]
    result = cli("reconstruct", *arguments, *noise, *out)
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert message in result.stderr
    assert not any(tmp_path.iterdir())


def test_help_lets_a_newcomer_run_it():
    result = _cli("--help")
    assert result.returncode == 0
    for flag in ("--forward", "--leadfield", "--noise-cov", "--baseline", "--plot", "examples:"):
        assert flag in result.stdout


# --- every output checked before any work; nothing but one line around an error -------------


@pytest.fixture(scope="module")
def more_files(files, mne_setup):
    folder = files / "more"
    folder.mkdir()
    forward = mne.read_forward_solution(files / "f-fwd.fif", verbose=False)
    # an MNE file named against MNE's conventions: MNE warns when it reads it
    with pytest.warns(RuntimeWarning, match="does not conform to MNE naming"):
        mne.write_forward_solution(folder / "forward.fif", forward, verbose=False)
    kept = [name for name in forward.ch_names if name != "Oz"]
    mne.write_forward_solution(
        folder / "no-oz-fwd.fif", mne.pick_channels_forward(forward, kept), verbose=False
    )
    cov = mne.read_cov(files / "n-cov.fif", verbose=False)
    for name, data in (("negative", -cov.data), ("nan", np.where(cov.data > 0, np.nan, 0))):
        bad = mne.Covariance(data, cov["names"], [], cov["projs"], cov["nfree"], verbose=False)
        mne.write_cov(folder / f"{name}-cov.fif", bad, verbose=False)
    evoked = mne.read_evokeds(files / "e-ave.fif", verbose=False)[0]
    evoked.info["bads"] = evoked.ch_names[1:]
    mne.write_evokeds(folder / "one-ave.fif", evoked, verbose=False)
    return folder


@pytest.mark.parametrize(
    "plot, message",
    [
        ("x.txt", "argument --plot: {}: a figure is written to"),
        ("nodir/p.png", "argument --plot: {}: the folder"),
    ],
)
def test_output_paths_are_checked_before_any_work(cli, files, tmp_path, plot, message):
    out, plot = tmp_path / "est.stc", tmp_path / plot
    arguments = ["--forward", str(files / "f-fwd.fif"), "--evoked", str(files / "e-ave.fif")]
    result = cli("reconstruct", *arguments, "--noise-std", "1e-6", "--out", str(out), "--plot",
                 str(plot))  # fmt: skip
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert message.format(plot) in result.stderr
    assert not any(tmp_path.iterdir())  # no estimate written before the figure failed


def test_a_missing_output_folder_is_named_as_given(cli, files, tmp_path):
    out = tmp_path / "nodir" / "a.npz"
    arguments = ["--leadfield", str(files / "L.npy"), "--data", str(files / "Y.npy")]
    result = cli("reconstruct", *arguments, "--noise-std", "1e-6", "--out", str(out))
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert f"argument --out: {out}: the folder {out.parent} does not exist" in result.stderr


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--evoked", "m-ave.fif", "--forward", "more/forward.fif", "--noise-std", "1e-6"],
         "custom EEG reference"),
        (["--noise-cov", "more/negative-cov.fif"],
         "argument --noise-cov: {files}/more/negative-cov.fif: noise_cov must be positive semi"),
        (["--noise-cov", "more/nan-cov.fif"], "noise_cov contains NaN or Inf"),
        (["--evoked", "more/one-ave.fif", "--noise-std", "1e-6"], "one EEG channel, 'Fp1', is"),
    ],
)  # fmt: skip
def test_input_mne_refuses_or_warns_about_is_one_line(cli, files, more_files, tmp_path,
                                                       arguments, message):  # fmt: skip
    given = dict(zip(arguments[::2], arguments[1::2], strict=True))
    inputs = {"--forward": "f-fwd.fif", "--evoked": "e-ave.fif"} | given
    inputs = [
        a
        for flag, name in inputs.items()
        for a in (flag, str(files / name) if name.endswith(".fif") else name)
    ]
    result = cli("reconstruct", *inputs, "--out", str(tmp_path / "e.stc"))
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1 and message.format(files=files) in result.stderr
    assert not result.warnings, [str(w.message) for w in result.warnings]
    assert not any(tmp_path.iterdir())


def test_the_channels_used_and_left_out_are_in_the_settings(cli, files, more_files, tmp_path):
    out = tmp_path / "e.npz"
    arguments = ["--forward", str(more_files / "no-oz-fwd.fif"), "--evoked"]
    arguments += [str(files / "e-ave.fif"), "--noise-cov", str(files / "n-cov.fif")]
    result = cli("reconstruct", *arguments, "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert "63 channels used; not in the forward: Oz" in result.stderr
    channels = json.loads((tmp_path / "e.npz.json").read_text())["channels"]
    assert channels["left_out"] == {"not in the forward": ["Oz"]} and len(channels["used"]) == 63


# --- outputs a user can trust: nothing replaced unless asked, no input ever -----------------


def _array_route(files, out, *more):
    return ["reconstruct", "--leadfield", str(files / "L.npy"), "--data", str(files / "Y.npy"),
            "--noise-std", "1e-6", "--out", str(out), *more]  # fmt: skip


@pytest.mark.parametrize("existing", ["out", "settings", "plot"])
def test_an_existing_output_is_replaced_only_with_overwrite(cli, files, tmp_path, existing):
    out, plot = tmp_path / "a.npz", tmp_path / "a.png"
    path = {"out": out, "settings": tmp_path / "a.npz.json", "plot": plot}[existing]
    path.write_text("a result of the user's")
    result = cli(*_array_route(files, out, "--plot", str(plot)))
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert f"{path} exists: give --overwrite to replace it" in result.stderr
    assert path.read_text() == "a result of the user's"
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # refused before any work
    result = cli(*_array_route(files, out, "--plot", str(plot), "--overwrite", "--quiet"))
    assert result.returncode == 0, result.stderr
    assert np.load(out)["z"].shape == (3762, 60) and plot.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("flag", ["--data", "--leadfield"])
def test_an_output_that_is_an_input_is_refused(cli, files, tmp_path, flag):
    import shutil

    for name in ("L.npy", "Y.npy"):
        shutil.copy(files / name, tmp_path / name)
    given = tmp_path / ("Y.npy" if flag == "--data" else "L.npy")
    out = tmp_path / "result.npz"
    out.symlink_to(given)  # the output's name leads to the input
    before = given.read_bytes()
    arguments = ["reconstruct", "--leadfield", str(tmp_path / "L.npy"), "--data"]
    arguments += [str(tmp_path / "Y.npy"), "--noise-std", "1e-6", "--out", str(out)]
    result = cli(*arguments, "--overwrite")
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert f"argument --out: {out} is the input {flag}" in result.stderr
    assert given.read_bytes() == before


@pytest.mark.parametrize("flag", ["--out", "--plot"])
def test_a_folder_where_a_file_goes_is_refused_before_any_work(cli, files, tmp_path, flag):
    folder = tmp_path / ("a.npz" if flag == "--out" else "a.png")
    folder.mkdir()
    out = folder if flag == "--out" else tmp_path / "b.npz"
    result = cli(*_array_route(files, out, "--plot", str(tmp_path / "a.png")))
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert f"argument {flag}: {folder} is a folder; give a file name" in result.stderr
    assert ".skf-tmp" not in result.stderr
    assert [p.name for p in tmp_path.iterdir()] == [folder.name] and not any(folder.iterdir())


def test_a_vector_estimate_to_stc_is_refused_before_any_work(cli, files, tmp_path):
    arguments = ["reconstruct", "--forward", str(files / "f-fwd.fif"), "--evoked"]
    arguments += [str(files / "e-ave.fif"), "--noise-std", "1e-6", "--pick-ori", "vector"]
    result = cli(*arguments, "--out", str(tmp_path / "v.stc"))
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert "MNE writes a vector source estimate (--pick-ori vector) to .h5 only" in result.stderr
    assert not any(tmp_path.iterdir())
    assert cli(*arguments, "--out", str(tmp_path / "v.h5"), "--quiet").returncode == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v-stc.h5", "v.h5.json"]


def test_an_estimate_in_stc_files_is_not_replaced_without_overwrite(cli, files, tmp_path):
    (tmp_path / "e-vl.stc").write_text("an earlier estimate")  # what --out e.stc writes
    arguments = ["reconstruct", "--forward", str(files / "f-fwd.fif"), "--evoked"]
    arguments += [
        str(files / "e-ave.fif"),
        "--noise-std",
        "1e-6",
        "--out",
        str(tmp_path / "e.stc"),
    ]
    result = cli(*arguments)
    assert result.returncode == 2 and f"{tmp_path / 'e-vl.stc'} exists: give --overwrite" in (
        result.stderr
    )
    assert cli(*arguments, "--overwrite", "--quiet").returncode == 0
    assert mne.read_source_estimate(tmp_path / "e-vl.stc").data.shape[1] == 60
