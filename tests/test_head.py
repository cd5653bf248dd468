"""Head models: the BEM route against MNE's analytic sphere, the sphere's cortex + thalamus,
the anatomy, the testing-data lookup and the cache folder. No test reads MNE's testing dataset:
the realistic head is validation's (the study, ``python -m validation.reproduce``)."""

import os

import matplotlib

matplotlib.use("Agg")

import mne  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from skf_ref.study import _head as heads  # noqa: E402
from skf_ref.study._head import Anatomy  # noqa: E402

#: Radii (m) and conductivities (S/m) of the three nested shells: brain, skull, scalp.
RADII = (0.080, 0.085, 0.090)
SIGMAS = (0.3, 0.006, 0.3)
# MNE's linear-collocation BEM on icosahedral spheres differs from the analytic solution by
# a discretization error that shrinks as the mesh is refined (measured, per dipole, at 20,
# 45 and 65 mm from the centre: 13-16 % with 320 triangles per surface, 5-7 % with 1280 (the
# resolution of the sample subject's BEM), 1.5-2 % with 5120; each subdivision halves the
# edge length and cuts the error 2.5-3.5 times). The tolerance is the 1280-triangle error with
# a margin, and the test checks the refinement too: a wrong model would not converge.
BEM_RTOL = {2: 0.18, 3: 0.08}
MIN_REFINEMENT_GAIN = 2.0


def icosphere(level):
    """Unit icosphere: vertices (n, 3) and triangles (m, 3), 20 * 4**level triangles."""
    t = (1 + 5**0.5) / 2
    vertices = [
        [-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
        [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1],
    ]  # fmt: skip
    faces = [
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
        [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
        [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ]  # fmt: skip
    vertices = [np.array(v, dtype=float) / np.linalg.norm(v) for v in vertices]
    for _ in range(level):
        faces = _subdivide(vertices, faces)
    return np.array(vertices), np.array(faces)


def _subdivide(vertices, faces):
    """Split every triangle in four; the new vertices (on the unit sphere) join ``vertices``."""
    middle, refined = {}, []

    def mid(a, b):
        key = (min(a, b), max(a, b))
        if key not in middle:
            point = vertices[a] + vertices[b]
            vertices.append(point / np.linalg.norm(point))
            middle[key] = len(vertices) - 1
        return middle[key]

    for a, b, c in faces:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        refined += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
    return refined


@pytest.fixture(scope="module")
def spheres():
    """Electrodes on the outer shell, six dipoles, and the analytic sphere's gain."""
    directions = icosphere(1)[0]
    directions = directions[directions[:, 2] > -0.2]
    names = [f"E{i}" for i in range(len(directions))]
    info = mne.create_info(names, 1000.0, "eeg")
    ch_pos = dict(zip(names, directions * RADII[2], strict=True))
    info.set_montage(mne.channels.make_dig_montage(ch_pos=ch_pos, coord_frame="head"))
    rng = np.random.default_rng(0)
    unit = rng.standard_normal((6, 3))
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    positions = unit * np.repeat([0.020, 0.045, 0.065], 2)[:, None]
    src = mne.setup_volume_source_space(
        pos=dict(rr=positions, nn=np.tile([0.0, 0.0, 1.0], (6, 1))),
        mindist=0.0,
        sphere=(0.0, 0.0, 0.0, RADII[2]),
        verbose=False,
    )
    sphere = mne.make_sphere_model(
        r0=(0.0, 0.0, 0.0),
        head_radius=RADII[2],
        relative_radii=[r / RADII[2] for r in RADII],
        sigmas=SIGMAS,
        verbose=False,
    )
    gain = mne.make_forward_solution(info, None, src, sphere, meg=False, verbose=False)
    return info, src, gain["sol"]["data"]


def bem_gain(tmp_path, level, info, src):
    """The gain of MNE's BEM on three nested icospheres written as FreeSurfer surfaces."""
    vertices, faces = icosphere(level)
    folder = tmp_path / f"level{level}" / "shells" / "bem"
    folder.mkdir(parents=True)
    for name, radius in zip(("inner_skull", "outer_skull", "outer_skin"), RADII, strict=True):
        mne.write_surface(str(folder / f"{name}.surf"), vertices * radius * 1e3, faces)
    model = mne.make_bem_model(
        "shells", ico=None, conductivity=SIGMAS, subjects_dir=folder.parents[1], verbose=False
    )
    solution = mne.make_bem_solution(model, verbose=False)
    identity = mne.transforms.Transform("head", "mri", np.eye(4))
    fwd = mne.make_forward_solution(info, identity, src, solution, meg=False, verbose=False)
    return fwd["sol"]["data"]


def relative_errors(gain, exact):
    """Per dipole, ||gain - exact|| / ||exact|| over its three columns, average referenced."""
    gain, exact = gain - gain.mean(axis=0), exact - exact.mean(axis=0)
    diff = np.linalg.norm((gain - exact).reshape(len(gain), -1, 3), axis=(0, 2))
    return diff / np.linalg.norm(exact.reshape(len(exact), -1, 3), axis=(0, 2))


@pytest.mark.slow
def test_bem_on_nested_spheres_converges_to_the_analytic_sphere(spheres, tmp_path):
    info, src, exact = spheres
    errors = {
        level: relative_errors(bem_gain(tmp_path, level, info, src), exact) for level in (2, 3)
    }
    for level, error in errors.items():
        assert error.max() < BEM_RTOL[level], (level, error)
    assert (errors[2] / errors[3]).min() > MIN_REFINEMENT_GAIN


# --------------------------------------------------------------------------- the sphere


def test_sphere_cortex_and_thalamus_follow_their_definition():
    head = heads.make_head("sphere", "anatomical")
    assert head.conductor_kind == "sphere" and head.source_space == "anatomical"
    origin, brain = head.origin, head.brain_radius
    depth = (brain - np.linalg.norm(head.positions - origin, axis=1)) * 1e3
    thalami = heads.template_mni_to_head()
    centres = np.array(heads.THALAMUS_MNI_MM) * 1e-3 @ thalami[:3, :3].T + thalami[:3, 3]
    to_thalamus = np.linalg.norm(head.positions[:, None] - centres[None], axis=2).min(axis=1)
    in_thalamus = to_thalamus * 1e3 <= heads.THALAMUS_RADIUS_MM + 1e-9
    shallow, deep = heads.SHELL_DEPTH_MM
    cortex = ~in_thalamus
    assert (depth[cortex] >= shallow - 1e-9).all() and (depth[cortex] <= deep + 1e-9).all()
    assert (head.positions[cortex, 2] >= -1e-12).all()  # at or above the fiducial plane
    assert 50 < in_thalamus.sum() < 110  # two balls of 8 cm³ on a 6 mm lattice: ~37 each
    assert 3000 < head.n_positions < 4500  # about the sample subject's 3550
    # a subset of a regular 6 mm lattice: the projections draw it
    steps = (head.positions - head.positions.min(axis=0)) / head.spacing
    np.testing.assert_allclose(steps, np.rint(steps), atol=1e-6)
    assert head.spacing == pytest.approx(heads.SPHERE_ANATOMICAL_SPACING_MM * 1e-3)


def test_make_head_picks_the_cell():
    assert heads.make_head("sphere", "volume", n_positions=500).n_positions == 480
    with pytest.raises(ValueError, match="conductor must be one of"):
        heads.make_head("fem", "volume")
    with pytest.raises(ValueError, match="source_space must be one of"):
        heads.make_head("sphere", "cortex")


# --------------------------------------------------------------------------- anatomy


def toy_anatomy(**changes):
    """A head frame equal to MNI, a 2 mm voxel label at the origin, a boundary at z = 50 mm."""
    values = dict(
        mni_to_head=np.eye(4),
        mni_source="toy",
        grid_transform=np.eye(4),
        grid_frame="head",
        labels={"spot": np.array([[0.0, 0.0, 0.0], [0.002, 0.0, 0.0]])},
        label_voxel_mm=2.0,
        boundary=(
            np.array([[0.0, 0.0, 0.05], [0.05, 0.0, 0.0]]),
            np.array([[0, 0, 1.0], [1, 0, 0]]),
        ),
        centre=np.zeros(3),
        radius=0.05,
    )
    return Anatomy(**(values | changes))


def test_a_point_in_its_label_stays_and_one_outside_moves_to_the_nearest_voxel():
    anatomy = toy_anatomy()
    position, moved = anatomy.place(np.array([0.0025, 0.0, 0.0]), "spot")
    assert moved == 0.0 and position == pytest.approx([0.0025, 0.0, 0.0])
    position, moved = anatomy.place(np.array([0.006, 0.0, 0.0]), "spot")
    assert position == pytest.approx([0.002, 0.0, 0.0]) and moved == pytest.approx(4.0)
    position, moved = anatomy.place(np.array([0.006, 0.0, 0.0]))  # no label asked: as mapped
    assert moved == 0.0
    with pytest.raises(ValueError, match="label must be one of"):
        anatomy.place(np.zeros(3), "Left-Thalamus")


def test_radial_is_the_nearest_boundary_normal_or_the_sphere_direction():
    anatomy = toy_anatomy()
    np.testing.assert_allclose(anatomy.radial(np.array([0.0, 0.01, 0.04])), [0, 0, 1])
    np.testing.assert_allclose(anatomy.radial(np.array([0.04, 0.0, 0.01])), [1, 0, 0])
    sphere = toy_anatomy(boundary=None)
    np.testing.assert_allclose(sphere.radial(np.array([0.0, 0.03, 0.04])), [0, 0.6, 0.8])
    with pytest.raises(ValueError, match="sphere centre"):
        sphere.radial(np.zeros(3))


# --------------------------------------------------------------------------- inputs


def test_testing_data_folder_is_checked(tmp_path):
    with pytest.raises(ValueError, match="testing_data must be MNE's testing dataset folder"):
        heads.find_testing_data(tmp_path)
    for name in heads.TESTING_FILES.values():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(b"")
    assert heads.find_testing_data(tmp_path) == tmp_path.resolve()
    with pytest.raises(TypeError, match="testing_data must be a folder path, got 3"):
        heads.find_testing_data(3)


def test_without_the_dataset_the_realistic_head_says_how_to_point_at_it(monkeypatch, tmp_path):
    monkeypatch.setattr(mne.datasets.testing, "data_path", lambda **kwargs: tmp_path / "none")
    assert heads.find_testing_data() is None
    with pytest.raises(ValueError, match="--mne-testing-data DIR"):
        heads.make_realistic_head(cache_dir=tmp_path)


def test_cache_folder(monkeypatch, tmp_path):
    assert heads.cache_dir(tmp_path) == tmp_path
    monkeypatch.setenv(heads.CACHE_ENV, str(tmp_path / "env"))
    assert heads.cache_dir() == tmp_path / "env"
    monkeypatch.delenv(heads.CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    if os.name == "posix" and not os.uname().sysname == "Darwin":
        assert heads.cache_dir() == tmp_path / "xdg" / "skf_ref"


def test_the_subjects_own_electrodes_and_noise_covariance(tmp_path):
    """Read from files in the dataset's layout, made here: MEG and EEG channels, one EEG
    channel bad in the covariance (as EEG 053 is in the sample subject's)."""
    from skf_ref.study._head import SENSOR_FILES, subject_electrodes

    rng = np.random.default_rng(0)
    names = ["MEG 0111", "EEG 001", "EEG 002", "EEG 003", "EEG 004", "EEG 005"]
    types = ["mag"] + ["eeg"] * 5
    info = mne.create_info(names, 100.0, types)
    positions = rng.normal(0, 0.05, (5, 3)) + [0, 0, 0.08]
    for k, pos in enumerate(positions, start=1):
        info["chs"][k]["loc"][:3] = pos
        info["chs"][k]["coord_frame"] = mne.io.constants.FIFF.FIFFV_COORD_HEAD
    raw_path = tmp_path / SENSOR_FILES["raw"]
    raw_path.parent.mkdir(parents=True)
    mne.io.RawArray(rng.standard_normal((6, 200)) * 1e-6, info, verbose=False).save(raw_path)
    A = rng.standard_normal((6, 6)) * 1e-6
    cov = mne.Covariance(A @ A.T, names, bads=["EEG 003"], projs=[], nfree=100)
    cov_path = tmp_path / SENSOR_FILES["cov"]
    cov_path.parent.mkdir(parents=True)
    cov.save(cov_path, verbose=False)

    info, C = subject_electrodes(tmp_path)
    assert info.ch_names == ["EEG 001", "EEG 002", "EEG 004", "EEG 005"]  # EEG, not bad
    located = np.array([ch["loc"][:3] for ch in info["chs"]])
    np.testing.assert_allclose(located, positions[[0, 1, 3, 4]])
    keep = [1, 2, 4, 5]
    P = np.eye(4) - 0.25
    np.testing.assert_allclose(C, P @ (A @ A.T)[np.ix_(keep, keep)] @ P, rtol=1e-12, atol=0)
    np.testing.assert_allclose(C @ np.ones(4), 0.0, atol=1e-12 * np.abs(C).max())
    assert any("Average" in proj["desc"] for proj in info["projs"])
    with pytest.raises(ValueError, match="montage='sample'.*needs conductor='bem'"):
        heads.make_head("sphere", "anatomical", montage="sample")
