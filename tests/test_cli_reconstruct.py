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
    assert settings["smoother"] == "none" and "versions" in settings["machine"]
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
