"""``method=`` chose the computational path until 0.6.0; MNE users mean an inverse method by
it. For one release it raises, naming ``path=``, on every SKF entry that took it."""

import subprocess
import sys

import numpy as np
import pytest

import skf_ref

ENTRIES = {
    "reconstruct": lambda: skf_ref.reconstruct(np.eye(2), np.ones((2, 3)), method="dense"),
    "apply_skf": lambda: skf_ref.apply_skf(None, None, method="sLORETA"),
    "apply_skf_epochs": lambda: skf_ref.apply_skf_epochs(None, None, method="dSPM"),
    "apply_skf_raw": lambda: skf_ref.apply_skf_raw(None, None, method="spectral"),
    "SKFOperator.reconstruct": lambda: skf_ref.SKFOperator.reconstruct(None, None, method="x"),
}


@pytest.mark.parametrize("entry", ENTRIES)
def test_method_is_refused_naming_path(entry):
    with pytest.raises(skf_ref.InputTypeError, match=r"method= was renamed path= in skf_ref 0\.6"):
        ENTRIES[entry]()


def test_path_is_the_new_name():
    rec = skf_ref.reconstruct(np.eye(2), np.ones((2, 3)), noise_std=1.0, theta0=1.0, q=0.1,
                              path="dense")  # fmt: skip
    assert rec.path == "dense" and rec.settings["path"] == "dense"


def test_the_command_line_refuses_method_in_one_line(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "skf_ref.cli", "reconstruct", "--method", "dense",
         "--leadfield", "L.npy", "--data", "Y.npy", "--out", "out.npz"],
        capture_output=True, text=True, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "--method was renamed --path" in result.stderr
    assert not list(tmp_path.iterdir())
