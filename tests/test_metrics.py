"""Each metric of docs/model.md §6 on hand-made cases with known answers."""

from types import SimpleNamespace

import numpy as np
import pytest

from skf_ref import InputError
from skf_ref.method import amplitude_from_components
from skf_ref.study import _metrics as metrics
from skf_ref.study import _regions as regions

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


# Earth mover's distance (issue 46, item 2). The reference solves the transportation problem
# by linprog with dense constraints, written here apart from the module's sparse one.
emd = metrics.earth_movers_distance


def lp_emd(amplitude, positions, points, weights):
    """The exact transport cost (mm) from linprog on the dense transportation problem."""
    from scipy.optimize import linprog

    a = np.asarray(amplitude, float) / np.sum(amplitude)
    w = np.asarray(weights, float) / np.sum(weights)
    n, k = a.size, w.size
    cost = np.linalg.norm(positions[:, None] - points[None], axis=2).ravel() * 1e3
    A_eq = np.vstack([np.kron(np.eye(n), np.ones(k)), np.kron(np.ones(n), np.eye(k))])
    result = linprog(cost, A_eq=A_eq, b_eq=np.concatenate([a, w]), method="highs")
    assert result.status == 0
    return result.fun


@pytest.mark.parametrize("shift", [0, 1, 4, 19])
def test_a_point_mass_moved_by_d_mm_costs_d(shift):
    amplitude = np.zeros(20)
    amplitude[shift] = 3.0
    assert emd(amplitude, POSITIONS, POSITIONS[:1]) == pytest.approx(5 * shift, abs=1e-12)
    off_grid = np.array([[0.0123, -0.004, 0.0071]])  # away from the line, in no grid plane
    expected = np.linalg.norm(POSITIONS[shift] - off_grid) * 1e3
    assert emd(amplitude, POSITIONS, off_grid) == pytest.approx(expected, rel=1e-14)


def test_a_split_mass_against_one_point_is_the_mean_distance():
    amplitude = np.zeros(20)
    amplitude[[2, 6]] = 1.0  # half at 10 mm, half at 30 mm
    assert emd(amplitude, POSITIONS, [[0.0, 0, 0]]) == pytest.approx(20)
    assert emd(amplitude, POSITIONS, [POSITIONS[4]]) == pytest.approx(10)  # midway: 10 each
    # and against the two points it sits on, in its own proportions, nothing moves
    assert emd(amplitude, POSITIONS, POSITIONS[[2, 6]]) == 0
    assert emd(amplitude, POSITIONS, POSITIONS[[2, 6]], [3, 1]) == pytest.approx(0.25 * 20)


@pytest.mark.parametrize("seed", range(8))
def test_two_and_three_points_match_the_linear_program(seed):
    rng = np.random.default_rng(seed)
    positions = rng.normal(size=(60, 3)) * 0.03
    amplitude = rng.random(60) * (rng.random(60) > 0.2)  # some positions without mass
    for n_points in (2, 3):
        points = rng.normal(size=(n_points, 3)) * 0.03
        weights = rng.random(n_points)
        expected = lp_emd(amplitude, positions, points, weights)
        got = emd(amplitude, positions, points, weights)
        assert got == pytest.approx(expected, rel=1e-9)


def test_two_point_ties_match_the_linear_program():
    # Regression for the closed form: the truth at x = +-10 mm, and the estimate in blocks of
    # equal d1 - d2 (on the line beyond either point: -20 or +20 mm; on the bisecting plane
    # x = 0: 0), with the truth's split falling inside each block in turn.
    points = np.array([[-0.01, 0, 0], [0.01, 0, 0]])
    left = np.column_stack([-0.01 - 0.004 * np.arange(1, 6), np.zeros(5), np.zeros(5)])
    plane = np.column_stack([np.zeros(6), 0.005 * np.arange(6) - 0.01, 0.003 * np.arange(6)])
    right = -left
    positions = np.vstack([right, plane, left])  # the blocks out of order
    amplitude = np.ones(16)
    for first in (0.1, 5 / 16, 0.5, 11 / 16, 0.75, 0.9):  # 5/16, 11/16: block ends
        weights = [first, 1 - first]
        expected = lp_emd(amplitude, positions, points, weights)
        assert emd(amplitude, positions, points, weights) == pytest.approx(expected, rel=1e-9)
        order = np.random.default_rng(0).permutation(16)
        assert emd(amplitude[order], positions[order], points, weights) == pytest.approx(
            expected, rel=1e-9
        )


@pytest.mark.parametrize("seed", range(5))
def test_swapping_a_two_point_estimate_and_a_two_point_truth(seed):
    rng = np.random.default_rng(seed)
    estimate, truth = rng.normal(size=(2, 3)) * 0.03, rng.normal(size=(2, 3)) * 0.03
    a, w = rng.random(2), rng.random(2)
    assert emd(a, estimate, truth, w) == pytest.approx(emd(w, truth, estimate, a), rel=1e-12)


def test_scaling_amplitude_or_weights_changes_nothing():
    rng = np.random.default_rng(1)
    positions, amplitude = rng.normal(size=(50, 3)) * 0.03, rng.random(50)
    for n_points in (1, 2, 3):
        points, weights = rng.normal(size=(n_points, 3)) * 0.03, rng.random(n_points)
        value = emd(amplitude, positions, points, weights)
        for scale in (1e-300, 1e-12, 7.0, 1e300):  # neither underflows nor overflows
            assert emd(amplitude * scale, positions, points, weights) == pytest.approx(
                value, rel=1e-12
            )
            assert emd(amplitude, positions, points, weights * scale) == pytest.approx(
                value, rel=1e-12
            )


def test_equal_weights_by_default_and_zero_weight_points_are_dropped():
    rng = np.random.default_rng(2)
    positions, amplitude = rng.normal(size=(40, 3)) * 0.03, rng.random(40)
    points = rng.normal(size=(3, 3)) * 0.03
    assert emd(amplitude, positions, points) == pytest.approx(
        emd(amplitude, positions, points, [2.0, 2.0, 2.0]), rel=1e-12
    )
    assert emd(amplitude, positions, points, [1.0, 0.0, 3.0]) == pytest.approx(
        emd(amplitude, positions, points[[0, 2]], [1.0, 3.0]), rel=1e-12
    )
    assert emd(amplitude, positions, points, [0.0, 0.0, 3.0]) == pytest.approx(
        emd(amplitude, positions, points[2:]), rel=1e-12
    )


def test_an_empty_estimate_has_no_distance():
    assert np.isnan(emd(np.zeros(20), POSITIONS, POSITIONS[:2]))


@pytest.mark.parametrize(
    "args, match",
    [
        ((np.ones(19), POSITIONS, POSITIONS[:1]), r"amplitude must have shape .*\(20,\)"),
        ((np.ones((20, 1)), POSITIONS, POSITIONS[:1]), "amplitude must have shape"),
        ((np.ones(20), POSITIONS[:, :2], POSITIONS[:1]), "positions must have shape"),
        ((np.ones(20), POSITIONS, POSITIONS[0]), "points must have shape"),
        ((np.ones(20), POSITIONS, np.zeros((0, 3))), "points must hold at least one"),
        ((np.ones(20), POSITIONS, POSITIONS[:2], [1.0]), r"weights must have shape .*\(2,\)"),
        ((-np.ones(20), POSITIONS, POSITIONS[:1]), "amplitude must be non-negative"),
        ((np.full(20, np.nan), POSITIONS, POSITIONS[:1]), "amplitude contains NaN"),
        ((np.ones(20), POSITIONS * np.nan, POSITIONS[:1]), "positions contains NaN"),
        ((np.ones(20), POSITIONS, [[np.nan, 0, 0]]), "points contains NaN"),
        ((np.ones(20), POSITIONS, POSITIONS[:2], [1.0, np.inf]), "weights contains NaN"),
        ((np.ones(20), POSITIONS, POSITIONS[:2], [1.0, -1.0]), "weights must be non-negative"),
        ((np.ones(20), POSITIONS, POSITIONS[:2], [0.0, 0.0]), "not all zero"),
    ],
)
def test_earth_movers_distance_refuses_bad_inputs(args, match):
    with pytest.raises(InputError, match=match):
        emd(*args)
