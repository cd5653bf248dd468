"""The head model and the P20/N20 scenario match docs/model.md §5."""

import mne
import numpy as np
import pytest

from skf_ref.study._head import template_mni_to_head
from skf_ref.study._scenario import (
    DEEP_MNI_MM,
    SUPERFICIAL_MNI_MM,
    make_head_model,
    p20n20_scenario,
    simulate,
)

POSITIONS = 500
# The noise standard deviation estimated from 64 x 41 x 20 samples has a relative standard
# error of about 1 / sqrt(2 N) = 0.4 %; 3 % is more than five standard errors.
SIGMA_RTOL = 0.03
# mne.make_forward_dipole stores its gain in float32 (7 significant digits); the package
# computes the same field in float64.
FLOAT32_RTOL = 1e-6


@pytest.fixture(scope="module")
def head():
    return make_head_model(POSITIONS)


@pytest.fixture(scope="module")
def scenario():
    return p20n20_scenario()


def test_head_model_geometry_and_lead_field(head):
    assert abs(head.n_positions - POSITIONS) / POSITIONS < 0.05
    assert head.leadfield.shape == (64, 3 * head.n_positions)
    np.testing.assert_allclose(head.leadfield.sum(axis=0), 0, atol=1e-12 * 1e3)  # average ref
    distances = np.linalg.norm(head.positions - head.origin, axis=1)
    assert distances.max() < head.brain_radius  # inside the brain compartment
    # the sphere is fitted to the electrodes: its centre and outer radius are those of the
    # least-squares sphere through them (|e|^2 = 2 e.c + (r^2 - |c|^2), linear in c)
    electrodes = np.array([ch["loc"][:3] for ch in head.info["chs"]])
    design = np.c_[2 * electrodes, np.ones(len(electrodes))]
    solution = np.linalg.lstsq(design, np.sum(electrodes**2, axis=1), rcond=None)[0]
    centre = solution[:3]
    np.testing.assert_allclose(head.origin, centre, atol=1e-6)
    outer = max(layer["rad"] for layer in head.sphere["layers"])
    # to 1 um, as the centre: MNE before 1.10 fits it iteratively (0.1 um off), 1.10 on exactly
    assert outer == pytest.approx(np.sqrt(solution[3] + centre @ centre), abs=1e-6)
    assert not head.leadfield.flags.writeable
    # free orientation in MNE's order: column 3 p + k is the k-th axis of position p
    gain = head.fwd["sol"]["data"]
    np.testing.assert_allclose(head.leadfield, gain - gain.mean(axis=0), rtol=1e-12)


def test_seed_shifts_the_grid(head):
    shifted = make_head_model(POSITIONS, seed=3)
    assert abs(shifted.n_positions - POSITIONS) / POSITIONS < 0.05
    assert not np.allclose(shifted.positions[:10], head.positions[:10])
    again = make_head_model(POSITIONS, seed=3)
    np.testing.assert_array_equal(again.positions, shifted.positions)


def test_waveforms_and_times(scenario):
    times_ms = scenario.times * 1e3
    assert len(times_ms) == 41 and times_ms[0] == 0 and times_ms[-1] == pytest.approx(4.0)
    deep, superficial = scenario.waveforms
    np.testing.assert_allclose(scenario.peak_times * 1e3, [1.5, 2.5])
    assert times_ms[np.argmax(deep)] == pytest.approx(1.5)
    assert times_ms[np.argmax(superficial)] == pytest.approx(2.5)
    np.testing.assert_allclose([deep.max(), superficial.max()], 10e-9)  # 10 nA m
    # supports [0, 3] and [1, 4] ms: both active on (1, 3) ms only, a 2 ms overlap
    both = (deep > 0) & (superficial > 0)
    assert times_ms[both].min() > 1.0 and times_ms[both].max() < 3.0
    assert times_ms[both].max() - times_ms[both].min() == pytest.approx(1.8)  # open interval
    assert deep[times_ms >= 3.0 - 1e-9].max() == pytest.approx(0, abs=1e-20)
    # Hann pulse: the deep waveform at 2.5 ms is a quarter of its peak (the echo's true ratio)
    assert deep[np.isclose(times_ms, 2.5)][0] / deep.max() == pytest.approx(0.25)


def test_source_positions_and_orientations(head, scenario):
    truth = scenario.dipoles(head)
    # MNI coordinates placed through the template's head frame (a rigid map for a sphere)
    mni_to_head = template_mni_to_head()
    mni = np.array([DEEP_MNI_MM, SUPERFICIAL_MNI_MM]) * 1e-3
    np.testing.assert_allclose(truth.positions, mni @ mni_to_head[:3, :3].T + mni_to_head[:3, 3])
    np.testing.assert_allclose(mni_to_head[:3, :3] @ mni_to_head[:3, :3].T, np.eye(3), atol=1e-6)
    assert truth.moved_mm == (0.0, 0.0)  # the sphere has no labels to move them into
    np.testing.assert_allclose(np.linalg.norm(truth.orientations, axis=1), 1.0)
    deep = mni_to_head[:3, :3] @ np.array([0.2, 0.196, -0.981])
    np.testing.assert_allclose(truth.orientations[0], deep / np.linalg.norm(deep))
    radial = truth.positions[1] - head.origin
    assert truth.orientations[1] @ radial == pytest.approx(0, abs=1e-12)  # tangential
    given, unit_radial = mni_to_head[:3, :3] @ [0.2, 1, 0], radial / np.linalg.norm(radial)
    tangential = given - (given @ unit_radial) * unit_radial  # what is left of (0.2, 1, 0)
    np.testing.assert_allclose(truth.orientations[1], tangential / np.linalg.norm(tangential))
    # both inside the brain sphere: the deep one about 21 mm from its centre, the other 68 mm
    depths = np.linalg.norm(truth.positions - head.origin, axis=1) * 1e3
    np.testing.assert_allclose(depths, [20.7, 68.2], atol=0.1)


def test_head_coordinates_are_taken_as_given(head):
    scenario = p20n20_scenario(
        deep_position_mm=(-12, -32, 50), superficial_position_mm=(-33, -37, 80), frame="head"
    )
    truth = scenario.dipoles(head)
    np.testing.assert_allclose(truth.positions * 1e3, [[-12, -32, 50], [-33, -37, 80]])


def test_a_control_holds_one_source_and_the_noise_of_both(head, scenario):
    both = simulate(head, scenario, 20.0, seed=3)
    for index, name in enumerate(("deep", "superficial")):
        alone = simulate(head, scenario, 20.0, seed=3, sources=(name,))
        assert alone.sigma == both.sigma and alone.sources == (name,)
        gain = head.dipole_gain(both.truth.positions, both.truth.orientations)
        expected = np.outer(gain[:, index], both.truth.waveforms[index])
        np.testing.assert_allclose(alone.Y_clean, expected, rtol=1e-12, atol=0)
        noise = both.Y - both.Y_clean  # the same draws (to the rounding of adding Y_clean)
        scale = np.abs(both.Y).max()
        np.testing.assert_allclose(alone.Y - alone.Y_clean, noise, atol=1e-14 * scale)
    with pytest.raises(ValueError, match="sources must be a non-empty subset"):
        simulate(head, scenario, 20.0, seed=3, sources=("thalamus",))


def test_grid_forward_uses_the_nearest_columns(head, scenario):
    sim = simulate(head, scenario, 20.0, seed=0, forward="grid")
    truth = sim.truth
    nearest = np.linalg.norm(head.positions[:, None] - truth.positions[None], axis=2).argmin(0)
    columns = [
        head.leadfield[:, 3 * p : 3 * p + 3] @ o
        for p, o in zip(nearest, truth.orientations, strict=True)
    ]
    np.testing.assert_allclose(sim.Y_clean, np.stack(columns, axis=1) @ truth.waveforms)


def test_blackman_harris_pulses():
    scenario = p20n20_scenario(window="blackman-harris")
    deep = scenario.waveforms[0] / scenario.waveforms[0].max()
    times_ms = scenario.times * 1e3
    assert times_ms[np.argmax(deep)] == pytest.approx(1.5)
    # the 4-term window at 5/6 of its support: 0.35875 - 0.48829/2 - 0.14128/2 + 0.01168
    assert deep[np.isclose(times_ms, 2.5)][0] == pytest.approx(0.055645, abs=1e-6)
    with pytest.raises(ValueError, match="window must be one of"):
        p20n20_scenario(window="hamming")


def test_data_come_from_the_exact_dipoles(head, scenario):
    sim = simulate(head, scenario, 30.0, seed=0)
    truth = sim.truth
    dipole = mne.Dipole(np.zeros(2), truth.positions, np.ones(2), truth.orientations, np.ones(2))
    fwd, _ = mne.make_forward_dipole(dipole, head.sphere, head.info, verbose=False)
    gain = fwd["sol"]["data"]  # MNE's dipole forward, stored in float32
    expected = (gain - gain.mean(axis=0)) @ truth.waveforms
    scale = abs(expected).max()
    np.testing.assert_allclose(sim.Y_clean, expected, atol=FLOAT32_RTOL * scale)
    np.testing.assert_allclose(sim.Y_clean.sum(axis=0), 0, atol=1e-13 * scale)  # float64 ref
    # no inverse crime: the data are not a combination of the grid's own columns at the
    # nearest positions (the exact dipoles lie off the grid)
    nearest = np.linalg.norm(head.positions[:, None] - truth.positions[None], axis=2).min(axis=0)
    assert nearest.min() > 1e-4


@pytest.mark.parametrize("snr_db", [10.0, 20.0, 30.0])
def test_noise_hits_the_requested_snr(head, scenario, snr_db):
    residuals = [simulate(head, scenario, snr_db, seed).Y for seed in range(20)]
    sim = simulate(head, scenario, snr_db, seed=0)
    assert sim.sigma == pytest.approx(np.abs(sim.Y_clean).max() * 10 ** (-snr_db / 20))
    noise = np.stack(residuals) - sim.Y_clean
    assert np.std(noise) == pytest.approx(sim.sigma, rel=SIGMA_RTOL)
    assert abs(np.mean(noise)) < 5 * sim.sigma / np.sqrt(noise.size)


def test_same_seed_same_noise_other_seed_other_noise(head, scenario):
    a, b = simulate(head, scenario, 20.0, 7), simulate(head, scenario, 20.0, 7)
    np.testing.assert_array_equal(a.Y, b.Y)
    assert not np.array_equal(a.Y, simulate(head, scenario, 20.0, 8).Y)


@pytest.mark.parametrize(
    "call, error, match",
    [
        (lambda: make_head_model(500, montage="biosemi65"), ValueError, "montage must be the"),
        (lambda: make_head_model(5), ValueError, "n_positions must be >= 10, got 5"),
        (lambda: make_head_model(500.5), TypeError, "n_positions must be an integer, got 500.5"),
        (lambda: make_head_model(500, seed=-1), ValueError, "seed must be >= 0, got -1"),
        (lambda: p20n20_scenario(pulse_ms=-3.0), ValueError, "pulse_ms must be > 0"),
        (lambda: p20n20_scenario(pulse_ms="3"), TypeError, "pulse_ms must be a real number"),
        (lambda: p20n20_scenario(superficial_onset_ms=3.0), ValueError, "superficial"),
        (lambda: p20n20_scenario(deep_position_mm=(1, 2)), ValueError, r"shape \(3,\)"),
    ],
)
def test_bad_input(call, error, match):
    with pytest.raises(error, match=match):
        call()


@pytest.mark.parametrize(
    "snr_db, error, match",
    [
        (float("nan"), ValueError, "snr_db must be finite, got nan"),
        (float("inf"), ValueError, "snr_db must be finite, got inf"),
        (-float("inf"), ValueError, "snr_db must be finite, got -inf"),
        ("20", TypeError, "snr_db must be a real number, got '20' \\(str\\)"),
    ],
)
def test_snr_must_be_finite(head, scenario, snr_db, error, match):
    with pytest.raises(error, match=match):
        simulate(head, scenario, snr_db, seed=0)


def test_too_coarse_a_grid_cannot_hold_the_scenario(scenario):
    coarse = make_head_model(40)
    with pytest.raises(ValueError, match="no grid position within 15 mm .* larger n_positions"):
        simulate(coarse, scenario, 20.0, seed=0)


def test_noise_with_the_heads_recorded_covariance(head, scenario):
    from dataclasses import replace

    rng = np.random.default_rng(5)
    n = head.n_channels
    A = rng.standard_normal((n, n)) * rng.uniform(0.1, 3.0, n)  # correlated, unequal channels
    P = np.eye(n) - 1.0 / n
    recorded = replace(head, noise_cov=P @ (A @ A.T) @ P * 1e-12)  # V², average referenced
    sim = simulate(recorded, scenario, 20.0, seed=1, noise="head")
    white = simulate(head, scenario, 20.0, seed=1)
    assert sim.noise == "head" and sim.sigma == white.sigma
    # the head's covariance scaled to a mean channel variance of sigma**2
    np.testing.assert_allclose(np.mean(np.diag(sim.noise_cov)), sim.sigma**2, rtol=1e-12)
    np.testing.assert_allclose(
        sim.noise_cov / recorded.noise_cov, sim.noise_cov[0, 0] / recorded.noise_cov[0, 0]
    )
    drawn = sim.Y - sim.Y_clean
    np.testing.assert_allclose(drawn.sum(axis=0), 0.0, atol=1e-9 * sim.sigma)  # referenced
    # white noise is what R = sigma**2 I says, and the same draws as before
    np.testing.assert_array_equal(white.noise_cov, white.sigma**2 * np.eye(n))


def test_the_drawn_noise_has_the_covariance():
    from skf_ref.study._scenario import _covariance_factor

    rng = np.random.default_rng(0)
    A = rng.standard_normal((6, 6))
    P = np.eye(6) - 1.0 / 6
    C = P @ (A @ A.T) @ P
    F = _covariance_factor(C)
    assert F.shape == (6, 5)  # the reference's null direction left out
    np.testing.assert_allclose(F @ F.T, C, atol=1e-12 * np.abs(C).max())


def test_head_noise_needs_a_head_with_a_recorded_covariance(head, scenario):
    with pytest.raises(ValueError, match="noise='head' needs a head with a recorded noise"):
        simulate(head, scenario, 20.0, seed=0, noise="head")
    with pytest.raises(ValueError, match="noise must be one of"):
        simulate(head, scenario, 20.0, seed=0, noise="pink")
