"""Spherical head model, the P20/N20 scenario and simulated EEG (shared/SKF_SPEC.md §5).

Three steps, each a public function returning a frozen dataclass:

- :func:`make_head_model` -> :class:`HeadModel`: MNE's sphere model fitted to a montage, a
  regular cubic grid of source positions in the brain compartment and its free-orientation,
  average-referenced lead field.
- :func:`p20n20_scenario` -> :class:`Scenario`: two dipoles (deep thalamic, superficial
  cortical) with overlapping Hann pulses.
- :func:`simulate` -> :class:`Simulation`: data from the exact dipoles' own forward field
  (not grid columns) plus white Gaussian noise at a peak SNR.

Source grid. Positions ``origin + spacing * (k + u)`` for integer ``k`` inside the *source
ball*, the brain compartment (innermost sphere layer) shrunk by ``MINDIST_MM`` = 5 mm, MNE's
default ``mindist`` for volume source spaces. ``u = (1/2, 1/2, 1/2)`` (``seed=None``) puts
the sphere centre at the centre of a cell, so the grid is symmetric about it and no position
sits at the centre itself, where MNE's sphere forward returns NaN; an integer seed draws ``u``
uniformly from the unit cell. The spacing is closed form: with ``d_1 <= d_2 <= ...`` the
distances of the lattice points ``k + u`` from the centre, in cells, the grid radius is put
midway between ``d_n`` and ``d_{n+1}``, so the ball holds exactly ``n`` points (the nearest
count possible when several points share a distance). Whether a grid can hold the scenario is
checked where the two meet, in :func:`simulate`: each source's 15 mm region (the metrics'
region) must contain a grid position, which a spacing of at most 2 * 15 mm / sqrt(3) (the
covering radius of a cubic lattice; about 420 positions for ``biosemi64``) always ensures.
"""

from __future__ import annotations

import copy
import functools
import numbers
from dataclasses import dataclass, field, replace

import numpy as np

from .metrics import REGION_RADIUS_MM, region_mask

__all__ = [
    "MINDIST_MM",
    "MIN_POSITIONS",
    "HeadModel",
    "Scenario",
    "Simulation",
    "Truth",
    "make_head_model",
    "p20n20_scenario",
    "simulate",
]

#: Margin (mm) between the source grid and the brain compartment's boundary (MNE's default).
MINDIST_MM = 5.0
#: Fewest grid positions a head model may have (the scenario may need more, see simulate).
MIN_POSITIONS = 10
_SFREQ_IRRELEVANT = 10000.0
_PULSE_EDGE_TOL = 1e-9  # relative phase treated as the (zero) edge of a Hann pulse


def _readonly(array):
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class HeadModel:
    """Sphere head model with a volume source grid and its EEG lead field.

    Attributes
    ----------
    leadfield : ndarray, shape (n_channels, 3 * n_positions)
        Free-orientation lead field in V/(A·m), average referenced (every column has zero
        channel mean); columns are MNE's x, y, z of position 0, then position 1, ...
    positions : ndarray, shape (n_positions, 3)
        Source positions in metres, head coordinates.
    info : mne.Info
        EEG channels with the montage and an (inactive) average-reference projection.
    sphere : mne.bem.ConductorModel
        The sphere model (``make_sphere_model("auto", "auto", info)``).
    src : mne.SourceSpaces
        Discrete MNE source space holding ``positions``.
    fwd : mne.Forward
        MNE's free-orientation forward as computed, *not* average referenced.
    montage : str
        Name of the built-in montage.
    seed : int or None
        Grid offset seed (None: canonical grid).
    spacing : float
        Grid spacing in metres.
    """

    leadfield: np.ndarray = field(repr=False)
    positions: np.ndarray = field(repr=False)
    info: object = field(repr=False)
    sphere: object = field(repr=False)
    src: object = field(repr=False)
    fwd: object = field(repr=False)
    montage: str = "biosemi64"
    seed: int | None = None
    spacing: float = float("nan")

    @property
    def n_positions(self):
        """int : Number of source positions."""
        return self.positions.shape[0]

    @property
    def n_channels(self):
        """int : Number of EEG channels."""
        return self.leadfield.shape[0]

    @property
    def origin(self):
        """ndarray, shape (3,) : Sphere centre in metres, head coordinates."""
        return np.array(self.sphere["r0"], dtype=float)

    @property
    def brain_radius(self):
        """float : Radius (m) of the brain compartment, the innermost sphere layer."""
        return float(min(layer["rad"] for layer in self.sphere["layers"]))


def make_head_model(n_positions=3000, montage="biosemi64", seed=None):
    """Build the spherical EEG head model with a grid of about `n_positions` positions.

    Parameters
    ----------
    n_positions : int
        Requested number of grid positions (the result holds this many, or the nearest
        count the lattice allows), at least ``MIN_POSITIONS``. To hold the P20/N20 scenario
        (see :func:`simulate`) about 420 or more for ``biosemi64``.
    montage : str
        Name of an MNE built-in montage (``mne.channels.get_builtin_montages()``).
    seed : int or None
        None: canonical grid, symmetric about the sphere centre. An int: grid shifted by a
        random offset within one cell (``numpy.random.default_rng(seed)``).

    Returns
    -------
    head : HeadModel
        Arrays are read-only and shared between calls with equal arguments (cached); the
        MNE objects are fresh copies.

    Examples
    --------
    >>> head = make_head_model(500)
    >>> head.leadfield.shape == (64, 3 * head.n_positions)
    True
    """
    if isinstance(n_positions, bool) or not isinstance(n_positions, numbers.Integral):
        raise ValueError(f"n_positions must be an int, got {n_positions!r}")
    if not isinstance(montage, str) or montage not in _builtin_montages():
        raise ValueError(
            f"montage must be the name of an MNE built-in montage such as 'biosemi64', "
            f"'biosemi32', 'standard_1020' (see mne.channels.get_builtin_montages()), "
            f"got {montage!r}"
        )
    if seed is not None and (
        isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0
    ):
        raise ValueError(f"seed must be None or a non-negative int, got {seed!r}")
    cached = _build_head(int(n_positions), montage, None if seed is None else int(seed))
    return replace(
        cached,
        info=cached.info.copy(),
        sphere=copy.deepcopy(cached.sphere),
        src=cached.src.copy(),
        fwd=cached.fwd.copy(),
    )


@functools.cache
def _builtin_montages():
    import mne

    return frozenset(mne.channels.get_builtin_montages())


@functools.lru_cache(maxsize=8)
def _sensors(montage):
    """Info (with average-reference projection) and fitted sphere for a montage."""
    import mne

    digmontage = mne.channels.make_standard_montage(montage)
    info = mne.create_info(digmontage.ch_names, _SFREQ_IRRELEVANT, "eeg")
    info.set_montage(digmontage, verbose=False)
    raw = mne.io.RawArray(np.zeros((len(info.ch_names), 1)), info, verbose=False)
    raw.set_eeg_reference("average", projection=True, verbose=False)
    sphere = mne.make_sphere_model("auto", "auto", raw.info, verbose=False)
    return raw.info, sphere


def _grid_cells(n_positions, offset):
    """Lattice points ``k + offset`` (in cells) of the ball holding ~n_positions of them.

    Returns the points, shape (n, 3), and the ball radius in cells, midway between the
    distances of the n-th and (n+1)-th nearest lattice points (or the nearest tie break).
    """
    t_guess = (3.0 * n_positions / (4.0 * np.pi)) ** (1.0 / 3.0)
    k = np.arange(-int(np.ceil(1.3 * t_guess)) - 2, int(np.ceil(1.3 * t_guess)) + 3)
    cells = np.stack(np.meshgrid(k, k, k, indexing="ij"), axis=-1).reshape(-1, 3) + offset
    dist = np.sort(np.linalg.norm(cells, axis=1))
    gaps = np.flatnonzero(np.diff(dist) > 1e-9)  # dist[g] < dist[g + 1]: count g + 1 possible
    best = gaps[np.argmin(np.abs(gaps + 1 - n_positions))]
    radius = 0.5 * (dist[best] + dist[best + 1])
    return cells[np.linalg.norm(cells, axis=1) <= radius], radius


@functools.lru_cache(maxsize=8)
def _build_head(n_positions, montage, seed):
    import mne

    info, sphere = _sensors(montage)
    origin = np.asarray(sphere["r0"], dtype=float)
    brain_radius = min(layer["rad"] for layer in sphere["layers"])
    ball = brain_radius - MINDIST_MM * 1e-3
    if n_positions < MIN_POSITIONS:
        raise ValueError(f"n_positions must be at least {MIN_POSITIONS}, got {n_positions}")
    if seed is None:
        offset = np.full(3, 0.5)
    else:
        offset = np.random.default_rng(seed).random(3)
    cells, radius = _grid_cells(n_positions, offset)
    spacing = ball / radius
    positions = origin + spacing * cells
    normals = np.tile([0.0, 0.0, 1.0], (len(positions), 1))
    src = mne.setup_volume_source_space(
        pos=dict(rr=positions, nn=normals), sphere=sphere, verbose=False
    )
    fwd = mne.make_forward_solution(
        info, trans=None, src=src, bem=sphere, eeg=True, meg=False, verbose=False
    )
    fwd = mne.convert_forward_solution(fwd, surf_ori=False, force_fixed=False, verbose=False)
    gain = fwd["sol"]["data"]
    if gain.shape != (len(info.ch_names), 3 * len(positions)) or not np.isfinite(gain).all():
        raise RuntimeError("MNE returned an unexpected or non-finite forward solution")
    return HeadModel(
        leadfield=_readonly(gain - gain.mean(axis=0, keepdims=True)),
        positions=_readonly(fwd["source_rr"]),
        info=info,
        sphere=sphere,
        src=src,
        fwd=fwd,
        montage=montage,
        seed=seed,
        spacing=float(spacing),
    )


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
                    raise ValueError(f"the {name} source sits at the sphere centre: no tangent")
                radial = radial / np.linalg.norm(radial)
                ori = ori - (ori @ radial) * radial
                if np.linalg.norm(ori) < 1e-9 * np.linalg.norm(self.orientations):
                    raise ValueError(f"the {name} orientation is radial: no tangential part")
            orientations.append(ori / np.linalg.norm(ori))
        peak_times = np.array(self.peak_times, dtype=float)
        return Truth(
            names=self.names,
            positions=self.positions,
            orientations=_readonly(orientations),
            waveforms=self.waveforms,
            peak_times=_readonly(peak_times),
            times=self.times,
        )


def _vector(value, name):
    vec = np.asarray(value, dtype=float) if _is_numeric(value) else None
    if vec is None or vec.shape != (3,) or not np.isfinite(vec).all():
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}")
    return vec


def _is_numeric(value):
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return True


def _real(value, name, *, minimum=None, strict=True):
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if not ok or not np.isfinite(value):
        raise ValueError(f"{name} must be a finite real number, got {value!r}")
    if minimum is not None and (value <= minimum if strict else value < minimum):
        raise ValueError(f"{name} must be {'>' if strict else '>='} {minimum}, got {value!r}")
    return float(value)


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
    positions = [_vector(deep_position_mm, "deep_position_mm")]
    positions.append(_vector(superficial_position_mm, "superficial_position_mm"))
    orientations = []
    for name, ori in [
        ("deep_orientation", deep_orientation),
        ("superficial_orientation", superficial_orientation),
    ]:
        vec = _vector(ori, name)
        if not np.linalg.norm(vec) > 0:
            raise ValueError(f"{name} must be nonzero, got {ori!r}")
        orientations.append(vec)
    peak = _real(peak_amplitude_nam, "peak_amplitude_nam", minimum=0.0) * 1e-9
    width = _real(pulse_ms, "pulse_ms", minimum=0.0) * 1e-3
    onsets = [
        _real(deep_onset_ms, "deep_onset_ms", minimum=0.0, strict=False) * 1e-3,
        _real(superficial_onset_ms, "superficial_onset_ms", minimum=0.0, strict=False) * 1e-3,
    ]
    sfreq = _real(sfreq, "sfreq", minimum=0.0)
    duration = _real(duration_ms, "duration_ms", minimum=0.0) * 1e-3
    if width * sfreq < 2.0:
        raise ValueError(
            f"sfreq must sample each pulse at least twice: pulse_ms * sfreq / 1000 >= 2, got "
            f"sfreq={sfreq!r} with pulse_ms={pulse_ms!r}"
        )
    for name, onset in zip(("deep", "superficial"), onsets, strict=True):
        if onset + width > duration * (1 + 1e-9):
            raise ValueError(
                f"duration_ms must cover every pulse: the {name} pulse ends at "
                f"{(onset + width) * 1e3:g} ms, got duration_ms={duration_ms!r}"
            )
    n_times = int(np.floor(duration * sfreq + 1e-6)) + 1
    times = np.arange(n_times) / sfreq
    waveforms = [_hann(times, onset, width, peak) for onset in onsets]
    return Scenario(
        names=("deep", "superficial"),
        positions=_readonly(np.array(positions) * 1e-3),
        orientations=_readonly(orientations),
        tangential=(False, True),
        times=_readonly(times),
        waveforms=_readonly(waveforms),
        peak_times=_readonly([onset + width / 2 for onset in onsets]),
        sfreq=sfreq,
    )


@dataclass(frozen=True, eq=False)
class Simulation:
    """Simulated EEG with its ground truth.

    Attributes
    ----------
    Y : ndarray, shape (n_channels, n_times)
        Noisy data in V, average referenced.
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
        raise ValueError("scenario: a source lies outside the brain compartment")
    fwd = mne.make_forward_solution(
        head.info, trans=None, src=src, bem=head.sphere, eeg=True, meg=False, verbose=False
    )
    fwd = mne.convert_forward_solution(fwd, surf_ori=False, force_fixed=False, verbose=False)
    free = np.asarray(fwd["sol"]["data"], dtype=float).reshape(head.n_channels, n, 3)
    gain = np.einsum("cnk,nk->cn", free, truth.orientations)
    if not np.isfinite(gain).all():
        raise ValueError("the sources' forward field is not finite (a source at the centre?)")
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
        Peak SNR in dB: ``sigma = max|Y_clean| * 10 ** (-snr_db / 20)``.
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
    if not isinstance(head, HeadModel):
        raise ValueError(f"head must be a HeadModel, got {type(head).__name__}")
    if not isinstance(scenario, Scenario):
        raise ValueError(f"scenario must be a Scenario, got {type(scenario).__name__}")
    snr_db = _real(snr_db, "snr_db")
    if isinstance(seed, bool) or not isinstance(seed, (numbers.Integral, np.random.Generator)):
        raise ValueError(f"seed must be an int or a numpy.random.Generator, got {seed!r}")
    truth = scenario.dipoles(head)
    for name, pos in zip(truth.names, truth.positions, strict=True):
        depth = np.linalg.norm(pos - head.origin)
        if depth >= head.brain_radius:
            raise ValueError(
                f"scenario: the {name} source lies {depth * 1e3:.1f} mm from the sphere centre, "
                f"outside the brain compartment (radius {head.brain_radius * 1e3:.1f} mm)"
            )
        if not region_mask(head.positions, pos).any():
            raise ValueError(
                f"head: no grid position within {REGION_RADIUS_MM:g} mm of the {name} source; "
                f"use a larger n_positions"
            )
    Y_clean = _dipole_gain(head, truth) @ truth.waveforms
    sigma = float(np.abs(Y_clean).max() * 10.0 ** (-snr_db / 20.0))
    noise = np.random.default_rng(seed).standard_normal(Y_clean.shape)
    return Simulation(
        Y=_readonly(Y_clean + sigma * noise),
        Y_clean=_readonly(Y_clean),
        sigma=sigma,
        times=truth.times,
        snr_db=snr_db,
        truth=truth,
    )
