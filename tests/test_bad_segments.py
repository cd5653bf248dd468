"""Bad segments of a raw recording are missing observations (docs/model.md §2).

``apply_skf_raw(..., reject_by_annotation=True)``, the default as in MNE's readers: the
samples inside ``BAD_`` annotations are predicted, not updated; the estimate there is NaN,
the estimate elsewhere does not depend on what they hold, the log names them; in memory and
streamed to a zarr store alike. ``reject_by_annotation=False`` filters every sample.
"""

import mne
import numpy as np
import pytest

from skf_ref import InputError, apply_skf_raw, make_skf_operator

SETTINGS = dict(exponent=1.25, smoother="rts-state")


@pytest.fixture(scope="module")
def operator_and_raw(mne_setup):
    epochs = mne_setup["make_epochs"](target=300, seed=21)
    cov = mne.compute_covariance(epochs, tmax=0, verbose=False)
    operator = make_skf_operator(epochs.info, mne_setup["forward"], cov, verbose=False)
    data = np.concatenate(list(epochs.get_data()[:6]), axis=1)  # 360 samples at 1 kHz
    raw = mne.io.RawArray(data, mne_setup["info"], verbose=False)
    raw.set_eeg_reference("average", verbose=False)
    return operator, raw


def _annotated(raw, onsets, duration, artefact=None):
    """A copy of ``raw`` with BAD_ annotations; ``artefact`` scales the data inside them."""
    raw = raw.copy()
    raw.set_annotations(mne.Annotations(onsets, duration, "BAD_blink"))
    if artefact is not None:
        inside = np.isnan(raw.get_data(reject_by_annotation="NaN")[0])
        raw._data[:, inside] *= artefact
    return raw


def _inside(times, onsets, duration, sfreq=1000.0):
    """The samples of ``times`` inside the segments (counted in whole samples)."""
    samples = np.round(times * sfreq)
    bounds = [(round(a * sfreq), round((a + duration) * sfreq)) for a in onsets]
    return np.any([(samples >= a) & (samples < b) for a, b in bounds], axis=0)


def test_bad_segments_have_no_estimate_and_the_rest_ignores_them(operator_and_raw, capsys):
    operator, raw = operator_and_raw
    annotated = _annotated(raw, [0.1, 0.25], 0.02)
    stc = apply_skf_raw(annotated, operator, **SETTINGS)
    inside = _inside(stc.times, [0.1, 0.25], 0.02)
    assert inside.sum() == 40
    assert np.isnan(stc.data[:, inside]).all() and np.isfinite(stc.data[:, ~inside]).all()
    log = capsys.readouterr().err
    assert "2 bad segment(s) (BAD_ annotations) skipped as missing observations, 40 of 360" in log
    assert "0.100-0.119 s, 0.250-0.269 s" in log
    # what a bad segment holds never reaches the estimate: a 1e6 x artefact, bit-equal (the
    # segment is missing on both runs: the same calls on the same numbers)
    shouted = apply_skf_raw(_annotated(raw, [0.1, 0.25], 0.02, 1e6), operator, **SETTINGS)
    np.testing.assert_array_equal(shouted.data, stc.data)


def test_without_rejection_every_sample_is_filtered(operator_and_raw):
    operator, raw = operator_and_raw
    annotated = _annotated(raw, [0.1], 0.02)
    kept = apply_skf_raw(annotated, operator, reject_by_annotation=False, **SETTINGS)
    # the same samples through the same calls: equal by construction
    np.testing.assert_array_equal(kept.data, apply_skf_raw(raw, operator, **SETTINGS).data)
    artefact = _annotated(raw, [0.1], 0.02, 1e6)
    moved = apply_skf_raw(artefact, operator, reject_by_annotation=False, **SETTINGS)
    assert not np.allclose(moved.data[:, 200:], kept.data[:, 200:])  # carried past the segment
    with pytest.raises(TypeError, match="reject_by_annotation must be True or False"):
        apply_skf_raw(raw, operator, reject_by_annotation="omit")


def test_bad_segments_follow_the_recordings_own_times(operator_and_raw):
    # a cropped recording (first_samp > 0) with a measurement date: MNE places the
    # annotation by orig_time and first_samp, and the estimate's NaN follow it
    operator, raw = operator_and_raw
    dated = raw.copy().set_meas_date(1_700_000_000.0)
    dated.set_annotations(mne.Annotations([0.2], [0.03], ["bad_muscle"], dated.info["meas_date"]))
    cropped = dated.crop(tmin=0.05)
    assert cropped.first_samp == 50
    stc = apply_skf_raw(cropped, operator)
    gap = np.isnan(stc.data).all(axis=0)
    np.testing.assert_array_equal(np.flatnonzero(gap), np.arange(150, 180))


def test_a_streamed_store_holds_the_same_gaps(operator_and_raw, tmp_path):
    pytest.importorskip("zarr")
    operator, raw = operator_and_raw
    annotated = _annotated(raw, [0.1], 0.02)
    in_memory = apply_skf_raw(annotated, operator, **SETTINGS)
    store = apply_skf_raw(annotated, operator, out=tmp_path / "r.zarr", **SETTINGS)
    streamed = np.asarray(store["data"][:])
    np.testing.assert_array_equal(np.isnan(streamed), np.isnan(in_memory.data))
    np.testing.assert_allclose(streamed, in_memory.data, rtol=1e-12, equal_nan=True)


def test_what_a_bad_segment_cannot_do_is_refused(operator_and_raw):
    operator, raw = operator_and_raw
    annotated = _annotated(raw, [0.1], 0.02)
    with pytest.raises(InputError, match=r"smoother='rts-standardized' is undefined over"):
        apply_skf_raw(annotated, operator, smoother="rts-standardized")
    smoothed = apply_skf_raw(annotated, operator, smoother="rts-standardized",
                             reject_by_annotation=False)  # fmt: skip
    assert np.isfinite(smoothed.data).all()
    with pytest.raises(InputError, match="every sample from start to stop lies in a bad"):
        apply_skf_raw(annotated, operator, 100, 120)
