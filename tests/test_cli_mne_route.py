"""``skf-ref reconstruct`` on MNE files: nave, epochs averaged, channel types, priors searched."""

import json

import mne
import numpy as np
import pytest

from skf_ref import apply_skf


@pytest.fixture(scope="module")
def files(tmp_path_factory, mne_setup):
    folder = tmp_path_factory.mktemp("mne-route")
    epochs = mne_setup["make_epochs"](target=300, seed=9)
    mne.write_forward_solution(folder / "f-fwd.fif", mne_setup["forward"], verbose=False)
    mne.write_cov(
        folder / "n-cov.fif", mne.compute_covariance(epochs, tmax=0, verbose=False), verbose=False
    )
    epochs.save(folder / "e-epo.fif", verbose=False)
    mne.write_evokeds(folder / "e-ave.fif", epochs.average(), verbose=False)
    long = mne.EpochsArray(
        np.concatenate([epochs.get_data()] * 3, axis=2),
        mne_setup["info"],
        tmin=-0.14,
        verbose=False,
    )
    long.set_eeg_reference("average", projection=True, verbose=False)
    mne.write_evokeds(folder / "long-ave.fif", long.average(), verbose=False)
    return folder


def _arguments(files, evoked="e-ave.fif", noise=("--noise-cov", "n-cov.fif")):
    noise = [str(files / a) if a.endswith(".fif") else a for a in noise]
    return [
        "reconstruct",
        "--forward",
        str(files / "f-fwd.fif"),
        "--evoked",
        str(files / evoked),
        *noise,
    ]


def _read(path):
    return mne.read_source_estimate(path), json.loads(
        path.with_name(path.name[:-7] + ".stc.json").read_text()
    )


def test_an_epochs_file_is_averaged_and_says_so(cli, files, tmp_path):
    result = cli(*_arguments(files, "e-epo.fif"), "--out", str(tmp_path / "e.stc"))
    assert result.returncode == 0, result.stderr
    assert (
        "e-epo.fif: epochs, averaged: 30 epochs, so the noise covariance is divided by "
        "nave = 30" in result.stderr
    )
    stc = mne.read_source_estimate(tmp_path / "e-vl.stc")
    settings = json.loads((tmp_path / "e.stc.json").read_text())
    epochs = mne.read_epochs(files / "e-epo.fif", proj=False, verbose=False)
    forward = mne.read_forward_solution(files / "f-fwd.fif", verbose=False)
    expected = apply_skf(
        epochs.average(), forward, mne.read_cov(files / "n-cov.fif", verbose=False)
    )
    np.testing.assert_allclose(stc.data, expected.data, rtol=1e-5)  # .stc is float32
    assert settings["nave"] == 30 and settings["meg"] is None and settings["eeg"] is None


def test_an_evokeds_nave_divides_the_covariance_and_is_recorded(cli, files, tmp_path):
    result = cli(*_arguments(files), "--out", str(tmp_path / "a.stc"), "--quiet")
    assert result.returncode == 0 and result.stderr == ""
    assert json.loads((tmp_path / "a.stc.json").read_text())["nave"] == 30


def test_a_baseline_on_the_mne_route_is_the_averages_own(cli, files, tmp_path):
    result = cli(
        *_arguments(files, "long-ave.fif", ("--baseline",)),
        "--out",
        str(tmp_path / "b.stc"),
        "--quiet",
    )
    assert result.returncode == 0, result.stderr
    evoked = mne.read_evokeds(files / "long-ave.fif", proj=False, verbose=False)[0]
    forward = mne.read_forward_solution(files / "f-fwd.fif", verbose=False)
    expected = apply_skf(evoked, forward, "baseline")
    np.testing.assert_allclose(
        mne.read_source_estimate(tmp_path / "b-vl.stc").data, expected.data, rtol=1e-5
    )


@pytest.mark.filterwarnings("ignore:tune. (pm|ep)_snr_db")
def test_priors_searched_over_a_range_from_the_command_line(cli, files, tmp_path):
    result = cli(*_arguments(files), "--pm-snr-db", "-40,20", "--out", str(tmp_path / "r.stc"))
    assert result.returncode == 0, result.stderr
    assert "priors chosen by the data: PM-SNR" in result.stderr
    settings = json.loads((tmp_path / "r.stc.json").read_text())
    assert settings["priors_searched"] == {
        "pm_snr_db": [-40.0, 20.0],
        "ep_snr_db": None,
        "time_constant_ms": "auto",
    }  # the default evolution prior: the AR(1) prior, its time constant searched too
    assert -40 <= settings["pm_snr_db"] <= 20
    assert settings["ep_snr_db"] is None and 1.0 <= settings["time_constant_ms"] <= 1000.0


@pytest.mark.parametrize(
    "extra, message",
    [
        (
            ["--pm-snr-db", "20,-40"],
            "argument --pm-snr-db: must be a range LOW,HIGH with LOW < HIGH, got '20,-40'",
        ),
        (["--ep-snr-db", "1,2,3"], "argument --ep-snr-db: must be one number, auto or LOW"),
        (["--no-eeg"], "no MEG channel is common to the data"),
        (["--meg"], "argument --meg: asks for grad/mag channels, but none is common"),
    ],
)
def test_types_and_ranges_are_checked_in_one_line(cli, files, tmp_path, extra, message):
    result = cli(*_arguments(files), *extra, "--out", str(tmp_path / "x.stc"))
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert message in result.stderr
    assert not any(tmp_path.iterdir())


def test_types_are_flags_of_the_mne_route_only(cli, files, tmp_path):
    arguments = [
        "reconstruct",
        "--leadfield",
        str(files / "f-fwd.fif"),
        "--data",
        str(files / "e-ave.fif"),
        "--noise-std",
        "1e-6",
        "--out",
        str(tmp_path / "a.npz"),
    ]
    result = cli(*arguments, "--no-meg")
    assert result.returncode == 2
    assert "argument --meg: channel types are picked on the MNE route only" in result.stderr
