"""The P20/N20 scenario and simulated EEG (docs/model.md §5).

Three steps, each a public function returning a frozen dataclass:

- :func:`make_head_model` -> :class:`HeadModel`: MNE's sphere model fitted to a montage, a
  regular cubic grid of source positions in the brain compartment and its free-orientation,
  average-referenced lead field.
- :func:`p20n20_scenario` -> :class:`Scenario`: two dipoles (deep thalamic, superficial
  cortical) with overlapping Hann pulses.
- :func:`simulate` -> :class:`Simulation`: data from the exact dipoles' own forward field
  (not grid columns) plus white Gaussian noise at a peak SNR.

The head model lives in :mod:`skf_ref.head`. ``make_head_model`` and ``HeadModel`` can
still be reached from here, where the first release put them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .checks import InputError, check_db, check_instance, check_int, check_real, check_vector
from .head import HeadModel, make_head_model  # noqa: F401  (make_head_model: issue-4 name)
from .regions import REGION_RADIUS_MM, region_mask
from .result import readonly

__all__ = ["Scenario", "Simulation", "Truth", "p20n20_scenario", "simulate"]

_PULSE_EDGE_TOL = 1e-9  # relative phase treated as the (zero) edge of a Hann pulse


@dataclass(frozen=True, eq=False)
class Truth:
    """The exact sources of a simulation (index 0 deep, 1 superficial).

    Attributes
    ----------
    names : tuple of str
        ``("deep", "superficial")``.
    positions : ndarray, shape (2, 3)
        Dipole positions in metres, head coordinates.
    orientations : ndarray, shape (2, 3)
        Unit dipole orientations (the superficial one tangential to the sphere).
    waveforms : ndarray, shape (2, n_times)
        Dipole moments over time in A·m.
    peak_times : ndarray, shape (2,)
        Time of each waveform's peak in seconds.
    times : ndarray, shape (n_times,)
        Sample times in seconds.
    """

    names: tuple
    positions: np.ndarray = field(repr=False)
    orientations: np.ndarray = field(repr=False)
    waveforms: np.ndarray = field(repr=False)
    peak_times: np.ndarray
    times: np.ndarray = field(repr=False)

    @property
    def peak_indices(self):
        """ndarray of int, shape (2,) : Sample index nearest to each peak time."""
        return np.abs(self.times[None, :] - self.peak_times[:, None]).argmin(axis=1)


@dataclass(frozen=True, eq=False)
class Scenario:
    """Two dipoles with Hann-pulse waveforms, head independent (index 0 deep, 1 superficial).

    Attributes
    ----------
    names : tuple of str
        ``("deep", "superficial")``.
    positions : ndarray, shape (2, 3)
        Dipole positions in metres, head coordinates.
    orientations : ndarray, shape (2, 3)
        Orientations as given (not normalized, not made tangential); see :meth:`dipoles`.
    tangential : tuple of bool
        Whether :meth:`dipoles` removes a source's radial component: ``(False, True)``.
    times : ndarray, shape (n_times,)
        Sample times in seconds, ``arange(n_times) / sfreq``.
    waveforms : ndarray, shape (2, n_times)
        Dipole moments in A·m.
    peak_times : ndarray, shape (2,)
        Pulse centres in seconds.
    sfreq : float
        Sampling frequency in Hz.
    """

    names: tuple
    positions: np.ndarray = field(repr=False)
    orientations: np.ndarray = field(repr=False)
    tangential: tuple
    times: np.ndarray = field(repr=False)
    waveforms: np.ndarray = field(repr=False)
    peak_times: np.ndarray
    sfreq: float

    def dipoles(self, head):
        """Exact sources in `head`: unit orientations, the tangential ones made tangential.

        The superficial orientation loses its radial component relative to the sphere
        centre ``head.origin`` (then is normalized); this needs the head, hence lives here.

        Parameters
        ----------
        head : HeadModel
            Anything with ``origin`` (ndarray, shape (3,), metres).

        Returns
        -------
        truth : Truth
        """
        origin = np.asarray(head.origin, dtype=float)
        orientations = []
        for name, pos, ori, tangential in zip(
            self.names, self.positions, self.orientations, self.tangential, strict=True
        ):
            if tangential:
                radial = pos - origin
                if np.linalg.norm(radial) < 1e-9:
                    raise InputError(f"the {name} source sits at the sphere centre: no tangent")
                radial = radial / np.linalg.norm(radial)
                ori = ori - (ori @ radial) * radial
                if np.linalg.norm(ori) < 1e-9 * np.linalg.norm(self.orientations):
                    raise InputError(f"the {name} orientation is radial: no tangential part")
            orientations.append(ori / np.linalg.norm(ori))
        peak_times = np.array(self.peak_times, dtype=float)
        return Truth(
            names=self.names,
            positions=self.positions,
            orientations=readonly(orientations),
            waveforms=self.waveforms,
            peak_times=readonly(peak_times),
            times=self.times,
        )


def _hann(times, onset, width, peak):
    """Hann pulse ``peak * sin(pi (t - onset) / width) ** 2`` on (onset, onset + width)."""
    phase = (times - onset) / width
    inside = (phase > _PULSE_EDGE_TOL) & (phase < 1.0 - _PULSE_EDGE_TOL)
    return np.where(inside, peak * np.sin(np.pi * phase) ** 2, 0.0)


def p20n20_scenario(
    *,
    deep_position_mm=(-12, -32, 50),
    deep_orientation=(0.2, 0.196, -0.981),
    superficial_position_mm=(-33, -37, 80),
    superficial_orientation=(0.2, 1, 0),
    peak_amplitude_nam=10.0,
    pulse_ms=3.0,
    deep_onset_ms=0.0,
    superficial_onset_ms=1.0,
    sfreq=10000.0,
    duration_ms=4.0,
):
    """The paper's P20/N20 scenario: a thalamic and a cortical dipole, 2 ms apart.

    Each waveform is a Hann pulse of `pulse_ms` support (zero at both ends) peaking at
    `peak_amplitude_nam` in its centre: deep on [0, 3] ms (peak 1.5 ms), superficial on
    [1, 4] ms (peak 2.5 ms) by default, sampled at `sfreq` over 0..`duration_ms` inclusive
    (41 samples). Positions in mm, head coordinates; orientations are unit-normalized and the
    superficial one made tangential by :meth:`Scenario.dipoles`, given a head.

    Returns
    -------
    scenario : Scenario

    Examples
    --------
    >>> sc = p20n20_scenario()
    >>> sc.times.shape, sc.peak_times * 1e3
    ((41,), array([1.5, 2.5]))
    """
    positions = [check_vector("deep_position_mm", deep_position_mm, 3)]
    positions.append(check_vector("superficial_position_mm", superficial_position_mm, 3))
    orientations = []
    for name, ori in [
        ("deep_orientation", deep_orientation),
        ("superficial_orientation", superficial_orientation),
    ]:
        vec = check_vector(name, ori, 3)
        if not np.linalg.norm(vec) > 0:
            raise InputError(f"{name} must be nonzero, got {ori!r}")
        orientations.append(vec)
    peak = check_real("peak_amplitude_nam", peak_amplitude_nam, positive=True) * 1e-9
    width = check_real("pulse_ms", pulse_ms, positive=True) * 1e-3
    onsets = [
        check_real("deep_onset_ms", deep_onset_ms, nonnegative=True) * 1e-3,
        check_real("superficial_onset_ms", superficial_onset_ms, nonnegative=True) * 1e-3,
    ]
    sfreq = check_real("sfreq", sfreq, positive=True)
    duration = check_real("duration_ms", duration_ms, positive=True) * 1e-3
    if width * sfreq < 2.0:
        raise InputError(
            f"sfreq must sample each pulse at least twice: pulse_ms * sfreq / 1000 >= 2, got "
            f"sfreq={sfreq!r} with pulse_ms={pulse_ms!r}"
        )
    for name, onset in zip(("deep", "superficial"), onsets, strict=True):
        if onset + width > duration * (1 + 1e-9):
            raise InputError(
                f"duration_ms must cover every pulse: the {name} pulse ends at "
                f"{(onset + width) * 1e3:g} ms, got duration_ms={duration_ms!r}"
            )
    n_times = int(np.floor(duration * sfreq + 1e-6)) + 1
    times = np.arange(n_times) / sfreq
    waveforms = [_hann(times, onset, width, peak) for onset in onsets]
    return Scenario(
        names=("deep", "superficial"),
        positions=readonly(np.array(positions) * 1e-3),
        orientations=readonly(orientations),
        tangential=(False, True),
        times=readonly(times),
        waveforms=readonly(waveforms),
        peak_times=readonly([onset + width / 2 for onset in onsets]),
        sfreq=sfreq,
    )


@dataclass(frozen=True, eq=False)
class Simulation:
    """Simulated EEG with its ground truth.

    Attributes
    ----------
    Y : ndarray, shape (n_channels, n_times)
        Noisy data in V: the average-referenced ``Y_clean`` plus white noise (the noise
        is not re-referenced; it is what ``R = sigma**2 I`` assumes).
    Y_clean : ndarray, shape (n_channels, n_times)
        Noise-free data in V: the exact dipoles' forward field times their waveforms.
    sigma : float
        Noise standard deviation in V, ``max|Y_clean| * 10 ** (-snr_db / 20)``.
    times : ndarray, shape (n_times,)
        Sample times in seconds.
    snr_db : float
        Peak signal-to-noise ratio in dB.
    truth : Truth
        The exact sources.
    """

    Y: np.ndarray = field(repr=False)
    Y_clean: np.ndarray = field(repr=False)
    sigma: float
    times: np.ndarray = field(repr=False)
    snr_db: float
    truth: Truth = field(repr=False)


def _dipole_gain(head, truth):
    """Average-referenced fixed-orientation gain of the exact dipoles, (n_channels, 2).

    The same MNE forward computation as the grid's lead field (in float64), at the dipoles'
    own positions, projected on their orientations.
    """
    import mne

    n = len(truth.names)
    src = mne.setup_volume_source_space(
        pos=dict(rr=truth.positions, nn=np.tile([0.0, 0.0, 1.0], (n, 1))),
        sphere=head.sphere,
        mindist=0.0,
        verbose=False,
    )
    if src[0]["nuse"] != n:
        raise InputError("scenario: a source lies outside the brain compartment")
    fwd = mne.make_forward_solution(
        head.info, trans=None, src=src, bem=head.sphere, eeg=True, meg=False, verbose=False
    )
    fwd = mne.convert_forward_solution(fwd, surf_ori=False, force_fixed=False, verbose=False)
    free = np.asarray(fwd["sol"]["data"], dtype=float).reshape(head.n_channels, n, 3)
    gain = np.einsum("cnk,nk->cn", free, truth.orientations)
    if not np.isfinite(gain).all():
        raise InputError("the sources' forward field is not finite (a source at the centre?)")
    return gain - gain.mean(axis=0, keepdims=True)


def simulate(head, scenario, snr_db, seed):
    """Simulate the scenario's EEG in the head with white Gaussian noise.

    ``Y_clean = G @ waveforms`` with ``G`` the average-referenced forward field of the exact
    dipoles (MNE's forward at their own positions, float64; not grid columns: no inverse crime);
    ``Y = Y_clean + sigma * N(0, 1)`` i.i.d. over channels and time.

    Parameters
    ----------
    head : HeadModel
    scenario : Scenario
    snr_db : float
        Peak SNR in dB, within +-300: ``sigma = max|Y_clean| * 10 ** (-snr_db / 20)``.
    seed : int or numpy.random.Generator
        Noise seed for ``numpy.random.default_rng``; required, so runs are reproducible.

    Returns
    -------
    sim : Simulation

    Examples
    --------
    >>> sim = simulate(make_head_model(500), p20n20_scenario(), 20.0, seed=0)
    >>> sim.Y.shape
    (64, 41)
    """
    check_instance("head", head, HeadModel, "a HeadModel (skf_ref.head.make_head_model)")
    check_instance("scenario", scenario, Scenario, "a Scenario (p20n20_scenario)")
    snr_db = check_db("snr_db", snr_db)
    if not isinstance(seed, np.random.Generator):
        seed = check_int("seed", seed, minimum=0)
    truth = scenario.dipoles(head)
    for name, pos in zip(truth.names, truth.positions, strict=True):
        depth = np.linalg.norm(pos - head.origin)
        if depth >= head.brain_radius:
            raise InputError(
                f"scenario: the {name} source lies {depth * 1e3:.1f} mm from the sphere centre, "
                f"outside the brain compartment (radius {head.brain_radius * 1e3:.1f} mm)"
            )
        if not region_mask(head.positions, pos).any():
            raise InputError(
                f"head: no grid position within {REGION_RADIUS_MM:g} mm of the {name} source; "
                f"use a larger n_positions"
            )
    Y_clean = _dipole_gain(head, truth) @ truth.waveforms
    sigma = float(np.abs(Y_clean).max() * 10.0 ** (-snr_db / 20.0))
    noise = np.random.default_rng(seed).standard_normal(Y_clean.shape)
    return Simulation(
        Y=readonly(Y_clean + sigma * noise),
        Y_clean=readonly(Y_clean),
        sigma=sigma,
        times=truth.times,
        snr_db=snr_db,
        truth=truth,
    )
