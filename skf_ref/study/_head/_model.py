"""The head model type, shared by every conductor and source space.

A :class:`HeadModel` holds a free-orientation, average-referenced EEG lead field on a set of
source positions, the MNE objects that produced it, and an :class:`Anatomy`: how MNI
coordinates map into the head, which anatomical labels exist (if any) and where the brain
compartment's boundary lies. Coordinates are MNE's head coordinates in metres throughout
(x towards the right preauricular point, y towards the nasion, z up).
"""

from __future__ import annotations

import functools
import weakref
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..._utils.checks import InputError, check_array
from ..._utils.extras import require
from ...method._result import readonly

if TYPE_CHECKING:
    import mne

require(("mne", "nibabel", "filelock"), "study", "skf_ref's head models")

__all__ = ["CONDUCTORS", "SOURCE_SPACES", "Anatomy", "HeadModel", "apply_affine", "sensors"]

#: Conductor models: MNE's multi-shell sphere, or a three-layer boundary-element model.
CONDUCTORS = ("sphere", "bem")
#: Source spaces: a regular grid filling the brain compartment, or cortex and thalamus.
SOURCE_SPACES = ("volume", "anatomical")
_SFREQ_IRRELEVANT = 10000.0


def apply_affine(affine: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
    """Map points by a 4 x 4 affine (the same length unit in and out).

    Parameters
    ----------
    affine : array_like, shape (4, 4)
        The affine transform.
    points : array_like, shape (n, 3)
        The points.

    Returns
    -------
    ndarray, shape (n, 3)
        The mapped points.
    """
    xyz = np.asarray(points, dtype=float)
    matrix = np.asarray(affine, dtype=float)
    return xyz @ matrix[:3, :3].T + matrix[:3, 3]


@dataclass(frozen=True, eq=False)
class Anatomy:
    """Where MNI coordinates and anatomical labels lie in a head (head coordinates, m).

    Each parameter is an attribute of the same name.

    Parameters
    ----------
    mni_to_head : ndarray, shape (4, 4)
        Affine from MNI coordinates (m) to head coordinates (m).
    mni_source : str
        How ``mni_to_head`` was obtained (for reports).
    grid_transform : ndarray, shape (4, 4)
        Affine from head coordinates to the frame in which the source grid is axis aligned
        (the identity when the grid is built in head coordinates).
    grid_frame : str
        Name of that frame: ``"head"`` or ``"MRI"``.
    labels : dict
        Anatomical label name -> ndarray (n_voxels, 3): centres of the label's voxels in head
        coordinates (m); empty without an anatomy.
    label_voxel_mm : float
        Edge of a label voxel in mm (NaN without labels).
    boundary : tuple or None
        Vertices (n, 3) and outward unit normals (n, 3) of the brain compartment's boundary
        (the inner skull), head coordinates; None for a sphere.
    centre : ndarray, shape (3,)
        Centre of the brain compartment's sphere (fitted to the boundary for a BEM), m.
    radius : float
        Its radius, m.
    trans : mne.transforms.Transform or None
        Head -> MRI transform of the subject (None for the sphere).
    subject : str or None
        The subject's name in MNE's subjects folder (None for the sphere).
    """

    mni_to_head: np.ndarray = field(repr=False)
    mni_source: str
    grid_transform: np.ndarray = field(repr=False)
    grid_frame: str
    labels: dict[str, np.ndarray] = field(repr=False)
    label_voxel_mm: float
    boundary: tuple[np.ndarray, np.ndarray] | None = field(repr=False)
    centre: np.ndarray = field(repr=False)
    radius: float
    trans: mne.transforms.Transform | None = field(default=None, repr=False)
    subject: str | None = None

    def place(self, mni_m: ArrayLike, label: str | None = None) -> tuple[np.ndarray, float]:
        """Head position (m) of an MNI point, moved into ``label`` if it lies outside it.

        Parameters
        ----------
        mni_m : ndarray, shape (3,)
            MNI coordinates in metres.
        label : str or None
            Anatomical label the point must lie in; ignored when the head has no labels.

        Returns
        -------
        position : ndarray, shape (3,)
            Head coordinates (m): the mapped point, or the centre of the nearest voxel of
            ``label`` when the mapped point lies in none of its voxels.
        moved_mm : float
            How far it was moved (0 when it lies in the label).
        """
        position = apply_affine(self.mni_to_head, np.asarray(mni_m, dtype=float)[None])[0]
        if label is None or not self.labels:
            return position, 0.0
        if label not in self.labels:
            raise InputError(f"label must be one of {sorted(self.labels)}, got {label!r}")
        voxels = self.labels[label]
        grid = apply_affine(self.grid_transform, voxels)  # the label's voxels are axis aligned
        here = apply_affine(self.grid_transform, position[None])[0]
        half = 0.5 * self.label_voxel_mm * 1e-3
        if (np.abs(grid - here) <= half + 1e-9).all(axis=1).any():
            return position, 0.0
        nearest = voxels[np.argmin(np.linalg.norm(voxels - position, axis=1))]
        return nearest, float(np.linalg.norm(nearest - position) * 1e3)

    def radial(self, position: ArrayLike) -> np.ndarray:
        """Outward unit normal of the brain compartment's boundary nearest ``position``.

        For a sphere the direction from its centre; for a BEM the normal of the inner skull
        at its vertex nearest the position.

        Parameters
        ----------
        position : array_like, shape (3,)
            Head coordinates (m).

        Returns
        -------
        ndarray, shape (3,)
            The unit normal.
        """
        point = np.asarray(position, dtype=float)
        if self.boundary is None:
            radial = point - self.centre
            if np.linalg.norm(radial) < 1e-9:
                raise InputError("the position sits at the sphere centre: no radial direction")
            return radial / np.linalg.norm(radial)
        vertices, normals = self.boundary
        return normals[np.argmin(np.linalg.norm(vertices - point, axis=1))]


@dataclass(frozen=True, eq=False)
class HeadModel:
    """An EEG head model: lead field, source positions, conductor and anatomy.

    Made by :func:`skf_ref.study._head.make_head`; each parameter is an attribute of the same
    name.

    Parameters
    ----------
    leadfield : ndarray, shape (n_channels, 3 * n_positions)
        Free-orientation lead field in V/(A·m), average referenced (every column has zero
        channel mean); columns are MNE's x, y, z of position 0, then position 1, ...
    positions : ndarray, shape (n_positions, 3)
        Source positions in metres, head coordinates.
    info : mne.Info
        EEG channels with their positions and an (inactive) average-reference projection.
    conductor : mne.bem.ConductorModel
        MNE's sphere model or BEM solution the lead field was computed with.
    src : mne.SourceSpaces or None
        MNE source space(s) holding ``positions``.
    fwd : mne.Forward or None
        MNE's free-orientation forward as computed, *not* average referenced.
    montage : str
        Name of the montage.
    seed : int or None
        Grid offset seed (sphere volume grids; None: canonical grid).
    spacing : float
        Grid spacing in metres.
    conductor_kind : str
        ``"sphere"`` or ``"bem"``.
    source_space : str
        ``"volume"`` (a grid filling the brain compartment) or ``"anatomical"`` (cortex
        and thalamus).
    anatomy : Anatomy
        MNI placement, labels and the brain compartment's boundary.
    noise_cov : ndarray, shape (n_channels, n_channels), or None
        The noise covariance of a recording made with these sensors, average referenced
        (V²), where the head has one (the sample subject's own electrodes); else None.
    """

    leadfield: np.ndarray = field(repr=False)
    positions: np.ndarray = field(repr=False)
    info: mne.Info = field(repr=False)
    conductor: mne.bem.ConductorModel = field(repr=False)
    src: mne.SourceSpaces | None = field(repr=False)
    fwd: mne.Forward | None = field(repr=False)
    montage: str = "biosemi64"
    seed: int | None = None
    spacing: float = float("nan")
    conductor_kind: str = "sphere"
    source_space: str = "volume"
    anatomy: Anatomy | None = field(default=None, repr=False)
    noise_cov: np.ndarray | None = field(default=None, repr=False)

    @property
    def n_positions(self) -> int:
        """Number of source positions."""
        return self.positions.shape[0]

    @property
    def n_channels(self) -> int:
        """Number of EEG channels."""
        return self.leadfield.shape[0]

    @property
    def sphere(self) -> mne.bem.ConductorModel | None:
        """The sphere model (``mne.bem.ConductorModel``; None for a BEM head)."""
        return self.conductor if self.conductor_kind == "sphere" else None

    @property
    def origin(self) -> np.ndarray:
        """Centre of the brain compartment's sphere, shape (3,), m (fitted for a BEM)."""
        if self.anatomy is not None:
            return np.array(self.anatomy.centre, dtype=float)
        return np.array(self.conductor["r0"], dtype=float)

    @property
    def brain_radius(self) -> float:
        """Radius (m) of the brain compartment's sphere (fitted for a BEM)."""
        if self.anatomy is not None:
            return float(self.anatomy.radius)
        return float(min(layer["rad"] for layer in self.conductor["layers"]))

    @property
    def description(self) -> str:
        """One line naming the conductor and the source space."""
        if self.conductor_kind == "sphere":
            conductor = f"{len(self.conductor['layers'])}-shell sphere"
        else:
            conductor = "three-layer BEM of MNE's 'sample' subject"
        space = {"volume": "volume grid", "anatomical": "cortex + thalamus"}[self.source_space]
        return f"{conductor}, {space} ({self.n_positions} positions, {self.montage})"

    def radial(self, position: ArrayLike) -> np.ndarray:
        """Outward unit normal of the brain compartment nearest ``position``.

        Parameters
        ----------
        position : array_like, shape (3,)
            Head coordinates (m).

        Returns
        -------
        ndarray, shape (3,)
            The unit normal (:meth:`Anatomy.radial`).
        """
        if self.anatomy is None:
            raise InputError("the head has no anatomy: no brain compartment to be radial to")
        return self.anatomy.radial(position)

    def dipole_gain(self, positions: ArrayLike, orientations: ArrayLike) -> np.ndarray:
        """Average-referenced gain of fixed dipoles at arbitrary positions, (n_channels, n).

        MNE's forward computation with this head's conductor and sensors, in float64, at the
        given positions (not grid positions), projected on the orientations. Computed once
        per head and set of dipoles (cached while the head lives).

        Parameters
        ----------
        positions : ndarray, shape (n, 3)
            Head coordinates in metres, inside the brain compartment.
        orientations : ndarray, shape (n, 3)
            Unit orientations.

        Returns
        -------
        gain : ndarray, shape (n_channels, n)
            Read-only; its columns have zero channel mean.
        """
        points = check_array("positions", positions, ("n", 3))
        directions = check_array("orientations", orientations, (points.shape[0], 3))
        key = (points.tobytes(), directions.tobytes())
        cache = _GAINS.setdefault(self, {})
        if key not in cache:
            cache[key] = readonly(_dipole_gain(self, points, directions))
        return cache[key]


_GAINS: weakref.WeakKeyDictionary[HeadModel, dict[tuple[bytes, bytes], np.ndarray]] = (
    weakref.WeakKeyDictionary()
)


def _dipole_gain(head: HeadModel, positions: np.ndarray, orientations: np.ndarray) -> np.ndarray:
    import mne

    n = len(positions)
    trans = head.anatomy.trans if head.anatomy is not None else None
    rr = positions if trans is None else apply_affine(trans["trans"], positions)  # -> MRI
    kwargs = {"sphere": head.conductor} if head.conductor_kind == "sphere" else {}
    if head.conductor_kind == "bem":
        kwargs["bem"] = head.conductor
    src = mne.setup_volume_source_space(
        pos=dict(rr=rr, nn=np.tile([0.0, 0.0, 1.0], (n, 1))), mindist=0.0, verbose=False, **kwargs
    )
    if src[0]["nuse"] != n:
        raise InputError("scenario: a source lies outside the brain compartment")
    fwd = mne.make_forward_solution(
        head.info, trans=trans, src=src, bem=head.conductor, eeg=True, meg=False, verbose=False
    )
    fwd = mne.convert_forward_solution(fwd, surf_ori=False, force_fixed=False, verbose=False)
    free = np.asarray(fwd["sol"]["data"], dtype=float).reshape(head.n_channels, n, 3)
    gain = np.einsum("cnk,nk->cn", free, orientations)
    if not np.isfinite(gain).all():
        raise InputError("the sources' forward field is not finite (a source at the centre?)")
    return gain - gain.mean(axis=0, keepdims=True)


@functools.lru_cache(maxsize=8)
def sensors(montage: str) -> tuple[mne.Info, mne.bem.ConductorModel]:
    """Info (with average-reference projection) and fitted sphere for a built-in montage.

    Parameters
    ----------
    montage : str
        An MNE built-in montage (``mne.channels.make_standard_montage``).

    Returns
    -------
    info : mne.Info
        Its EEG channels, with an (inactive) average-reference projection.
    sphere : mne.bem.ConductorModel
        MNE's sphere model fitted to the electrodes.
    """
    import mne

    digmontage = mne.channels.make_standard_montage(montage)
    info = mne.create_info(digmontage.ch_names, _SFREQ_IRRELEVANT, "eeg")
    info.set_montage(digmontage, verbose=False)
    info = with_average_reference(info)
    sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    return info, sphere


def with_average_reference(info: mne.Info) -> mne.Info:
    """Add an (inactive) average-reference projection to a measurement info.

    Parameters
    ----------
    info : mne.Info
        EEG channels.

    Returns
    -------
    mne.Info
        A copy of ``info`` with the projection.
    """
    import mne

    raw = mne.io.RawArray(np.zeros((len(info.ch_names), 1)), info, verbose=False)
    raw.set_eeg_reference("average", projection=True, verbose=False)
    return raw.info


def finish_forward(fwd: mne.Forward, n_channels: int) -> tuple[mne.Forward, np.ndarray]:
    """The free-orientation gain of an MNE forward, checked, and its average reference.

    Parameters
    ----------
    fwd : mne.Forward
        As MNE computed it.
    n_channels : int
        The EEG channels it must have.

    Returns
    -------
    fwd : mne.Forward
        In free orientation, x, y, z per position.
    gain : ndarray, shape (n_channels, 3 * n_positions)
        Its gain, average referenced, read-only.
    """
    import mne

    fwd = mne.convert_forward_solution(fwd, surf_ori=False, force_fixed=False, verbose=False)
    gain = fwd["sol"]["data"]
    n_positions = int(fwd["nsource"])
    if gain.shape != (n_channels, 3 * n_positions) or not np.isfinite(gain).all():
        raise RuntimeError("MNE returned an unexpected or non-finite forward solution")
    return fwd, readonly(gain - gain.mean(axis=0, keepdims=True))
