"""The two options through the MNE routes and the command line (docs/model.md §2-3)."""

import json

import mne
import numpy as np
import pytest

from skf_ref import InputError, apply_skf, apply_skf_epochs, make_skf_operator, reconstruct
from skf_ref.cli import main


@pytest.fixture(scope="module")
def problem(mne_setup):
    epochs = mne_setup["make_epochs"](target=300, seed=0)
    return mne_setup, epochs, mne.compute_covariance(epochs, tmax=0, verbose=False)


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@pytest.mark.parametrize("smoother", [None, "rts-smoothed-weights"])
def test_apply_skf_takes_the_orientations_from_the_forward(problem, smoother):
    setup, epochs, cov = problem
    evoked = epochs.average()
    settings = dict(smoother=smoother, standardize="position")
    walk = dict(ep_snr_db=0.0)  # fixed priors: the operator below makes the same ones
    stc, rec = apply_skf(
        evoked, setup["forward"], cov, return_reconstruction=True, **walk, **settings
    )
    assert rec.standardize == "position" and rec.n_orient == 3
    assert rec.smoother == smoother
    # the operator's whitened data through reconstruct, the same numbers
    operator = make_skf_operator(evoked.info, setup["forward"], cov, **walk, verbose=False)
    data = operator.select(evoked.info, evoked.data, "evoked") * np.sqrt(evoked.nave)
    direct = reconstruct(
        operator.leadfield, operator.whitener @ data, noise_std=1.0, theta0=rec.theta0, q=rec.q,
        n_orient=3, path="spectral", **settings,
    )  # fmt: skip
    assert relative(rec.z, direct.z) < 1e-10
    vector = apply_skf(evoked, setup["forward"], cov, pick_ori="vector", **walk, **settings)
    np.testing.assert_allclose(np.linalg.norm(vector.data, axis=1), stc.data, rtol=1e-12)


def test_epochs_and_their_operator(problem):
    setup, epochs, cov = problem
    operator = make_skf_operator(epochs.info, setup["forward"], cov, verbose=False)
    estimates = apply_skf_epochs(epochs[:2], operator, standardize="position")
    for k, stc in enumerate(estimates):
        data = operator.select(epochs.info, epochs[k].get_data()[0], "epoch")
        rec = operator.reconstruct(data, standardize="position")
        np.testing.assert_allclose(stc.data, rec.amplitude(3), rtol=1e-12)
    with pytest.raises(InputError, match=r"standardize must be one of \['column', 'position'\]"):
        apply_skf_epochs(epochs[:1], operator, standardize="positions")


@pytest.mark.slow  # 14 s; its fast sibling: test_standardize_position's exact localization
def test_a_dipole_of_any_orientation_is_localized(mne_setup):
    # As test_apply.test_a_dipole_is_localized (the numbers of apply_skf's docstring), with
    # each position standardized as a whole: the largest error falls (69 to 29 mm for the
    # filter), and with the smoother standardized by its own variance every dipole is found
    # within one grid step (median 0 mm; the column form's median is 17 mm).
    errors = {"column": [], "position": [], "position, rts-smoothed-weights": []}
    for target in range(50, len(mne_setup["positions"]), 150):
        epochs = mne_setup["make_epochs"](target, seed=target)
        evoked, cov = epochs.average(), mne.compute_covariance(epochs, tmax=0, verbose=False)
        for name in errors:
            standardize, _, smoother = name.partition(", ")
            stc = apply_skf(
                evoked, mne_setup["forward"], cov, standardize=standardize,
                smoother=smoother or None, ep_snr_db=20.0,
            )  # fmt: skip
            best = np.argmax(stc.data[:, mne_setup["peak"]])
            distance = np.linalg.norm(
                mne_setup["positions"][best] - mne_setup["positions"][target]
            )
            errors[name].append(distance * 1e3)
    step = 12.0 + 1e-6  # the grid's spacing
    assert max(errors["position"]) < max(errors["column"])
    assert max(errors["position, rts-smoothed-weights"]) <= step
    assert np.median(errors["position, rts-smoothed-weights"]) < np.median(errors["column"])


def _write_arrays(folder, mne_setup, evoked):
    L = mne_setup["forward"]["sol"]["data"]
    np.save(folder / "L.npy", L)
    np.savez(folder / "L_pos.npz", data=L, positions=mne_setup["positions"])
    np.save(folder / "Y.npy", evoked.data)


def test_command_line(problem, tmp_path):
    setup, epochs, cov = problem
    evoked = epochs.average()
    _write_arrays(tmp_path, setup, evoked)
    common = ["reconstruct", "--data", str(tmp_path / "Y.npy"), "--noise-std", "1e-6"]
    common += ["--average-reference", "--quiet", "--standardize", "position"]
    out = tmp_path / "a.npz"
    arguments = [*common, "--leadfield", str(tmp_path / "L.npy"), "--n-orient", "3"]
    assert main([*arguments, "--smoother", "rts-smoothed-weights", "--out", str(out)]) == 0
    saved = np.load(out)
    assert str(saved["standardize"]) == "position" and int(saved["n_orient"]) == 3
    assert str(saved["smoother"]) == "rts-smoothed-weights"
    # the positions of the file tell the orientations
    out = tmp_path / "b.npz"
    arguments = [*common, "--leadfield", str(tmp_path / "L_pos.npz"), "--key", "data"]
    assert main([*arguments, "--out", str(out)]) == 0
    assert int(np.load(out)["n_orient"]) == 3


def test_command_line_refuses_what_it_cannot_know(problem, tmp_path, capsys):
    setup, epochs, cov = problem
    _write_arrays(tmp_path, setup, epochs.average())
    arguments = ["reconstruct", "--leadfield", str(tmp_path / "L.npy"), "--data"]
    arguments += [str(tmp_path / "Y.npy"), "--noise-std", "1e-6", "--average-reference"]
    arguments += ["--standardize", "position", "--out", str(tmp_path / "c.npz")]
    assert main(arguments) == 2
    err = capsys.readouterr().err
    assert "--standardize position needs the columns per source position" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "c.npz").exists()
    # the MNE route takes them from the forward, and refuses another number
    mne.write_forward_solution(tmp_path / "f-fwd.fif", setup["forward"], verbose=False)
    mne.write_evokeds(tmp_path / "e-ave.fif", epochs.average(), verbose=False)
    mne.write_cov(tmp_path / "n-cov.fif", cov, verbose=False)
    arguments = ["reconstruct", "--forward", str(tmp_path / "f-fwd.fif"), "--evoked"]
    arguments += [str(tmp_path / "e-ave.fif"), "--noise-cov", str(tmp_path / "n-cov.fif")]
    arguments += ["--standardize", "position", "--quiet"]
    assert main([*arguments, "--n-orient", "1", "--out", str(tmp_path / "d.stc")]) == 2
    assert "the forward has 3 column(s) per position, got 1" in capsys.readouterr().err
    assert main([*arguments, "--out", str(tmp_path / "e.stc")]) == 0
    settings = json.loads((tmp_path / "e.stc.json").read_text())
    assert settings["standardize"] == "position"
