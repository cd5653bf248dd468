"""The P20/N20 scenario and simulated EEG (docs/model.md §5).

Three steps, each a public function returning a frozen dataclass:

- :func:`make_head_model` -> :class:`HeadModel`: MNE's sphere model fitted to a montage, a
  regular cubic grid of source positions in the brain compartment and its free-orientation,
  average-referenced lead field (other heads: :mod:`skf_ref.study._head`).
- :func:`p20n20_scenario` -> :class:`Scenario`: two dipoles (deep thalamic, superficial
  cortical) at MNI coordinates, with overlapping pulses.
- :func:`simulate` -> :class:`Simulation`: data from the exact dipoles' own forward field
  (not grid columns) plus Gaussian noise at a peak SNR, white or with the spatial covariance
  of a real recording; optionally from one source only, with the noise of both (the
  controls of the reproduction study).

The head model lives in :mod:`skf_ref.study._head`. ``make_head_model`` and ``HeadModel`` can
still be reached from here, where the first release put them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils.checks import (
    InputError,
    check_choice,
    check_db,
    check_instance,
    check_int,
    check_real,
    check_vector,
)
from ..method._result import readonly
from ._head import HeadModel, make_head_model  # noqa: F401  (make_head_model: issue-4 name)
from ._regions import REGION_RADIUS_MM, region_mask

__all__ = [
    "DEEP_MNI_MM",
    "FORWARDS",
    "NOISES",
    "SOURCES",
    "SUPERFICIAL_MNI_MM",
    "WINDOWS",
    "Scenario",
    "Simulation",
    "Truth",
    "p20n20_scenario",
    "simulate",
]

_PULSE_EDGE_TOL = 1e-9  # relative phase treated as the (zero) edge of a pulse
#: The deep source: left thalamus, ventral posterolateral nucleus (VPL), MNI mm. A round-number
#: estimate of the nucleus' centre in stereotactic atlases: 16 mm left of the midline, 22 mm
#: behind and 4 mm above the anterior commissure.
DEEP_MNI_MM = (-16.0, -22.0, 4.0)
#: The superficial source: posterior wall of the left central sulcus (area 3b, hand
#: representation, the N20 generator), MNI mm.
SUPERFICIAL_MNI_MM = (-38.0, -27.0, 54.0)
#: Anatomical labels the two sources must lie in, where the head has labels.
_LABELS = ("Left-Thalamus", "Left-Cerebral-Cortex")
#: Pulse windows: the Hann window, and the 4-term Blackman-Harris window (the reference
#: toolbox's) with its coefficients.
WINDOWS = ("hann", "blackman-harris")
_BLACKMAN_HARRIS = (0.35875, 0.48829, 0.14128, 0.01168)


@dataclass(frozen=True, eq=False)
class Truth:
    """The exact sources of a simulation (index 0 deep, 1 superficial).

    Made by :meth:`Scenario.dipoles`; each parameter is an attribute of the same name.

    Parameters
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
    moved_mm : tuple of float
        How far each source was moved from its mapped MNI point into its anatomical label
        (zeros where it lay in it, or where the head has no labels or the scenario gave
        head coordinates).
    """

    names: tuple[str, ...]
    positions: np.ndarray = field(repr=False)
    orientations: np.ndarray = field(repr=False)
    waveforms: np.ndarray = field(repr=False)
    peak_times: np.ndarray
    times: np.ndarray = field(repr=False)
    moved_mm: tuple[float, ...] = (0.0, 0.0)

    @property
    def peak_indices(self) -> NDArray[np.intp]:
        """Sample index nearest to each peak time, shape (2,)."""
        return np.abs(self.times[None, :] - self.peak_times[:, None]).argmin(axis=1)


@dataclass(frozen=True, eq=False)
class Scenario:
    """Two dipoles with pulse waveforms, head independent (index 0 deep, 1 superficial).

    Made by :func:`p20n20_scenario`; each parameter is an attribute of the same name.

    Parameters
    ----------
    names : tuple of str
        ``("deep", "superficial")``.
    positions : ndarray, shape (2, 3)
        Dipole positions in metres, in ``frame``.
    orientations : ndarray, shape (2, 3)
        Orientations as given in ``frame`` (not normalized, not made tangential); see
        :meth:`dipoles`.
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
    frame : str
        ``"mni"``: positions and orientations are MNI coordinates, placed in a head by its
        anatomy; ``"head"``: head coordinates of any head.
    labels : tuple of str
        Anatomical label each source must lie in (used where the head has labels).
    window : str
        Pulse window, one of ``WINDOWS``.
    """

    names: tuple[str, ...]
    positions: np.ndarray = field(repr=False)
    orientations: np.ndarray = field(repr=False)
    tangential: tuple[bool, ...]
    times: np.ndarray = field(repr=False)
    waveforms: np.ndarray = field(repr=False)
    peak_times: np.ndarray
    sfreq: float
    frame: str = "mni"
    labels: tuple[str, ...] = _LABELS
    window: str = "hann"

    def _placed(self, head: Any) -> tuple[np.ndarray, np.ndarray, tuple[float, ...]]:
        """Head positions and orientations of the sources, and how far each was moved."""
        if self.frame == "head":
            return np.array(self.positions), np.array(self.orientations), (0.0, 0.0)
        anatomy = getattr(head, "anatomy", None)
        if anatomy is None:
            raise InputError(
                "scenario: MNI positions need a head with an anatomy (skf_ref.study._head); give "
                "head coordinates with frame='head' for other heads"
            )
        placed = [
            anatomy.place(pos, label)
            for pos, label in zip(self.positions, self.labels, strict=True)
        ]
        linear = np.asarray(anatomy.mni_to_head)[:3, :3]
        orientations = np.asarray(self.orientations) @ linear.T  # directions: linear part
        positions = np.array([pos for pos, _ in placed])
        return positions, orientations, tuple(moved for _, moved in placed)

    def dipoles(self, head: Any) -> Truth:
        """Exact sources in `head`: placed, unit orientations, the tangential ones tangential.

        MNI positions are mapped into the head by ``head.anatomy`` (and moved into their
        labels where the head has labels; :meth:`skf_ref.study._head.Anatomy.place`). A tangential
        orientation loses its component along ``head.radial(position)`` (the outward normal
        of the brain compartment nearest the source: the direction from the sphere centre,
        or the inner skull's normal), then every orientation is normalized.

        Parameters
        ----------
        head : HeadModel
            Or, for a scenario in head coordinates, anything with ``origin`` (ndarray,
            shape (3,), metres), the centre tangential is taken about.

        Returns
        -------
        truth : Truth
            The sources as placed in ``head``.
        """
        positions, given, moved = self._placed(head)
        orientations = []
        for name, pos, ori, tangential in zip(
            self.names, positions, given, self.tangential, strict=True
        ):
            if tangential:
                radial = _radial(head, pos, name)
                ori = ori - (ori @ radial) * radial
                if np.linalg.norm(ori) < 1e-9 * np.linalg.norm(given):
                    raise InputError(f"the {name} orientation is radial: no tangential part")
            orientations.append(ori / np.linalg.norm(ori))
        peak_times = np.array(self.peak_times, dtype=float)
        return Truth(
            names=self.names,
            positions=readonly(positions),
            orientations=readonly(orientations),
            waveforms=self.waveforms,
            peak_times=readonly(peak_times),
            times=self.times,
            moved_mm=moved,
        )


def _radial(head: Any, position: np.ndarray, name: str) -> np.ndarray:
    if hasattr(head, "radial"):
        return head.radial(position)
    radial = position - np.asarray(head.origin, dtype=float)
    if np.linalg.norm(radial) < 1e-9:
        raise InputError(f"the {name} source sits at the sphere centre: no tangent")
    return radial / np.linalg.norm(radial)


def _pulse(
    times: np.ndarray, onset: float, width: float, peak: float, window: str = "hann"
) -> np.ndarray:
    """A window pulse of support (onset, onset + width) peaking at ``peak`` in its centre.

    Hann: ``peak * sin(pi x) ** 2``; Blackman-Harris: ``peak * sum_k (-1)**k a_k cos(2 pi k
    x)`` with the 4-term coefficients (1 at the centre, 6e-5 at the edges, set to 0 outside);
    ``x = (t - onset) / width``.
    """
    phase = (times - onset) / width
    inside = (phase > _PULSE_EDGE_TOL) & (phase < 1.0 - _PULSE_EDGE_TOL)
    if window == "hann":
        shape = np.sin(np.pi * phase) ** 2
    else:
        shape = sum(
            (-1) ** k * a * np.cos(2 * np.pi * k * phase) for k, a in enumerate(_BLACKMAN_HARRIS)
        )
    return np.where(inside, peak * shape, 0.0)


def p20n20_scenario(
    *,
    deep_position_mm: ArrayLike = DEEP_MNI_MM,
    deep_orientation: ArrayLike = (0.2, 0.196, -0.981),
    superficial_position_mm: ArrayLike = SUPERFICIAL_MNI_MM,
    superficial_orientation: ArrayLike = (0.2, 1, 0),
    frame: str = "mni",
    peak_amplitude_nam: float = 10.0,
    pulse_ms: float = 3.0,
    deep_onset_ms: float = 0.0,
    superficial_onset_ms: float = 1.0,
    sfreq: float = 10000.0,
    duration_ms: float = 4.0,
    window: str = "hann",
) -> Scenario:
    """The paper's P20/N20 scenario: a thalamic and a cortical dipole, 2 ms apart.

    Each waveform is a pulse of `pulse_ms` support (zero at both ends; `window` "hann" or
    "blackman-harris") peaking at `peak_amplitude_nam` in its centre: deep on [0, 3] ms (peak
    1.5 ms), superficial on [1, 4] ms (peak 2.5 ms) by default, sampled at `sfreq` over
    0..`duration_ms` inclusive (41 samples). Positions in mm and orientations, both in
    `frame`: ``"mni"`` (the default: ``DEEP_MNI_MM`` in the left thalamus' VPL nucleus,
    ``SUPERFICIAL_MNI_MM`` on the posterior wall of the left central sulcus) or
    ``"head"`` (head coordinates). :meth:`Scenario.dipoles` places them in a head,
    normalizes the orientations and makes the superficial one tangential.

    Parameters
    ----------
    deep_position_mm : array_like, shape (3,)
        The deep source's position in mm, in ``frame``.
    deep_orientation : array_like, shape (3,)
        Its orientation in ``frame``, nonzero (normalized when placed).
    superficial_position_mm : array_like, shape (3,)
        The superficial source's position in mm, in ``frame``.
    superficial_orientation : array_like, shape (3,)
        Its orientation in ``frame``, nonzero (made tangential and normalized when placed).
    frame : {"mni", "head"}
        The coordinates of the positions and orientations.
    peak_amplitude_nam : float
        Each pulse's peak dipole moment in nA·m.
    pulse_ms : float
        Each pulse's support in ms.
    deep_onset_ms, superficial_onset_ms : float
        Where each pulse starts, ms.
    sfreq : float
        Sampling frequency in Hz; it samples each pulse at least twice.
    duration_ms : float
        The data's span in ms; it covers every pulse.
    window : {"hann", "blackman-harris"}
        The pulses' window.

    Returns
    -------
    scenario : Scenario
        Head independent: :meth:`Scenario.dipoles` places it in a head.

    Examples
    --------
    >>> sc = p20n20_scenario()
    >>> sc.times.shape, sc.peak_times * 1e3
    ((41,), array([1.5, 2.5]))
    """
    check_choice("frame", frame, ("mni", "head"))
    check_choice("window", window, WINDOWS)
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
    rate = check_real("sfreq", sfreq, positive=True)
    duration = check_real("duration_ms", duration_ms, positive=True) * 1e-3
    if width * rate < 2.0:
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
    n_times = int(np.floor(duration * rate + 1e-6)) + 1
    times = np.arange(n_times) / rate
    waveforms = [_pulse(times, onset, width, peak, window) for onset in onsets]
    return Scenario(
        names=("deep", "superficial"),
        positions=readonly(np.array(positions) * 1e-3),
        orientations=readonly(orientations),
        tangential=(False, True),
        times=readonly(times),
        waveforms=readonly(waveforms),
        peak_times=readonly([onset + width / 2 for onset in onsets]),
        sfreq=rate,
        frame=frame,
        window=window,
    )


@dataclass(frozen=True, eq=False)
class Simulation:
    """Simulated EEG with its ground truth.

    Made by :func:`simulate`; each parameter is an attribute of the same name.

    Parameters
    ----------
    Y : ndarray, shape (n_channels, n_times)
        Noisy data in V: the average-referenced ``Y_clean`` plus noise drawn from
        ``noise_cov`` (white noise is not re-referenced: it is what ``R = sigma**2 I``
        assumes; the head's recorded noise is average referenced, as its covariance).
    Y_clean : ndarray, shape (n_channels, n_times)
        Noise-free data in V: the active dipoles' forward field times their waveforms.
    sigma : float
        Noise standard deviation in V, ``max|Y_clean| * 10 ** (-snr_db / 20)`` of the data
        with both sources.
    times : ndarray, shape (n_times,)
        Sample times in seconds.
    snr_db : float
        Peak signal-to-noise ratio in dB.
    truth : Truth
        The exact sources (both, whichever are active).
    sources : tuple of str
        The sources active in the data.
    noise : str
        ``"white"`` or ``"head"`` (the head's recorded noise covariance).
    noise_cov : ndarray, shape (n_channels, n_channels)
        The covariance the noise was drawn from, V²: ``sigma**2 I`` for white noise; the
        head's covariance scaled to a mean channel variance of ``sigma**2`` otherwise.
    """

    Y: np.ndarray = field(repr=False)
    Y_clean: np.ndarray = field(repr=False)
    sigma: float
    times: np.ndarray = field(repr=False)
    snr_db: float
    truth: Truth = field(repr=False)
    sources: tuple[str, ...] = ("deep", "superficial")
    noise: str = "white"
    noise_cov: np.ndarray | None = field(default=None, repr=False)


SOURCES = ("deep", "superficial")
FORWARDS = ("exact", "grid")
#: Kinds of noise: white, or with the spatial covariance of the head's recording.
NOISES = ("white", "head")


def _grid_gain(head: HeadModel, truth: Truth) -> np.ndarray:
    """Average-referenced gain of the grid columns at each source's nearest position."""
    nearest = np.linalg.norm(head.positions[:, None] - truth.positions[None], axis=2)
    columns = [head.leadfield[:, 3 * p : 3 * p + 3] for p in nearest.argmin(axis=0)]
    return np.stack(
        [cols @ ori for cols, ori in zip(columns, truth.orientations, strict=True)], axis=1
    )


def simulate(
    head: HeadModel,
    scenario: Scenario,
    snr_db: float,
    seed: int | np.random.Generator,
    *,
    sources: Sequence[str] = SOURCES,
    forward: str = "exact",
    noise: str = "white",
) -> Simulation:
    """Simulate the scenario's EEG in the head with Gaussian noise.

    ``Y_clean = G @ waveforms`` with ``G`` the average-referenced forward field of the exact
    dipoles (MNE's forward at their own positions, float64; not grid columns: no inverse crime);
    ``Y = Y_clean + sigma * N(0, 1)`` i.i.d. over channels and time (white noise), or
    ``Y = Y_clean + F N(0, 1)`` with ``F F^T = C`` the head's recorded noise covariance scaled
    to a mean channel variance of ``sigma**2`` (``noise="head"``: spatially correlated as
    the recording, i.i.d. over time).

    Parameters
    ----------
    head : HeadModel
        The head (:func:`skf_ref.study._head.make_head`).
    scenario : Scenario
        The sources (:func:`p20n20_scenario`).
    snr_db : float
        Peak SNR in dB, within +-300: ``sigma = max|Y_clean| * 10 ** (-snr_db / 20)`` of the
        data with both sources.
    seed : int or numpy.random.Generator
        Noise seed for ``numpy.random.default_rng``; required, so runs are reproducible.
    sources : sequence of str
        The sources active in the data, of ``("deep", "superficial")``. With one, the data
        hold that source's field and the noise (same ``sigma``, same draws) of the data with
        both: a control that shows what the other source contributes. ``truth`` keeps both.
    forward : {"exact", "grid"}
        ``"grid"``: the field of each source is its nearest grid position's lead-field
        columns projected on its orientation (an "inverse crime", for comparison only).
    noise : {"white", "head"}
        ``"head"`` needs a head with a recorded noise covariance (``head.noise_cov``: the
        realistic head with the subject's own electrodes, ``montage="sample"``).

    Returns
    -------
    sim : Simulation
        The data, the noise's covariance and the truth.

    Examples
    --------
    >>> sim = simulate(make_head_model(500), p20n20_scenario(), 20.0, seed=0)
    >>> sim.Y.shape
    (64, 41)
    """
    check_instance("head", head, HeadModel, "a HeadModel (skf_ref.study._head.make_head_model)")
    check_instance("scenario", scenario, Scenario, "a Scenario (p20n20_scenario)")
    snr = check_db("snr_db", snr_db)
    if not isinstance(seed, np.random.Generator):
        seed = check_int("seed", seed, minimum=0)
    if isinstance(sources, str) or not all(name in SOURCES for name in sources) or not sources:
        raise InputError(f"sources must be a non-empty subset of {list(SOURCES)}, got {sources!r}")
    check_choice("forward", forward, FORWARDS)
    check_choice("noise", noise, NOISES)
    if noise == "head" and head.noise_cov is None:
        raise InputError(
            "noise='head' needs a head with a recorded noise covariance (head.noise_cov): "
            "the realistic head with montage='sample'; this head has none"
        )
    truth = scenario.dipoles(head)
    for name, pos in zip(truth.names, truth.positions, strict=True):
        if head.anatomy is None or head.anatomy.boundary is None:
            depth = np.linalg.norm(pos - head.origin)
            if depth >= head.brain_radius:
                raise InputError(
                    f"scenario: the {name} source lies {depth * 1e3:.1f} mm from the sphere "
                    f"centre, outside the brain compartment (radius "
                    f"{head.brain_radius * 1e3:.1f} mm)"
                )
        if not region_mask(head.positions, pos).any():
            raise InputError(
                f"head: no grid position within {REGION_RADIUS_MM:g} mm of the {name} source; "
                f"use a larger n_positions"
            )
    if forward == "exact":
        gain = head.dipole_gain(truth.positions, truth.orientations)
    else:
        gain = _grid_gain(head, truth)
    sigma = float(np.abs(gain @ truth.waveforms).max() * 10.0 ** (-snr / 20.0))
    active = np.array([name in sources for name in truth.names], dtype=float)
    Y_clean = gain @ (active[:, None] * truth.waveforms)
    rng = np.random.default_rng(seed)
    if head.noise_cov is None or noise == "white":
        noise_cov = sigma**2 * np.eye(len(Y_clean))
        drawn = sigma * rng.standard_normal(Y_clean.shape)
    else:
        noise_cov = head.noise_cov * (sigma**2 / np.mean(np.diag(head.noise_cov)))
        factor = _covariance_factor(noise_cov)
        drawn = factor @ rng.standard_normal((factor.shape[1], Y_clean.shape[1]))
    return Simulation(
        Y=readonly(Y_clean + drawn),
        Y_clean=readonly(Y_clean),
        sigma=sigma,
        times=truth.times,
        snr_db=snr,
        truth=truth,
        sources=tuple(name for name in truth.names if name in sources),
        noise=noise,
        noise_cov=readonly(noise_cov),
    )


def _covariance_factor(C: np.ndarray) -> np.ndarray:
    """``F`` with ``F F^T = C`` for a symmetric positive semi-definite ``C`` (eigh; the
    directions of eigenvalues at rounding level, an average reference's, left out)."""
    lam, U = np.linalg.eigh(C)
    keep = lam > lam[-1] * 1e-12
    return U[:, keep] * np.sqrt(lam[keep])
