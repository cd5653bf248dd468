"""Resolution metrics, the calibrated detector and sources drawn off the grid
(skf_ref.study._resolution, skf_ref.study._detection, skf_ref.study._sources)."""

import numpy as np
import pytest

from skf_ref import InputError
from skf_ref.study._detection import FALSE_DETECTION_RATE, null_threshold, thalamic_level
from skf_ref.study._resolution import (
    level_db,
    peak_errors,
    position_amplitudes,
    spatial_dispersion,
)


@pytest.fixture
def maps():
    rng = np.random.default_rng(3)
    positions = rng.uniform(-0.05, 0.05, (40, 3))
    amplitude = np.abs(rng.standard_normal((40, 7)))
    points = rng.uniform(-0.05, 0.05, (7, 3))
    return amplitude, positions, points


def test_peak_errors_and_dispersion_follow_their_definitions(maps):
    amplitude, positions, points = maps
    errors, peak = peak_errors(amplitude, positions, points)
    for r in range(amplitude.shape[1]):
        d = np.linalg.norm(positions - points[r], axis=1) * 1e3
        assert errors[r] == pytest.approx(d[np.argmax(amplitude[:, r])])
        assert peak[r] == np.argmax(amplitude[:, r])
        expected = np.sqrt(np.sum(amplitude[:, r] ** 2 * d**2) / np.sum(amplitude[:, r] ** 2))
        assert spatial_dispersion(amplitude, positions, points)[r] == pytest.approx(expected)


def test_an_empty_run_has_no_error_and_no_dispersion(maps):
    amplitude, positions, points = maps
    amplitude = amplitude.copy()
    amplitude[:, 2] = 0.0
    assert np.isnan(peak_errors(amplitude, positions, points)[0][2])
    assert np.isnan(spatial_dispersion(amplitude, positions, points)[2])
    assert level_db(amplitude, np.arange(40) < 5)[2] == -np.inf


def test_a_set_holding_the_maximum_is_at_0_db(maps):
    amplitude, _, _ = maps
    mask = np.zeros(40, dtype=bool)
    mask[np.argmax(amplitude[:, 0])] = True
    assert level_db(amplitude, mask)[0] == 0.0
    assert (level_db(amplitude, mask) <= 0).all()


def test_position_amplitudes_are_norms_over_three_components():
    z = np.arange(12.0).reshape(6, 2)
    expected = np.linalg.norm(z.reshape(2, 3, 2), axis=1)
    assert np.allclose(position_amplitudes(z), expected)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: peak_errors(np.ones((3, 2)), np.zeros((4, 3)), np.zeros((2, 3))), "amplitude"),
        (lambda: spatial_dispersion(np.ones((3, 2)), np.zeros((3, 3)), np.zeros((3, 3))),
         "points"),
        (lambda: level_db(np.ones((3, 2)), np.zeros(3, dtype=bool)), "mask"),
        (lambda: position_amplitudes(np.ones((4, 2))), "multiple of 3"),
        (lambda: thalamic_level(np.ones(3), np.array([True, False])), "thalamus"),
        (lambda: null_threshold(), "at least one"),
        (lambda: null_threshold(np.array([1.0, np.nan])), "finite"),
        (lambda: null_threshold(np.ones(3), rate=0.0), "rate"),
    ],
)  # fmt: skip
def test_bad_input_names_the_parameter(call, message):
    with pytest.raises(InputError, match=message):
        call()


def test_the_threshold_lets_through_at_most_5_percent_of_every_kind_of_null():
    rng = np.random.default_rng(5)
    for n_noise, n_cortical in ((100, 630), (37, 11), (1, 20)):
        noise, cortical = rng.normal(0, 1, n_noise), rng.normal(2, 1, n_cortical)
        tau = null_threshold(noise, cortical)
        assert np.mean(noise > tau) <= FALSE_DETECTION_RATE
        assert np.mean(cortical > tau) <= FALSE_DETECTION_RATE
        assert tau in np.r_[noise, cortical]  # an order statistic, never interpolated


def test_the_thalamic_level_is_the_thalamus_maximum():
    amplitude = np.array([[1.0, 4.0], [3.0, 0.5], [2.0, 1.0]])
    assert np.allclose(thalamic_level(amplitude, np.array([False, True, True])), [3.0, 1.0])


def test_sources_are_drawn_in_their_cells_and_labels_reproducibly():
    from skf_ref.study._head import make_head
    from skf_ref.study._sources import draw_sources, position_structures

    head = make_head("sphere", "anatomical", spacing_mm=12.0)
    structures = position_structures(head)
    positions = np.r_[np.flatnonzero(structures == "thalamus")[:2], 10, 200]
    sources = draw_sources(head, positions, seed=1, n_orientations=2)
    assert len(sources) == 8 and list(sources.position) == list(np.repeat(positions, 2))
    offset = np.abs(sources.points - head.positions[sources.position])
    assert (offset <= head.spacing / 2 + 1e-12).all() and (offset > 0).any()
    assert list(sources.structure) == list(np.repeat(structures[positions], 2))
    again = draw_sources(head, positions, seed=1, n_orientations=2)
    assert np.array_equal(again.points, sources.points)
    assert np.array_equal(again.gain, sources.gain)
    first = sources.take(np.arange(2))
    assert first.gain.shape == (head.n_channels, 2) and first.points.shape == (2, 3)
    with pytest.raises(InputError, match="distinct"):
        draw_sources(head, [3, 3], seed=0)
    with pytest.raises(InputError, match="n_orientations"):
        draw_sources(head, [3], seed=0, n_orientations=4)
    with pytest.raises(InputError, match="cortex \\+ thalamus"):
        draw_sources(make_head("sphere", "volume", n_positions=500), [3], seed=0)


def test_null_levels_feed_every_method_the_same_null_runs():
    from skf_ref.study._detection import null_levels
    from skf_ref.study._head import make_head
    from skf_ref.study._resolution import position_amplitudes as amplitudes

    head = make_head("sphere", "anatomical", spacing_mm=12.0)
    wave = 1e-8 * np.hanning(9)
    seen = []

    def backprojection(Y):
        seen.append(Y)
        return amplitudes(head.leadfield.T @ Y)

    methods = {"a": backprojection, "b": lambda Y: 2.0 * backprojection(Y)}
    levels = null_levels(head, methods, 1e-7, wave, 4, n_noise=3, n_cortical=4, seed=2)
    noise, cortical = levels["a"]
    assert noise.shape == (3,) and cortical.shape == (4,)
    assert np.allclose(levels["b"][1], 2 * cortical)  # the same data sets, in order
    assert np.array_equal(seen[0], seen[1])
    again = null_levels(head, {"a": backprojection}, 1e-7, wave, 4, n_noise=3, n_cortical=4,
                        seed=2)  # fmt: skip
    assert np.array_equal(again["a"][1], cortical)
    assert cortical.mean() > noise.mean()  # a cortical source spreads into the thalamus


def test_calibrate_gives_each_method_its_own_threshold_in_its_own_units():
    from skf_ref.study._detection import calibrate, null_levels
    from skf_ref.study._head import make_head
    from skf_ref.study._resolution import position_amplitudes as amplitudes
    from skf_ref.study._scenario import p20n20_scenario, simulate

    head = make_head("sphere", "anatomical", spacing_mm=12.0)
    sim = simulate(head, p20n20_scenario(), 20.0, 0)

    def backprojection(Y):
        return amplitudes(head.leadfield.T @ Y)

    methods = {"a": backprojection, "b": lambda Y: 3.0 * backprojection(Y)}
    thresholds = calibrate(head, sim, methods, n_runs=20, seed=5)
    assert thresholds["b"] == pytest.approx(3 * thresholds["a"], rel=1e-12)
    peak = int(sim.truth.peak_indices[0])
    levels = null_levels(head, methods, sim.sigma, sim.truth.waveforms[1], peak, n_noise=20,
                         n_cortical=20, seed=5)  # fmt: skip
    for kind in levels["a"]:
        assert np.mean(kind > thresholds["a"]) <= FALSE_DETECTION_RATE
    with pytest.raises(InputError, match="n_runs"):
        calibrate(head, sim, methods, n_runs=0)
