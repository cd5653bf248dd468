"""Hypothesis profiles (a reproducible default run, an opt-in exploration) and MNE fixtures."""

import numpy as np
import pytest
from hypothesis import settings

# The default run (and CI) draws the same examples every time: a red run can be rerun. 25
# models a property in the default run (its time budget); CI draws 150 of each again
# (``--hypothesis-profile=thorough -m property``).
settings.register_profile("default", max_examples=25, deadline=None, derandomize=True)
settings.register_profile("thorough", max_examples=150, deadline=None, derandomize=True)
# ``--hypothesis-profile=explore``: thousands of fresh models, and hypothesis's example
# database keeps any failure it finds for the next run.
settings.register_profile("explore", max_examples=5000, deadline=None)
settings.load_profile("default")


def pytest_collection_modifyitems(items):
    """Every hypothesis test is marked ``property`` (CI runs them again, thoroughly)."""
    for item in items:
        if getattr(getattr(item, "obj", None), "is_hypothesis_test", False):
            item.add_marker(pytest.mark.property)


# --- MNE objects made here (no dataset needed) ----------------------------------------------


@pytest.fixture(scope="session")
def mne_setup():
    """A biosemi64 sphere forward on a 12 mm volume grid, and a noise-free dipole field.

    Returns a dict: ``info`` (EEG, montage), ``sphere``, ``forward`` (free orientation),
    ``positions`` (n, 3) m, ``make_epochs(target, seed)`` -> 30 average-referenced epochs of
    one dipole at grid position ``target`` with 5 uV noise, peak SNR 20 dB in the average.
    """
    import mne

    montage = mne.channels.make_standard_montage("biosemi64")
    info = mne.create_info(montage.ch_names, 1000.0, "eeg")
    info.set_montage(montage)
    sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    src = mne.setup_volume_source_space(sphere=sphere, pos=12.0, mindist=5.0, verbose=False)
    forward = mne.make_forward_solution(
        info, None, src, sphere, eeg=True, meg=False, verbose=False
    )
    positions = src[0]["rr"][src[0]["vertno"]]
    times = np.arange(60) / 1000.0 - 0.02
    wave = np.where(times > 0, np.sin(np.pi * np.clip(times, 0, 0.03) / 0.03), 0.0)

    def make_epochs(target, seed, n_epochs=30, noise=5e-6):
        rng = np.random.default_rng(seed)
        orientation = rng.standard_normal(3)
        orientation /= np.linalg.norm(orientation)
        gain = forward["sol"]["data"][:, 3 * target : 3 * target + 3] @ orientation
        amplitude = 10 * noise / np.sqrt(n_epochs) / np.abs(gain - gain.mean()).max()
        signal = gain[:, None] * amplitude * wave[None]
        data = signal[None] + noise * rng.standard_normal((n_epochs, *signal.shape))
        epochs = mne.EpochsArray(data, info, tmin=times[0], verbose=False)
        epochs.set_eeg_reference("average", projection=True, verbose=False)
        return epochs

    return dict(
        info=info,
        sphere=sphere,
        forward=forward,
        positions=positions,
        times=times,
        peak=int(np.argmax(wave)),
        make_epochs=make_epochs,
    )


# --- the command line, in this process ------------------------------------------------------


@pytest.fixture
def cli(capsys):
    """Run ``skf-ref`` in this process: ``cli("demo", "--out", ...)`` returns its exit status,
    standard output and error, and every warning it raised (a warning would be printed around
    the command's output in a terminal). The console script itself is run in a subprocess by
    a few tests of its own."""
    import warnings
    from types import SimpleNamespace

    from skf_ref.cli import main

    def run(*arguments):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            status = main(list(arguments))
        out, err = capsys.readouterr()
        return SimpleNamespace(returncode=status, stdout=out, stderr=err, warnings=caught)

    return run
