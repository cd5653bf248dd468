"""Each metric of docs/model.md §6 on hand-made cases with known answers."""

from types import SimpleNamespace

import numpy as np
import pytest

from skf_ref.method import amplitude_from_components
from skf_ref.study import metrics, regions

# A line of positions 5 mm apart along x (metres): distances between them are exact.
POSITIONS = np.column_stack([np.arange(0, 0.1, 0.005), np.zeros(20), np.zeros(20)])
DEEP, SUPERFICIAL = POSITIONS[2], POSITIONS[15]  # 65 mm apart: separate 15 mm regions
TIMES = np.arange(41) / 10_000.0
I_DEEP, I_SUP = 15, 25  # 1.5 and 2.5 ms


def hann(onset_ms):
    t = TIMES * 1e3 - onset_ms
    return np.where((t > 0) & (t < 3), np.sin(np.pi * t / 3) ** 2, 0.0) * 1e-8


TRUTH = SimpleNamespace(
    positions=np.stack([DEEP, SUPERFICIAL]),
    waveforms=np.stack([hann(0.0), hann(1.0)]),
    peak_times=np.array([1.5e-3, 2.5e-3]),
    times=TIMES,
)
HEAD = SimpleNamespace(positions=POSITIONS)


def perfect():
    """Each source's waveform exactly at its own position, nothing elsewhere."""
    amplitude = np.zeros((20, 41))
    amplitude[2], amplitude[15] = np.abs(TRUTH.waveforms)
    return amplitude


def test_a_perfect_reconstruction_scores_perfectly():
    summary = metrics.summarize(perfect(), HEAD, TRUTH)
    assert summary["deep_error_mm"] == 0 and summary["superficial_error_mm"] == 0
    assert summary["deep_detected"] and summary["superficial_detected"]
    assert summary["deep_region_db"] == 0 and summary["superficial_region_db"] == 0
    assert summary["echo"] == pytest.approx(0, abs=1e-12)
    assert summary["deep_corr"] == pytest.approx(1) and summary[
        "superficial_corr"
    ] == pytest.approx(1)
    assert summary["separation"]
    # at 2.5 ms the deep source is a quarter of the superficial one: -12 dB
    assert summary["deep_region_at_superficial_peak_db"] == pytest.approx(20 * np.log10(0.25))


def test_deep_source_moved_20_mm_reports_20_mm():
    amplitude = perfect()
    amplitude[2 + 4], amplitude[2] = amplitude[2], 0  # 4 positions x 5 mm
    assert metrics.summarize(amplitude, HEAD, TRUTH)["deep_error_mm"] == pytest.approx(20)
    assert metrics.peak_localization_error(amplitude, POSITIONS, DEEP, I_DEEP) == pytest.approx(20)


def test_region_is_15_mm():
    mask = regions.region_mask(POSITIONS, DEEP)
    assert mask[:5].all()  # up to 10 mm away
    assert not mask[6:].any()  # 20 mm and more (position 5 sits on the 15 mm boundary)


def test_detection_uses_a_6_db_range():
    amplitude = perfect()
    amplitude[15, I_DEEP] = amplitude[2, I_DEEP] * 10 ** (6.5 / 20)  # superficial 6.5 dB up
    assert not metrics.detected(amplitude, POSITIONS, DEEP, I_DEEP)
    amplitude[15, I_DEEP] = amplitude[2, I_DEEP] * 10 ** (5.5 / 20)
    assert metrics.detected(amplitude, POSITIONS, DEEP, I_DEEP)
    assert regions.region_db(amplitude, POSITIONS, DEEP, I_DEEP) == pytest.approx(-5.5)


def test_echo_is_the_excess_of_deep_activity_at_the_superficial_peak():
    amplitude = perfect()
    amplitude[2, I_SUP] = 0.75 * amplitude[2, I_DEEP]  # 0.5 above the true 0.25
    assert metrics.echo(amplitude, POSITIONS, DEEP, I_DEEP, I_SUP, 0.25) == pytest.approx(0.5)
    assert metrics.summarize(amplitude, HEAD, TRUTH)["echo"] == pytest.approx(0.5)


def test_time_course_correlation():
    amplitude = perfect()
    assert metrics.time_course_correlation(
        amplitude, POSITIONS, SUPERFICIAL, hann(1.0)
    ) == pytest.approx(1)
    amplitude[15] = amplitude[15, ::-1]  # the superficial course reversed in time
    assert metrics.time_course_correlation(amplitude, POSITIONS, SUPERFICIAL, hann(1.0)) < 0.5


def test_separation_fails_when_deep_persists_at_the_superficial_peak():
    amplitude = perfect()
    amplitude[2, I_SUP] = 0.9 * amplitude[15, I_SUP]  # deep within 6 dB at 2.5 ms
    assert not metrics.separation(amplitude, POSITIONS, DEEP, SUPERFICIAL, I_DEEP, I_SUP)
    assert not metrics.summarize(amplitude, HEAD, TRUTH)["separation"]


def test_summarize_takes_a_reconstruction_object():
    z = np.zeros((60, 41))
    z[3 * 2 + 1], z[3 * 15 + 2] = TRUTH.waveforms  # y of the deep, z of the superficial
    reconstruction = SimpleNamespace(amplitude=lambda c: amplitude_from_components(z, c))
    assert metrics.summarize(reconstruction, HEAD, TRUTH) == metrics.summarize(
        perfect(), HEAD, TRUTH
    )


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: metrics.summarize(np.ones((19, 41)), HEAD, TRUTH), "n_positions=20"),
        (lambda: metrics.summarize(np.ones((20, 40)), HEAD, TRUTH), r"\(20, 41\)"),
        (lambda: amplitude_from_components(np.ones((7, 3))), "n_components=3"),
        (lambda: regions.region_mask(POSITIONS[:, :2], DEEP), "positions"),
        (lambda: metrics.peak_localization_error(perfect(), POSITIONS, DEEP, 41), "peak_index"),
    ],
)
def test_bad_shapes_are_refused(call, match):
    with pytest.raises(ValueError, match=match):
        call()
