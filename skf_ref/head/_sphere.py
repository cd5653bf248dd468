"""The spherical EEG head model with a volume source grid (docs/model.md §5).

Source grid. Positions ``origin + spacing * (k + u)`` for integer ``k`` inside the *source
ball*, the brain compartment (innermost sphere layer) shrunk by ``MINDIST_MM`` = 5 mm, MNE's
default ``mindist`` for volume source spaces. ``u = (1/2, 1/2, 1/2)`` (``seed=None``) puts
the sphere centre at the centre of a cell, so the grid is symmetric about it and no position
sits at the centre itself, where MNE's sphere forward returns NaN; an integer seed draws ``u``
uniformly from the unit cell. The spacing is closed form: with ``d_1 <= d_2 <= ...`` the
distances of the lattice points ``k + u`` from the centre, in cells, the grid radius is put
midway between ``d_n`` and ``d_{n+1}``, so the ball holds exactly ``n`` points (the nearest
count possible when several points share a distance).

Whether a grid can hold the scenario is checked where the two meet, in
:func:`skf_ref.simulate.simulate`: each source's 15 mm region (the metrics' region) must
contain a grid position, which a spacing of at most 2 * 15 mm / sqrt(3) (the covering radius
of a cubic lattice; about 420 positions for ``biosemi64``) always ensures.
"""

from __future__ import annotations

import copy
import functools
from dataclasses import dataclass, field, replace

import numpy as np

from .checks import InputError, check_int
from .result import readonly

__all__ = [
    "MINDIST_MM",
    "MIN_POSITIONS",
    "HeadModel",
    "check_montage",
    "grid_size",
    "check_size",
    "make_head_model",
    "required_memory",
]

#: Margin (mm) between the source grid and the brain compartment's boundary (MNE's default).
MINDIST_MM = 5.0
#: Fewest grid positions a head model may have (the scenario may need more, see simulate).
MIN_POSITIONS = 10
_SFREQ_IRRELEVANT = 10000.0


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
    n_positions = check_int("n_positions", n_positions, minimum=MIN_POSITIONS)
    check_montage(montage)
    if seed is not None:
        seed = check_int("seed", seed, minimum=0)
    cached = _build_head(n_positions, montage, seed)
    return replace(
        cached,
        info=cached.info.copy(),
        sphere=copy.deepcopy(cached.sphere),
        src=cached.src.copy(),
        fwd=cached.fwd.copy(),
    )


def check_montage(montage):
    """``montage`` if it names an MNE built-in montage, else an :class:`~skf_ref.InputError`."""
    if not isinstance(montage, str) or montage not in _builtin_montages():
        raise InputError(
            f"montage must be the name of an MNE built-in montage such as 'biosemi64', "
            f"'biosemi32', 'standard_1020' (see mne.channels.get_builtin_montages()), "
            f"got {montage!r}"
        )
    return montage


def grid_size(n_positions=3000, seed=None):
    """The number of positions ``make_head_model(n_positions, seed=seed)`` holds, cheaply.

    The lattice count nearest to the request (see the module docstring); no forward model
    is computed.

    Examples
    --------
    >>> grid_size(3000)
    3016
    """
    n_positions = check_int("n_positions", n_positions, minimum=MIN_POSITIONS)
    return len(_grid_cells(n_positions, _offset(seed))[0])


def required_memory(n_positions=3000, montage="biosemi64"):
    """Bytes that building ``make_head_model(n_positions, montage)`` needs, about.

    MNE's forward computation peaked at 10-15 times the size of the lead field it returns
    (3000 and 12 000 positions, biosemi64, measured with the peak resident size); this
    allows 16 times.

    Returns
    -------
    int

    Examples
    --------
    >>> required_memory(3000) / 2**20  # MiB
    70.3...
    """
    n_channels = len(_sensors(check_montage(montage))[0]["ch_names"])
    n_positions = check_int("n_positions", n_positions, minimum=MIN_POSITIONS)
    return 16 * 8 * n_channels * 3 * n_positions  # the grid holds n_positions within ~1 %


def check_size(n_positions, montage="biosemi64", *, extra=0, name="n_positions"):
    """Refuse, before any work, a head model (plus ``extra`` bytes) that does not fit.

    Raises ``MemoryError`` naming ``name`` (a parameter or a command-line flag).
    """
    from . import memory

    memory.require(required_memory(n_positions, montage) + extra, f"{name} {n_positions}")


def _offset(seed):
    """The grid's offset within a cell: the centre, or drawn from the seed."""
    if seed is None:
        return np.full(3, 0.5)
    return np.random.default_rng(check_int("seed", seed, minimum=0)).random(3)


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
    cells, radius = _grid_cells(n_positions, _offset(seed))
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
        leadfield=readonly(gain - gain.mean(axis=0, keepdims=True)),
        positions=readonly(np.array(fwd["source_rr"], dtype=float)),
        info=info,
        sphere=sphere,
        src=src,
        fwd=fwd,
        montage=montage,
        seed=seed,
        spacing=float(spacing),
    )
