"""Sources drawn over a head's structures: exact dipoles near grid positions, never on them.

The resolution study (what a method does with one source anywhere in cortex or thalamus)
needs many sources whose fields no method has in its lead field: a source on a grid position
would hand sLORETA and the SKF their own columns (an "inverse crime"). Each source here is a
point drawn uniformly in the grid cell of a position (the cube of the grid's spacing centred on
it), inside the position's own anatomical label, with three orthonormal orientations (the
axes of a uniformly random rotation, not the head's axes), and its field is MNE's forward
solution at that point (:func:`exact_gains`), average referenced.

- :func:`position_structures`: ``"thalamus"`` or ``"cortex"`` for every position of a cortex +
  thalamus head, and the label (side) of each;
- :func:`draw_sources`: :class:`Sources` near the given positions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils.checks import InputError, check_int
from ._head._model import apply_affine

if TYPE_CHECKING:
    from ._head import HeadModel

__all__ = [
    "STRUCTURES",
    "Sources",
    "draw_sources",
    "exact_gains",
    "position_labels",
    "position_structures",
    "random_rotation",
]

#: The structures of a cortex + thalamus source space.
STRUCTURES = ("cortex", "thalamus")
#: Draws of a point in its cell before the grid position itself is taken.
MAX_DRAWS = 100
#: Forward computations at most, for points MNE left out (redrawn each time).
FORWARD_ROUNDS = 10
_SIDES = ("Left", "Right")


def position_labels(head: HeadModel) -> NDArray[np.str_]:
    """The anatomical label of every position of a cortex + thalamus head.

    Parameters
    ----------
    head : HeadModel
        ``source_space="anatomical"``: the BEM head's labels are its source spaces' (aseg
        names); the sphere's are its two thalamic balls and the cortex on either side of the
        midline (x of the sphere's centre).

    Returns
    -------
    labels : ndarray of str, shape (n_positions,)
        ``"Left-Thalamus"``, ``"Right-Cerebral-Cortex"``, ...

    Examples
    --------
    >>> from skf_ref.study._head import make_head
    >>> labels = position_labels(make_head("sphere", "anatomical"))
    >>> sorted(str(label) for label in set(labels))
    ['Left-Cerebral-Cortex', 'Left-Thalamus', 'Right-Cerebral-Cortex', 'Right-Thalamus']
    """
    if head.source_space != "anatomical":
        raise InputError(
            f"head must have the cortex + thalamus source space (source_space='anatomical'), "
            f"got {head.source_space!r}"
        )
    src = head.fwd["src"] if head.fwd is not None else []
    names = [s.get("seg_name") for s in src]
    if src and all(names):
        return np.concatenate(
            [np.full(s["nuse"], name) for s, name in zip(src, names, strict=True)]
        )
    return _sphere_labels(head)


def _sphere_labels(head):
    from ._head import THALAMUS_MNI_MM, THALAMUS_RADIUS_MM, template_mni_to_head

    centres = apply_affine(template_mni_to_head(), np.array(THALAMUS_MNI_MM) * 1e-3)
    distance = np.linalg.norm(head.positions[:, None] - centres[None], axis=2)
    thalamus = distance.min(axis=1) <= THALAMUS_RADIUS_MM * 1e-3 + 1e-9
    left = head.positions[:, 0] < head.origin[0]
    side = np.where(left, _SIDES[0], _SIDES[1])
    nearest = np.where(distance.argmin(axis=1) == 0, _SIDES[0], _SIDES[1])
    return np.where(
        thalamus, np.char.add(nearest, "-Thalamus"), np.char.add(side, "-Cerebral-Cortex")
    )


def position_structures(head: HeadModel) -> NDArray[np.str_]:
    """``"thalamus"`` or ``"cortex"`` for every position of a cortex + thalamus head.

    Parameters
    ----------
    head : HeadModel
        ``source_space="anatomical"`` (:func:`position_labels`).

    Returns
    -------
    ndarray of str, shape (n_positions,)
        Each position's structure, from its label.
    """
    labels = position_labels(head)
    return np.where(np.char.endswith(labels, "Thalamus"), STRUCTURES[1], STRUCTURES[0])


def random_rotation(rng: np.random.Generator) -> NDArray[np.float64]:
    """A uniformly random 3 x 3 rotation: its rows are three orthonormal orientations.

    QR of a standard normal matrix with the signs fixed so that R has a positive diagonal
    (Haar measure on the orthogonal group), and one row flipped if needed so the
    determinant is +1.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator drawn from (nine standard normal numbers).

    Returns
    -------
    ndarray, shape (3, 3)
        A rotation matrix (orthonormal rows, determinant +1).

    Examples
    --------
    >>> Q = random_rotation(np.random.default_rng(0))
    >>> bool(np.allclose(Q @ Q.T, np.eye(3))), round(float(np.linalg.det(Q)), 12)
    (True, 1.0)
    """
    Q, R = np.linalg.qr(rng.standard_normal((3, 3)))
    Q = Q * np.sign(np.diag(R))
    if np.linalg.det(Q) < 0:
        Q[:, 0] = -Q[:, 0]
    return Q.T


@dataclass(frozen=True, eq=False)
class Sources:
    """Exact dipoles drawn near grid positions (n = positions x orientations).

    Made by :func:`draw_sources`; each parameter is an attribute of the same name.

    Parameters
    ----------
    position : ndarray of int, shape (n,)
        The grid position each source was drawn near (its cell).
    points : ndarray, shape (n, 3)
        Exact positions, head coordinates, m (the sources of a position share one point).
    orientations : ndarray, shape (n, 3)
        Unit orientations (a position's are orthonormal).
    structure : ndarray of str, shape (n,)
        ``"thalamus"`` or ``"cortex"``.
    gain : ndarray, shape (n_channels, n)
        Average-referenced forward field of each source at unit moment (V / (A m)).
    on_grid : ndarray of bool, shape (n,)
        Where no point of the cell could be used and the grid position itself was.
    """

    position: np.ndarray = field(repr=False)
    points: np.ndarray = field(repr=False)
    orientations: np.ndarray = field(repr=False)
    structure: np.ndarray = field(repr=False)
    gain: np.ndarray = field(repr=False)
    on_grid: np.ndarray = field(repr=False)

    def __len__(self):
        return len(self.position)

    def take(self, index: ArrayLike) -> Sources:
        """The sources at ``index``, as :class:`Sources`.

        Parameters
        ----------
        index : array_like of int or bool, shape (k,) or (n,)
            Indices, or a boolean mask over the sources.

        Returns
        -------
        Sources
            Those sources, read-only.
        """
        at = np.asarray(index)
        parts = {name: np.asarray(getattr(self, name))[at] for name in _FIELDS[:4]}
        parts["gain"] = self.gain[:, at]
        parts["on_grid"] = self.on_grid[at]
        return Sources(**{name: readonly(value) for name, value in parts.items()})


_FIELDS = ("position", "points", "orientations", "structure", "gain", "on_grid")


def readonly(value):
    """A read-only copy of an array of any type."""
    array = np.array(value)
    array.flags.writeable = False
    return array


def exact_gains(
    head: HeadModel, points: ArrayLike, orientations: ArrayLike | None = None
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """MNE's forward field of dipoles at arbitrary points, and which points it kept.

    Parameters
    ----------
    head : HeadModel
        A head with MNE's forward model (its BEM or sphere, sensors and transforms).
    points : ndarray, shape (n, 3)
        Head coordinates, m.
    orientations : ndarray, shape (n, 3), optional
        Unit orientations; None: the free-orientation field.

    Returns
    -------
    gain : ndarray, shape (n_channels, n) or (n_channels, n, 3)
        Average referenced, float64; zero columns where the point was not kept.
    kept : ndarray of bool, shape (n,)
        False where MNE left the point out (outside the inner skull by its test).
    """
    import mne

    points = np.asarray(points, dtype=float)
    n = len(points)
    trans = head.anatomy.trans if head.anatomy is not None else None
    rr = points if trans is None else apply_affine(trans["trans"], points)  # head -> MRI
    kind = "sphere" if head.conductor_kind == "sphere" else "bem"
    kwargs = {kind: head.conductor}
    src = mne.setup_volume_source_space(
        pos=dict(rr=rr, nn=np.tile([0.0, 0.0, 1.0], (n, 1))), mindist=0.0, verbose=False, **kwargs
    )
    free = np.zeros((head.n_channels, n, 3))
    kept = np.zeros(n, dtype=bool)
    if src[0]["nuse"]:
        try:
            fwd = mne.make_forward_solution(
                head.info, trans=trans, src=src, bem=head.conductor, eeg=True, meg=False,
                verbose=False,
            )  # fmt: skip
        except RuntimeError as err:  # MNE refuses a source space it left no point of
            if "No points left" not in str(err):
                raise
            return _oriented(free, orientations), kept
        fwd = mne.convert_forward_solution(fwd, surf_ori=False, force_fixed=False, verbose=False)
        kept = fwd["src"][0]["inuse"].astype(bool)
        free[:, kept] = np.asarray(fwd["sol"]["data"], dtype=float).reshape(head.n_channels, -1, 3)
    return _oriented(free - free.mean(axis=0, keepdims=True), orientations), kept


def _oriented(free, orientations):
    if orientations is None:
        return free
    return np.einsum("cnk,nk->cn", free, np.asarray(orientations, dtype=float))


def _label_keys(head):
    """Per label, the integer voxel keys of its voxels in the grid frame (None: no labels)."""
    anatomy = head.anatomy
    if not anatomy.labels:
        return None
    voxel = anatomy.label_voxel_mm * 1e-3
    return {
        name: np.unique(_keys(apply_affine(anatomy.grid_transform, voxels), voxel))
        for name, voxels in anatomy.labels.items()
    }


def _keys(points, voxel):
    index = np.round(points / voxel).astype(np.int64) + 2**20
    return (index[:, 0] << 42) | (index[:, 1] << 21) | index[:, 2]


def _in_labels(head, keys, points, labels):
    """Whether each point (head coordinates) lies in a voxel of its label."""
    if keys is None:
        return np.ones(len(points), dtype=bool)
    voxel = head.anatomy.label_voxel_mm * 1e-3
    point_keys = _keys(apply_affine(head.anatomy.grid_transform, points), voxel)
    inside = np.zeros(len(points), dtype=bool)
    for name in np.unique(labels):
        mine = labels == name
        inside[mine] = np.isin(point_keys[mine], keys[name])
    return inside


def _cell_points(head, positions, rng):
    """A point drawn uniformly in each position's grid cell (axis-aligned in the grid frame)."""
    rotation = np.asarray(head.anatomy.grid_transform)[:3, :3]
    offsets = rng.uniform(-0.5, 0.5, (len(positions), 3)) * head.spacing
    return head.positions[positions] + offsets @ rotation


def _points_in_cells(head, positions, labels, rng):
    """Points in the cells and labels of ``positions`` (NaN where MAX_DRAWS draws missed)."""
    keys = _label_keys(head)
    points = np.full((len(positions), 3), np.nan)
    for _ in range(MAX_DRAWS):
        todo = np.flatnonzero(np.isnan(points[:, 0]))
        if not todo.size:
            break
        candidates = _cell_points(head, positions[todo], rng)
        inside = _in_labels(head, keys, candidates, labels[todo])
        points[todo[inside]] = candidates[inside]
    return points


def draw_sources(
    head: HeadModel, positions: ArrayLike, seed: int, n_orientations: int = 3
) -> Sources:
    """Exact dipoles in the cells of grid positions, with random orthonormal orientations.

    For each position (in the order given): a uniformly random rotation (its first
    ``n_orientations`` rows are the sources' orientations), then a point drawn uniformly in
    the position's grid cell, redrawn until it lies in the position's label (where the head
    has label voxels), at most ``MAX_DRAWS`` times, and again while MNE's forward leaves
    it out (``FORWARD_ROUNDS`` forward computations at most); the grid position itself
    where that fails (``on_grid``).

    Parameters
    ----------
    head : HeadModel
        A cortex + thalamus head.
    positions : array_like of int, shape (n_positions,)
        Grid positions, distinct.
    seed : int
        Seed of ``numpy.random.default_rng``.
    n_orientations : int
        Sources per position, 1 to 3.

    Returns
    -------
    Sources
        ``n_positions * n_orientations`` sources, position-major.
    """
    positions = np.asarray(positions, dtype=int)
    if positions.ndim != 1 or len(np.unique(positions)) != len(positions):
        raise InputError("positions must be distinct grid position indices (a 1-d array)")
    if positions.size and (positions.min() < 0 or positions.max() >= head.n_positions):
        raise InputError(f"positions must lie in [0, {head.n_positions}), got {positions!r}")
    n_orientations = check_int("n_orientations", n_orientations, minimum=1, maximum=3)
    rng = np.random.default_rng(seed)
    rotations = np.array([random_rotation(rng) for _ in positions]).reshape(-1, 3, 3)
    labels = position_labels(head)[positions]
    points = _points_in_cells(head, positions, labels, rng)
    free = np.zeros((head.n_channels, len(positions), 3))
    for _ in range(FORWARD_ROUNDS):
        todo = np.flatnonzero(~np.isnan(points[:, 0]) & ~free.any(axis=(0, 2)))
        if not todo.size:
            break
        gains, kept = exact_gains(head, points[todo])
        free[:, todo[kept]] = gains[:, kept]
        retry = todo[~kept]
        points[retry] = _points_in_cells(head, positions[retry], labels[retry], rng)
    on_grid = np.asarray(~free.any(axis=(0, 2)), dtype=bool)
    points[on_grid] = head.positions[positions[on_grid]]
    if on_grid.any():
        free[:, on_grid] = exact_gains(head, points[on_grid])[0][:, :]
    orientations = rotations[:, :n_orientations].reshape(-1, 3)
    repeat = np.repeat(np.arange(len(positions)), n_orientations)
    gain = np.einsum("cnk,nk->cn", free[:, repeat], orientations)
    structures = position_structures(head)[positions]
    return Sources(
        position=readonly(positions[repeat]),
        points=readonly(points[repeat]),
        orientations=readonly(orientations),
        structure=readonly(structures[repeat]),
        gain=readonly(gain),
        on_grid=readonly(on_grid[repeat]),
    )
