"""The spherical EEG head models: a volume grid, or cortex and thalamus (docs/model.md §5).

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
:func:`skf_ref.study._scenario.simulate`: each source's 15 mm region (the metrics' region) must
contain a grid position, which a spacing of at most 2 * 15 mm / sqrt(3) (the covering radius
of a cubic lattice; about 420 positions for ``biosemi64``) always ensures.

Cortex and thalamus in a sphere. The sphere has no anatomy; its nearest equivalent of the
realistic head's cortex + thalamus source space (:data:`SHELL_DEPTH_MM`,
:data:`THALAMUS_RADIUS_MM`, :data:`THALAMUS_MNI_MM`) is, on a 6 mm lattice centred like the
volume grid (``SPHERE_ANATOMICAL_SPACING_MM``: about as many positions as the sample
subject's 5 mm cortex + thalamus): the *cortex*, every position 5-20 mm below the brain
sphere's surface at or above the plane of the montage's fiducials (the sample subject's 5 mm
cortex positions lie 9-53 mm, median 28 mm, below its inner skull, and all above that plane;
20 mm takes in the depth of the scenario's superficial source, 17 mm, on the sulcal wall);
and two *thalami*, balls of the volume of the sample subject's left thalamus label (7.9 cm³,
radius 12.4 mm) around the MNI centroids of the sample subject's thalami, (-12, -19, 7) and
(12, -19, 7) mm.

MNI coordinates. The sphere is fitted to a template montage, so MNI coordinates are placed
in it through the template (MNE's fsaverage, whose MRI coordinates are MNI coordinates): its
fiducials define the head frame as MNE defines any (origin between the preauricular points,
x towards the right one, y towards the nasion), which is also how the montage's head
frame is defined.
"""

from __future__ import annotations

import functools
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..._utils.checks import InputError, check_int, check_real
from ...method._result import readonly
from .._sizes import DEFAULT_POSITIONS
from ._model import Anatomy, HeadModel, apply_affine, finish_forward, sensors

if TYPE_CHECKING:
    import mne

__all__ = [
    "MINDIST_MM",
    "MIN_POSITIONS",
    "SHELL_DEPTH_MM",
    "THALAMUS_MNI_MM",
    "THALAMUS_RADIUS_MM",
    "ANATOMICAL_SPACING_MM",
    "SPHERE_ANATOMICAL_SPACING_MM",
    "check_montage",
    "check_size",
    "grid_size",
    "make_head_model",
    "make_sphere_head",
    "required_memory",
    "template_mni_to_head",
]

#: Margin (mm) between the source grid and the brain compartment's boundary (MNE's default).
MINDIST_MM = 5.0
#: Fewest grid positions a head model may have (the scenario may need more, see simulate).
MIN_POSITIONS = 10
#: Spacing (mm) of the BEM head's cortex + thalamus source space (MNE's default).
ANATOMICAL_SPACING_MM = 5.0
#: Spacing (mm) of the sphere's cortex + thalamus: its smooth 15 mm band then holds about as
#: many positions as the sample subject's folded cortex at 5 mm (3717 against 3550).
SPHERE_ANATOMICAL_SPACING_MM = 6.0
#: Depths (mm) below the brain sphere's surface of the sphere's "cortex".
SHELL_DEPTH_MM = (MINDIST_MM, 20.0)
#: MNI centroids (mm) of the sample subject's left and right thalamus labels.
THALAMUS_MNI_MM = ((-12.0, -19.0, 7.0), (12.0, -19.0, 7.0))
#: Radius (mm) of a ball with the volume of the sample subject's left thalamus label.
THALAMUS_RADIUS_MM = 12.4


def make_head_model(
    n_positions: int = DEFAULT_POSITIONS, montage: str = "biosemi64", seed: int | None = None
) -> HeadModel:
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
    count = check_int("n_positions", n_positions, minimum=MIN_POSITIONS)
    check_montage(montage)
    offset_seed = None if seed is None else check_int("seed", seed, minimum=0)
    return _fresh(_build_head(count, montage, offset_seed))


def make_sphere_head(
    source_space: str = "volume",
    n_positions: int = DEFAULT_POSITIONS,
    montage: str = "biosemi64",
    spacing_mm: float | None = None,
) -> HeadModel:
    """The sphere head with either source space (see the module docstring).

    Parameters
    ----------
    source_space : {"volume", "anatomical"}
        ``"volume"``: :func:`make_head_model` (``n_positions``); ``"anatomical"``: the
        sphere's cortex and thalami on a lattice of ``spacing_mm`` (``n_positions`` is not
        used).
    n_positions : int
        Requested grid positions of the volume grid (:func:`make_head_model`).
    montage : str
        Name of an MNE built-in montage.
    spacing_mm : float or None
        The anatomical lattice's spacing; None: ``SPHERE_ANATOMICAL_SPACING_MM``.

    Returns
    -------
    head : HeadModel
        Arrays read-only and shared between calls with equal arguments; fresh MNE objects.
    """
    if source_space == "volume":
        return make_head_model(n_positions, montage)
    if source_space != "anatomical":
        raise InputError(f"source_space must be 'volume' or 'anatomical', got {source_space!r}")
    spacing = SPHERE_ANATOMICAL_SPACING_MM if spacing_mm is None else spacing_mm
    spacing = check_real("spacing_mm", spacing, minimum=1.0, maximum=20.0)
    return _fresh(_build_anatomical(check_montage(montage), spacing))


def _fresh(cached: HeadModel) -> HeadModel:
    import copy

    return replace(
        cached,
        info=cached.info.copy(),
        conductor=copy.deepcopy(cached.conductor),
        src=None if cached.src is None else cached.src.copy(),
        fwd=None if cached.fwd is None else cached.fwd.copy(),
    )


def check_montage(montage: str) -> str:
    """Check that ``montage`` names an MNE built-in montage.

    Parameters
    ----------
    montage : str
        The name (``mne.channels.get_builtin_montages()``).

    Returns
    -------
    str
        ``montage``.

    Raises
    ------
    skf_ref.InputError
        If it is not a built-in montage's name.
    """
    if not isinstance(montage, str) or montage not in _builtin_montages():
        raise InputError(
            f"montage must be the name of an MNE built-in montage such as 'biosemi64', "
            f"'biosemi32', 'standard_1020' (see mne.channels.get_builtin_montages()), "
            f"got {montage!r}"
        )
    return montage


def grid_size(n_positions: int = DEFAULT_POSITIONS, seed: int | None = None) -> int:
    """The number of positions ``make_head_model(n_positions, seed=seed)`` holds, cheaply.

    The lattice count nearest to the request (see the module docstring); no forward model
    is computed.

    Parameters
    ----------
    n_positions : int
        Requested number of grid positions.
    seed : int or None
        The grid's offset seed (:func:`make_head_model`).

    Returns
    -------
    int
        The number of positions of that grid.

    Examples
    --------
    >>> grid_size(3000)
    3016
    """
    count = check_int("n_positions", n_positions, minimum=MIN_POSITIONS)
    return len(_grid_cells(count, _offset(seed))[0])


def required_memory(n_positions: int = DEFAULT_POSITIONS, montage: str = "biosemi64") -> int:
    """Bytes that building ``make_head_model(n_positions, montage)`` needs, about.

    MNE's forward computation peaked at 10-15 times the size of the lead field it returns
    (3000 and 12 000 positions, biosemi64, measured with the peak resident size); this
    allows 16 times.

    Parameters
    ----------
    n_positions : int
        Requested number of grid positions.
    montage : str
        Name of an MNE built-in montage.

    Returns
    -------
    int
        Bytes.

    Examples
    --------
    >>> required_memory(3000) / 2**20  # MiB
    70.3...
    """
    n_channels = len(sensors(check_montage(montage))[0]["ch_names"])
    count = check_int("n_positions", n_positions, minimum=MIN_POSITIONS)
    return 16 * 8 * n_channels * 3 * count  # the grid holds n_positions within ~1 %


def check_size(
    n_positions: int, montage: str = "biosemi64", *, extra: int = 0, name: str = "n_positions"
) -> None:
    """Refuse, before any work, a head model (plus ``extra`` bytes) that does not fit.

    Parameters
    ----------
    n_positions : int
        Requested number of grid positions.
    montage : str
        Name of an MNE built-in montage.
    extra : int
        Bytes needed besides the head model's.
    name : str
        What to name in the error: a parameter or a command-line flag.

    Raises
    ------
    MemoryError
        If the memory available does not hold it.
    """
    from ..._utils import memory

    memory.require(required_memory(n_positions, montage) + extra, f"{name} {n_positions}")


def _offset(seed: int | None) -> NDArray[np.float64]:
    """The grid's offset within a cell: the centre, or drawn from the seed."""
    if seed is None:
        return np.full(3, 0.5)
    return np.random.default_rng(check_int("seed", seed, minimum=0)).random(3)


@functools.cache
def _builtin_montages():
    import mne

    return frozenset(mne.channels.get_builtin_montages())


def _grid_cells(
    n_positions: int, offset: NDArray[np.float64]
) -> tuple[NDArray[np.float64], float]:
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


def template_mni_to_head() -> NDArray[np.float64]:
    """Affine (4 x 4, m -> m) from MNI coordinates to the template's head frame.

    MNE's fsaverage fiducials (``mne/data/fsaverage/fsaverage-fiducials.fif``, in fsaverage's
    MRI coordinates, which are MNI coordinates) define the head frame as MNE does for any
    subject (:func:`mne.transforms.get_ras_to_neuromag_trans`).

    Returns
    -------
    ndarray, shape (4, 4)
        The affine: head = A[:3, :3] @ mni + A[:3, 3], both in metres.

    Examples
    --------
    >>> np.round(template_mni_to_head()[:3, 3] * 1e3)  # MNI origin in the head frame (mm)
    array([-2., 31., 40.])
    """
    return _template_mni_to_head().copy()


@functools.cache
def _template_mni_to_head():
    from pathlib import Path

    import mne

    path = Path(mne.__file__).parent / "data" / "fsaverage" / "fsaverage-fiducials.fif"
    points, _ = mne.io.read_fiducials(path, verbose=False)
    by_kind = {int(p["ident"]): np.asarray(p["r"], dtype=float) for p in points}
    lpa, nasion, rpa = (by_kind[k] for k in (1, 2, 3))  # FIFFV_POINT_LPA, NASION, RPA
    return mne.transforms.get_ras_to_neuromag_trans(nasion, lpa, rpa)


def _anatomy(sphere):
    centre = np.asarray(sphere["r0"], dtype=float)
    return Anatomy(
        mni_to_head=readonly(template_mni_to_head()),
        mni_source="template: MNE's fsaverage fiducials (fsaverage MRI = MNI coordinates)",
        grid_transform=readonly(np.eye(4)),
        grid_frame="head",
        labels={},
        label_voxel_mm=float("nan"),
        boundary=None,
        centre=readonly(centre),
        radius=float(min(layer["rad"] for layer in sphere["layers"])),
    )


def _sphere_head(positions, info, sphere, montage, seed, spacing, source_space):
    import mne

    normals = np.tile([0.0, 0.0, 1.0], (len(positions), 1))
    src = mne.setup_volume_source_space(
        pos=dict(rr=positions, nn=normals), sphere=sphere, mindist=0.0, verbose=False
    )
    if src[0]["nuse"] != len(positions):
        raise RuntimeError("a grid position fell outside the sphere's brain compartment")
    fwd = mne.make_forward_solution(
        info, trans=None, src=src, bem=sphere, eeg=True, meg=False, verbose=False
    )
    fwd, leadfield = finish_forward(fwd, len(info.ch_names))
    return HeadModel(
        leadfield=leadfield,
        positions=readonly(np.array(fwd["source_rr"], dtype=float)),
        info=info,
        conductor=sphere,
        src=src,
        fwd=fwd,
        montage=montage,
        seed=seed,
        spacing=float(spacing),
        conductor_kind="sphere",
        source_space=source_space,
        anatomy=_anatomy(sphere),
    )


@functools.lru_cache(maxsize=8)
def _build_head(n_positions, montage, seed):
    info, sphere = sensors(montage)
    origin = np.asarray(sphere["r0"], dtype=float)
    brain_radius = min(layer["rad"] for layer in sphere["layers"])
    ball = brain_radius - MINDIST_MM * 1e-3
    cells, radius = _grid_cells(n_positions, _offset(seed))
    spacing = ball / radius
    positions = origin + spacing * cells
    return _sphere_head(positions, info, sphere, montage, seed, spacing, "volume")


def anatomical_positions(
    sphere: mne.bem.ConductorModel, floor: float, spacing_mm: float = SPHERE_ANATOMICAL_SPACING_MM
) -> NDArray[np.float64]:
    """The sphere's cortex + thalamus positions (m, head coordinates), cortex first.

    Parameters
    ----------
    sphere : mne.bem.ConductorModel
        MNE's sphere model.
    floor : float
        Height (m, head coordinates) below which the cortex has no positions.
    spacing_mm : float
        The lattice's spacing.

    Returns
    -------
    positions : ndarray, shape (n, 3)
        The cortex's positions, then the thalami's.
    """
    origin = np.asarray(sphere["r0"], dtype=float)
    brain = min(layer["rad"] for layer in sphere["layers"])
    spacing = spacing_mm * 1e-3
    extent = int(np.ceil(brain / spacing)) + 1
    k = np.arange(-extent, extent) + 0.5
    cells = np.stack(np.meshgrid(k, k, k, indexing="ij"), axis=-1).reshape(-1, 3)
    points = origin + spacing * cells
    depth = brain - np.linalg.norm(points - origin, axis=1)
    shallow, deep = (d * 1e-3 for d in SHELL_DEPTH_MM)
    cortex = (depth >= shallow - 1e-12) & (depth <= deep + 1e-12) & (points[:, 2] >= floor)
    centres = apply_affine(template_mni_to_head(), np.array(THALAMUS_MNI_MM) * 1e-3)
    distance = np.linalg.norm(points[:, None] - centres[None], axis=2).min(axis=1)
    thalamus = (distance <= THALAMUS_RADIUS_MM * 1e-3) & ~cortex
    return np.concatenate([points[cortex], points[thalamus]])


@functools.lru_cache(maxsize=4)
def _build_anatomical(montage, spacing_mm):
    info, sphere = sensors(montage)
    floor = 0.0  # the plane of the fiducials: z = 0 in head coordinates
    positions = anatomical_positions(sphere, floor, spacing_mm)
    return _sphere_head(positions, info, sphere, montage, None, spacing_mm * 1e-3, "anatomical")
