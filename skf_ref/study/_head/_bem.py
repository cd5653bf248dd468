"""The realistic head: MNE's "sample" subject, a three-layer BEM and two source spaces.

Built with MNE-Python from MNE's testing dataset (:func:`skf_ref.study._head.find_testing_data`;
never downloaded):

- **Conductor**: the linear-collocation BEM solution (:func:`mne.make_bem_solution`) of the
  subject's three surfaces in ``sample-1280-1280-1280-bem.fif`` (inner skull, outer skull,
  scalp; 1280 triangles each) with the conductivities stored there, 0.3, 0.006 and 0.3 S/m.
  OpenMEEG's solver was checked and not adopted: its lead field differs by 9 % (median
  column), which left the reproduction's verdicts as they are but for one marginal criterion
  (``validation/archive/report-v2/REPORT.md``).
- **Sources**: ``"anatomical"``, MNE's volume source space restricted to the cortex and
  thalamus labels of the subject's ``aseg.mgz`` (:data:`LABELS`) on a 5 mm grid, 5 mm inside
  the inner skull (:func:`mne.setup_volume_source_space`); or ``"volume"``, a grid filling the
  inner skull (same margin) at ``VOLUME_SPACING_MM``, about 3000 positions like the
  sphere's volume grid. Both grids are axis aligned in the subject's MRI coordinates.
- **Sensors**: the montage's channels at their MNI positions in MNE's 10-05 template (the
  Colin27 positions MNE ships), mapped into the subject by :func:`subject_mni_to_head` and
  moved to the nearest point of the scalp surface; or, with the montage
  ``SUBJECT_MONTAGE`` (``"sample"``), the subject's own electrodes as digitized on its
  head, with the noise covariance of its recording (``subject_electrodes``).
- **MNI coordinates**: :func:`subject_mni_to_head`, the inverse of the affine
  :func:`mne.head_to_mni` applies (the subject's ``talairach.xfm``, its MRI geometry and
  the head <-> MRI transform ``sample_audvis_trunc-trans.fif``).

The BEM solution and each forward solution are cached on disk (:func:`cache_dir`), keyed by
the digest of their inputs, so a study computes them once.
"""

from __future__ import annotations

import contextlib
import functools
import os
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..._utils.atomic_files import atomic_path
from ..._utils.checks import InputError, check_choice, check_instance, check_real
from ...method._result import readonly
from ._data import SENSOR_FILES, SUBJECT, TESTING_FILES, cache_dir, find_testing_data, input_digest
from ._model import Anatomy, HeadModel, apply_affine, finish_forward, with_average_reference
from ._sphere import ANATOMICAL_SPACING_MM, MINDIST_MM, check_montage

if TYPE_CHECKING:
    import mne

__all__ = [
    "CACHE_FORMAT",
    "LABELS",
    "SUBJECT_MONTAGE",
    "VOLUME_SPACING_MM",
    "make_realistic_head",
    "subject_electrodes",
    "subject_mni_to_head",
]

#: aseg labels of the anatomical source space: name -> FreeSurfer id (the thalamus is 10/49,
#: named "Left-/Right-Thalamus-Proper" in older lookup tables; id 9/48 is unused in aseg).
LABELS = {
    "Left-Cerebral-Cortex": 3,
    "Right-Cerebral-Cortex": 42,
    "Left-Thalamus": 10,
    "Right-Thalamus": 49,
}
#: Spacing (mm) of the volume grid filling the inner skull: 2959 positions.
VOLUME_SPACING_MM = 7.8
#: The montage name of the subject's own electrodes, with its recording's noise covariance.
SUBJECT_MONTAGE = "sample"
#: Bumped when what the cache holds changes meaning.
CACHE_FORMAT = 1
_SCALP_ID = 4  # FIFFV_BEM_SURF_ID_HEAD
_INNER_SKULL_ID = 1  # FIFFV_BEM_SURF_ID_BRAIN
_TEMPLATES = ("colin27_1005", "standard_1005")  # MNI 10-05 positions; the first MNE has


def make_realistic_head(
    testing_data: str | os.PathLike | None = None,
    source_space: str = "anatomical",
    montage: str = "biosemi64",
    cache_dir: str | os.PathLike | None = None,
    spacing_mm: float | None = None,
) -> HeadModel:
    """The sample subject's BEM head with either source space (see the module docstring).

    Parameters
    ----------
    testing_data : path-like or None
        Root of MNE's testing dataset; None: MNE's own lookup, without downloading.
    source_space : {"anatomical", "volume"}
        Cortex + thalamus, or a grid filling the inner skull.
    montage : str
        A built-in montage whose channel names are 10-05 names (e.g. ``"biosemi64"``), or
        ``SUBJECT_MONTAGE`` (``"sample"``): the subject's own electrodes, with the noise
        covariance of its recording as ``head.noise_cov`` (``subject_electrodes``).
    cache_dir : path-like or None
        Where the forward models are cached (:func:`skf_ref.study._head.cache_dir`).
    spacing_mm : float or None
        The source grid's spacing; None: ``ANATOMICAL_SPACING_MM`` (cortex + thalamus)
        or ``VOLUME_SPACING_MM`` (the grid filling the inner skull).

    Returns
    -------
    head : HeadModel
        Read-only arrays shared between calls with equal arguments in a process.

    Raises
    ------
    skf_ref.InputError
        The dataset is not found (say where it is with ``testing_data``), lacks the
        recording the ``"sample"`` montage needs, or a channel has no 10-05 position.
    """
    check_choice("source_space", source_space, ("anatomical", "volume"))
    if montage != SUBJECT_MONTAGE:
        check_montage(montage)
    root = find_testing_data(testing_data)
    if root is None:
        raise InputError(
            "testing_data: the realistic head needs MNE's testing dataset; give its folder "
            "(the one mne.datasets.testing.data_path() returns; on the command line "
            "--mne-testing-data DIR), MNE did not find it and nothing is downloaded"
        )
    if montage == SUBJECT_MONTAGE:
        missing = [rel for rel in SENSOR_FILES.values() if not (root / rel).is_file()]
        if missing:
            raise InputError(
                f"montage={SUBJECT_MONTAGE!r} needs the subject's recording and noise "
                f"covariance from MNE's testing dataset; {str(root)!r} lacks {missing[0]}"
            )
    default = ANATOMICAL_SPACING_MM if source_space == "anatomical" else VOLUME_SPACING_MM
    spacing = check_real(
        "spacing_mm", default if spacing_mm is None else spacing_mm, minimum=1.0, maximum=20.0
    )
    return _build(str(root), source_space, montage, str(_data_cache_dir(cache_dir)), spacing)


def _data_cache_dir(path):
    return cache_dir(path).resolve()


def subject_mni_to_head(testing_data: str | os.PathLike) -> np.ndarray:
    """Affine (4 x 4, m -> m) from MNI coordinates to the sample subject's head frame.

    The inverse of :func:`mne.head_to_mni` (an affine map), evaluated on the origin and the
    three unit vectors.

    Parameters
    ----------
    testing_data : path-like
        Root of MNE's testing dataset.

    Returns
    -------
    ndarray, shape (4, 4)
        The affine: head = A[:3, :3] @ mni + A[:3, 3], both in metres.
    """
    import mne

    root = Path(testing_data)
    trans = mne.read_trans(root / TESTING_FILES["trans"], verbose=False)
    basis = np.vstack([np.zeros(3), np.eye(3)])
    mni = mne.head_to_mni(basis, SUBJECT, trans, subjects_dir=root / "subjects", verbose=False)
    linear, offset = (mni[1:] - mni[0]).T * 1e-3, mni[0] * 1e-3  # mni = linear @ head + offset
    mni_to_head = np.eye(4)
    mni_to_head[:3, :3] = np.linalg.solve(linear, np.eye(3))
    mni_to_head[:3, 3] = -mni_to_head[:3, :3] @ offset
    return mni_to_head


@contextlib.contextmanager
def _locked(path):
    from filelock import FileLock

    path.parent.mkdir(parents=True, exist_ok=True)
    with FileLock(path.with_name(f".{path.name}.lock")):
        yield


@contextlib.contextmanager
def _mne_quiet():
    """MNE warns about the hidden temporary's name: the file gets its proper name on rename."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*conform to MNE naming")
        yield


def _bem_solution(root, cache):
    import mne

    files = {"bem": root / TESTING_FILES["bem"]}
    key = input_digest(files, {"what": "bem", "mne": mne.__version__, "format": CACHE_FORMAT})
    path = cache / f"bem-{key}-sol.fif"
    with _locked(path):
        if not path.exists():
            surfaces = mne.read_bem_surfaces(files["bem"], verbose=False)
            solution = mne.make_bem_solution(surfaces, verbose=False)
            with atomic_path(path) as tmp, _mne_quiet():
                mne.write_bem_solution(tmp, solution, overwrite=True, verbose=False)
    return mne.read_bem_solution(path, verbose=False)


def _surface(bem, surface_id, head_from_mri):
    surf = next(s for s in bem["surfs"] if s["id"] == surface_id)
    rotation = head_from_mri[:3, :3]
    return apply_affine(head_from_mri, surf["rr"]), surf["nn"] @ rotation.T, surf["tris"]


def _nearest_on_mesh(points, vertices, tris, subdivisions=16):
    """Nearest points of a triangle mesh, to about its edge length / ``subdivisions``."""
    from scipy.spatial import cKDTree

    weights = [
        (i / subdivisions, j / subdivisions, 1.0 - (i + j) / subdivisions)
        for i in range(subdivisions + 1)
        for j in range(subdivisions + 1 - i)
    ]
    samples = np.einsum("wk,tkd->twd", np.array(weights), vertices[tris]).reshape(-1, 3)
    return samples[cKDTree(samples).query(points)[1]]


def _electrodes(montage, mni_to_head, scalp):
    """Info of the montage's channels placed on the subject's scalp (head coordinates)."""
    import mne

    names = mne.channels.make_standard_montage(montage).ch_names
    template = next(t for t in _TEMPLATES if t in mne.channels.get_builtin_montages())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)  # a deprecated template name
        positions = mne.channels.make_standard_montage(template).get_positions()["ch_pos"]
    lookup = {name.lower(): name for name in positions}
    missing = [name for name in names if name.lower() not in lookup]
    if missing:
        raise InputError(
            f"montage must have 10-05 channel names to be placed on the sample subject; "
            f"{montage!r} has {missing[:3]}"
        )
    mni = np.array([positions[lookup[name.lower()]] for name in names])
    on_scalp = _nearest_on_mesh(apply_affine(mni_to_head, mni), scalp[0], scalp[2])
    ch_pos = dict(zip(names, on_scalp, strict=True))
    dig = mne.channels.make_dig_montage(ch_pos=ch_pos, coord_frame="head")
    info = mne.create_info(names, 10000.0, "eeg")
    info.set_montage(dig, verbose=False)
    return with_average_reference(info)


def subject_electrodes(testing_data: str | os.PathLike) -> tuple[mne.Info, np.ndarray]:
    """The sample subject's own EEG electrodes and the noise covariance of its recording.

    The EEG channels of ``SSS/sample_audvis_trunc_raw_sss.fif`` that neither the recording
    nor the covariance ``MEG/sample/sample_audvis_trunc-cov.fif`` marks bad (the covariance
    marks EEG 053: 59 of the 60 electrodes remain), at their digitized positions (head
    coordinates); and the covariance's EEG part for them, average referenced:
    ``P C P`` with ``P = I - 1 1^T / n`` (rank ``n - 1``), in V².

    Parameters
    ----------
    testing_data : path-like
        Root of MNE's testing dataset.

    Returns
    -------
    info : mne.Info
        EEG channels with positions and an (inactive) average-reference projection.
    noise_cov : ndarray, shape (n_channels, n_channels)
        Symmetric positive semi-definite, average referenced.
    """
    import mne

    check_instance("testing_data", testing_data, (str, os.PathLike), "a folder path")
    root = Path(testing_data)
    recorded = mne.io.read_info(root / SENSOR_FILES["raw"], verbose=False)
    cov = mne.read_cov(root / SENSOR_FILES["cov"], verbose=False)
    bads = set(recorded["bads"]) | set(cov["bads"])
    eeg = mne.pick_types(recorded, meg=False, eeg=True, exclude=[])
    names = [
        recorded.ch_names[k]
        for k in eeg
        if recorded.ch_names[k] not in bads and recorded.ch_names[k] in cov.ch_names
    ]
    ch_pos = {name: recorded["chs"][recorded.ch_names.index(name)]["loc"][:3] for name in names}
    info = mne.create_info(names, 10000.0, "eeg")
    info.set_montage(mne.channels.make_dig_montage(ch_pos=ch_pos, coord_frame="head"))
    index = [cov.ch_names.index(name) for name in names]
    C = np.asarray(cov.data, dtype=float)[np.ix_(index, index)]
    P = np.eye(len(names)) - 1.0 / len(names)
    C = P @ C @ P
    return with_average_reference(info), readonly(0.5 * (C + C.T))


def _source_space(root, bem, source_space, spacing_mm):
    import mne

    common = dict(
        subject=SUBJECT,
        subjects_dir=root / "subjects",
        bem=bem,
        mindist=MINDIST_MM,
        add_interpolator=False,  # only the positions are used
        verbose=False,
    )
    if source_space == "volume":
        return mne.setup_volume_source_space(pos=spacing_mm, **common)
    return mne.setup_volume_source_space(
        pos=spacing_mm, mri="aseg.mgz", volume_label=dict(LABELS), **common
    )


def _forward(root, cache, bem, info, trans, source_space, montage, spacing_mm):
    import mne

    files = {name: root / rel for name, rel in TESTING_FILES.items()}
    parameters = dict(
        what="forward",
        source_space=source_space,
        labels=LABELS if source_space == "anatomical" else None,
        spacing_mm=spacing_mm,
        mindist_mm=MINDIST_MM,
        interpolator=False,
        montage=montage,
        channels=[ch["loc"][:3].round(9).tolist() for ch in info["chs"]],
        mne=mne.__version__,
        format=CACHE_FORMAT,
    )
    path = cache / f"{source_space}-{input_digest(files, parameters)}-fwd.fif"
    with _locked(path):
        if not path.exists():
            src = _source_space(root, bem, source_space, spacing_mm)
            fwd = mne.make_forward_solution(
                info, trans=trans, src=src, bem=bem, eeg=True, meg=False, verbose=False
            )
            with atomic_path(path) as tmp, _mne_quiet():
                mne.write_forward_solution(tmp, fwd, overwrite=True, verbose=False)
    return mne.read_forward_solution(path, verbose=False)


def _labels(root, head_from_mri):
    """Voxel centres (head coordinates, m) of every label of :data:`LABELS`, and voxel edge."""
    from nibabel.freesurfer.mghformat import MGHImage

    image = MGHImage.from_filename(root / TESTING_FILES["aseg"])
    volume = np.asarray(image.dataobj)
    vox_to_mri = image.header.get_vox2ras_tkr()  # voxel -> MRI (surface RAS), mm
    vox_to_head = head_from_mri @ np.diag([1e-3, 1e-3, 1e-3, 1.0]) @ vox_to_mri
    labels = {
        name: readonly(apply_affine(vox_to_head, np.argwhere(volume == label_id)))
        for name, label_id in LABELS.items()
    }
    return labels, float(max(image.header.get_zooms()[:3]))


def _fit_sphere(points):
    design = np.c_[2 * points, np.ones(len(points))]
    solution = np.linalg.lstsq(design, np.sum(points**2, axis=1), rcond=None)[0]
    centre = solution[:3]
    return centre, float(np.sqrt(solution[3] + centre @ centre))


@functools.lru_cache(maxsize=4)
def _build(root, source_space, montage, cache, spacing_mm):
    import mne

    root, cache = Path(root), Path(cache)
    bem = _bem_solution(root, cache)
    trans = mne.read_trans(root / TESTING_FILES["trans"], verbose=False)  # head -> MRI
    if trans["from"] != mne.io.constants.FIFF.FIFFV_COORD_HEAD:
        trans = mne.transforms.invert_transform(trans)
    head_from_mri = mne.transforms.invert_transform(trans)["trans"]
    mni_to_head = subject_mni_to_head(root)
    scalp = _surface(bem, _SCALP_ID, head_from_mri)
    noise_cov = None
    if montage == SUBJECT_MONTAGE:
        info, noise_cov = subject_electrodes(root)
    else:
        info = _electrodes(montage, mni_to_head, scalp)
    fwd = _forward(root, cache, bem, info, trans, source_space, montage, spacing_mm)
    fwd, leadfield = finish_forward(fwd, len(info.ch_names))
    inner = _surface(bem, _INNER_SKULL_ID, head_from_mri)
    centre, radius = _fit_sphere(inner[0])
    labels, voxel_mm = _labels(root, head_from_mri)
    anatomy = Anatomy(
        mni_to_head=readonly(mni_to_head),
        mni_source=(
            "the sample subject's talairach.xfm and head <-> MRI transform (inverse of "
            "mne.head_to_mni)"
        ),
        grid_transform=readonly(trans["trans"]),
        grid_frame="MRI",
        labels=labels,
        label_voxel_mm=voxel_mm,
        boundary=(readonly(inner[0]), readonly(inner[1])),
        centre=readonly(centre),
        radius=radius,
        trans=trans,
        subject=SUBJECT,
    )
    spacing = spacing_mm
    return HeadModel(
        leadfield=leadfield,
        positions=readonly(np.array(fwd["source_rr"], dtype=float)),
        info=info,
        conductor=bem,
        src=fwd["src"],
        fwd=fwd,
        montage=montage,
        seed=None,
        spacing=spacing * 1e-3,
        conductor_kind="bem",
        source_space=source_space,
        anatomy=anatomy,
        noise_cov=noise_cov,
    )
