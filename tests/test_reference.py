"""References as MNE users make them: the same estimate whatever route gave the data theirs.

MNE's default, ``set_eeg_reference("average", projection=False)``, references the data and
records a custom reference; ``projection=True`` adds a projector instead. MNE stores both
in float32. Each of these, in memory or saved and read back, gives the estimate of the
projector route, in apply_skf and on the command line.
"""

import json

import mne
import numpy as np
import pytest

from skf_ref import InputError, apply_skf, reconstruct

# float32 storage rounds the data by 6e-8 of their size; the estimate is linear in them
# (the weights do not depend on the data) and moved by 3e-8 in a probe: 1e-6 is the bar.
REFERENCE_RTOL = 1e-6


@pytest.fixture(scope="module")
def evoked(mne_setup):
    return mne_setup["make_epochs"](target=400, seed=11).average().del_proj()


@pytest.fixture(scope="module")
def by_projector(evoked, mne_setup):
    with_projector = evoked.copy().set_eeg_reference("average", projection=True, verbose=False)
    return apply_skf(with_projector, mne_setup["forward"], noise_std=5e-6).data


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def _referenced(evoked, projection, how, tmp_path):
    referenced = evoked.copy().set_eeg_reference("average", projection=projection, verbose=False)
    if how == "file":  # float32 in the file, float64 again when read
        mne.write_evokeds(tmp_path / "r-ave.fif", referenced, overwrite=True, verbose=False)
        return mne.read_evokeds(tmp_path / "r-ave.fif", proj=False, verbose=False)[0]
    if how == "float32":
        data = referenced.data.astype(np.float32)
        return mne.EvokedArray(
            data, referenced.info, tmin=referenced.times[0], nave=referenced.nave, verbose=False
        )
    return referenced


@pytest.mark.parametrize("how", ["memory", "file", "float32"])
@pytest.mark.parametrize("projection", [False, True])
def test_every_average_reference_gives_the_projector_estimate(
    evoked, by_projector, mne_setup, tmp_path, projection, how
):
    referenced = _referenced(evoked, projection, how, tmp_path)
    assert bool(referenced.info["custom_ref_applied"]) is not projection
    stc = apply_skf(referenced, mne_setup["forward"], noise_std=5e-6)
    assert relative(stc.data, by_projector) < REFERENCE_RTOL


def test_the_command_line_reads_mne_s_default_reference(
    cli, evoked, by_projector, mne_setup, tmp_path
):
    _referenced(evoked, False, "file", tmp_path)  # r-ave.fif, as MNE saves it
    mne.write_forward_solution(tmp_path / "f-fwd.fif", mne_setup["forward"], verbose=False)
    out = tmp_path / "e.h5"
    arguments = ["--forward", str(tmp_path / "f-fwd.fif"), "--evoked", str(tmp_path / "r-ave.fif")]
    result = cli("reconstruct", *arguments, "--noise-std", "5e-6", "--out", str(out), "--quiet")
    assert result.returncode == 0, result.stderr
    written = mne.read_source_estimate(tmp_path / "e-stc.h5")
    assert relative(written.data, by_projector) < REFERENCE_RTOL  # forward read as float32 too
    channels = json.loads((tmp_path / "e.h5.json").read_text())["channels"]
    assert len(channels["used"]) == 64 and channels["left_out"] == {}


def test_only_the_good_channels_need_be_referenced(evoked, by_projector, mne_setup):
    # referenced over its 64 channels, then one marked bad: the 63 others differ from their
    # own average reference by a common signal, which the projector removes exactly
    referenced = evoked.copy().set_eeg_reference("average", verbose=False)
    referenced.info["bads"] = ["Oz"]
    with_projector = evoked.copy().set_eeg_reference("average", projection=True, verbose=False)
    with_projector.info["bads"] = ["Oz"]
    expected = apply_skf(with_projector, mne_setup["forward"], noise_std=5e-6).data
    stc = apply_skf(referenced, mne_setup["forward"], noise_std=5e-6)
    assert relative(stc.data, expected) < REFERENCE_RTOL


def _float32_problem(seed=0):
    rng = np.random.default_rng(seed)
    L = rng.standard_normal((32, 60))
    Y = L[:, [7]] * np.hanning(9) + 0.1 * rng.standard_normal((32, 9))
    return L, Y


def test_a_float32_lead_field_the_user_referenced_is_accepted():
    # as MNE stores a forward: float32, referenced in float32 (column means ~3e-8 of their
    # size), with data referenced in double precision
    L, Y = _float32_problem()
    L32 = L.astype(np.float32)
    L32 -= L32.mean(axis=0)
    Y -= Y.mean(axis=0)
    rec = reconstruct(L32, Y, noise_std=0.1, theta0=1.0, q=0.1)
    exact = reconstruct(L - L.mean(axis=0), Y, noise_std=0.1, theta0=1.0, q=0.1)
    assert relative(rec.z, exact.z) < 1e-5  # the float32 lead field's rounding, amplified


def test_float32_referenced_data_with_an_unreferenced_lead_field_are_refused():
    L, Y = _float32_problem()
    Y32 = (Y - Y.mean(axis=0)).astype(np.float32)
    with pytest.raises(InputError, match="Y is average referenced .* but L is not"):
        reconstruct(L, Y32, noise_std=0.1, theta0=1.0, q=0.1)


def test_a_float32_evoked_array_is_accepted(evoked, by_projector, mne_setup):
    referenced = evoked.copy().set_eeg_reference("average", verbose=False)
    info = mne.create_info(evoked.ch_names, evoked.info["sfreq"], "eeg")  # no custom flag
    array = mne.EvokedArray(
        referenced.data.astype(np.float32), info, tmin=evoked.times[0], nave=evoked.nave
    )
    stc = apply_skf(array, mne_setup["forward"], noise_std=5e-6)
    assert relative(stc.data, by_projector) < REFERENCE_RTOL
