"""Readers and writers: every format gives the same arrays, and a bad file names itself."""

import h5py
import mne
import numpy as np
import pandas as pd
import pytest
from scipy.io import savemat

from skf_ref import InputError, apply_skf, reconstruct
from skf_ref.io import read_data, read_leadfield, write_reconstruction, write_stc
from skf_ref.io._variables import read_variables

RNG = np.random.default_rng(0)
L = RNG.standard_normal((5, 12))
Y = RNG.standard_normal((5, 7))
NAMES = [f"E{i}" for i in range(5)]
TIMES = np.arange(7) / 100.0 - 0.02


def _v73(path, **arrays):
    """A MATLAB v7.3 file: HDF5 after a 512-byte MATLAB header, arrays column-major."""
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, value in arrays.items():
            dataset = f.create_dataset(name, data=np.asarray(value).T)
            dataset.attrs["MATLAB_class"] = np.bytes_("double")
    with open(path, "r+b") as f:
        f.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, HDF5 schema 1.00 .".ljust(116))
        f.write(b"\x00" * 8 + b"\x00\x02IM")
    return path


@pytest.mark.parametrize("fmt", ["npy", "npz", "npz-named", "mat5", "mat73"])
def test_lead_field_formats(tmp_path, fmt):
    path = tmp_path / f"L.{fmt[:3]}"
    key = None
    if fmt == "npy":
        np.save(path, L)
    elif fmt == "npz":
        np.savez(path, L, positions=RNG.standard_normal((4, 3)))  # one array: arr_0 (2-D)
        key = "arr_0"
    elif fmt == "npz-named":
        np.savez(path, gain=L, other=np.ones((2, 2)))
        key = "gain"
    elif fmt == "mat5":
        savemat(path, {"leadfield": L, "ch_names": np.array(NAMES, dtype=object)})
    else:
        _v73(path, L=L)
    read = read_leadfield(path, key=key)
    np.testing.assert_array_equal(read.data, L)
    if fmt == "mat5":
        assert read.ch_names == NAMES


@pytest.mark.parametrize("fmt", ["npy", "npz", "mat5", "mat73", "csv"])
def test_data_formats(tmp_path, fmt):
    path = tmp_path / f"Y.{fmt[:3]}"
    if fmt == "npy":
        np.save(path, Y)
    elif fmt == "npz":
        np.savez(path, Y=Y, times=TIMES, ch_names=np.array(NAMES))
    elif fmt == "mat5":
        savemat(path, {"Y": Y})
    elif fmt == "mat73":
        _v73(path, data=Y)
    else:
        pd.DataFrame(Y, index=NAMES, columns=TIMES).to_csv(path)
    read = read_data(path)
    np.testing.assert_allclose(read.data, Y, rtol=1e-15)
    if fmt in ("npz", "csv"):
        assert read.ch_names == NAMES
        np.testing.assert_allclose(read.times, TIMES)


def test_mne_files_round_trip(tmp_path, mne_setup):
    epochs = mne_setup["make_epochs"](target=300, seed=4)
    evoked = epochs.average()
    other = evoked.copy()
    other.comment = "other"
    mne.write_evokeds(tmp_path / "x-ave.fif", [evoked, other], verbose=False)
    mne.write_forward_solution(tmp_path / "x-fwd.fif", mne_setup["forward"], verbose=False)
    epochs.save(tmp_path / "x-epo.fif", verbose=False)
    with pytest.raises(InputError, match=r"holds 2 conditions .*: choose one"):
        read_data(tmp_path / "x-ave.fif")
    with pytest.raises(InputError, match=r"no condition 'missing'; it holds"):
        read_data(tmp_path / "x-ave.fif", condition="missing")
    float32 = 1e-6 * np.abs(evoked.data).max()  # FIF stores data in single precision
    read = read_data(tmp_path / "x-ave.fif", condition=0).evoked
    np.testing.assert_allclose(read.data, evoked.data, rtol=0, atol=float32)
    assert read_data(tmp_path / "x-ave.fif", condition="other").evoked.comment == "other"
    np.testing.assert_allclose(read_data(tmp_path / "x-epo.fif").data, evoked.data, atol=float32)
    forward = read_leadfield(tmp_path / "x-fwd.fif")
    assert forward.ch_names == mne_setup["info"].ch_names
    np.testing.assert_allclose(forward.positions, mne_setup["positions"], atol=1e-6)
    # the estimate from the files equals the one from the objects in memory
    from_files = apply_skf(read, forward.forward, noise_std=1e-6).data
    in_memory = apply_skf(evoked, mne_setup["forward"], noise_std=1e-6).data
    np.testing.assert_allclose(from_files, in_memory, rtol=1e-4)  # float32 storage


def test_raw_recordings_are_read_through_mne(tmp_path, mne_setup):
    raw = mne.io.RawArray(Y[:, :7] * 1e-6, mne.create_info(NAMES, 100.0, "eeg"), verbose=False)
    raw.save(tmp_path / "x_raw.fif", verbose=False)
    read = read_data(tmp_path / "x_raw.fif")
    np.testing.assert_allclose(read.data, Y * 1e-6, rtol=1e-6)
    assert read.ch_names == NAMES and read.evoked is not None


@pytest.mark.parametrize(
    "name, content, match",
    [
        ("missing.npy", None, "missing.npy: no such file"),
        ("x.xlsx", b"PK", r"unknown lead-field format '.xlsx'"),
        ("x.npy", b"not numpy", r"x.npy: not a NumPy .npy file$"),
        ("x.mat", b"garbage", "cannot be read as a MATLAB v5 file"),
        ("x.npy", "1-D", r"must have shape \(n_channels, n_sources\), got \(3,\)"),
        ("x.npz", "two", r"holds \['a', 'b'\]: say which is meant"),
    ],
)
def test_unusable_lead_field_files(tmp_path, name, content, match):
    path = tmp_path / name
    if content == "1-D":
        np.save(path, np.ones(3))
    elif content == "two":
        np.savez(path, a=np.ones((2, 2)), b=np.ones((2, 2)))
    elif content is not None:
        path.write_bytes(content)
    with pytest.raises(InputError, match=match):
        read_leadfield(path)


@pytest.mark.parametrize("layout", ["text", "hdf5"])
def test_an_octave_file_that_is_no_matlab_file_says_to_save_with_v7(tmp_path, layout):
    path = tmp_path / "mine.mat"
    if layout == "text":  # Octave's default: save('mine.mat', 'z')
        path.write_text("# Created by Octave 7.3.0\n# name: z\n# type: scalar\n1\n")
    else:  # save('-hdf5', ...): a group per variable, no MATLAB header
        with h5py.File(path, "w") as f:
            f.create_group("z").create_dataset("value", data=np.ones(3))
    with pytest.raises(InputError, match=r"mine.mat: cannot be read .* save\('-v7'"):
        read_variables(path)


def test_unusable_data_files(tmp_path):
    bad_csv = tmp_path / "x.csv"
    bad_csv.write_text("channel,0.0,0.1\nE1,1.0,two\n")
    with pytest.raises(InputError, match="x.csv: cannot be read as CSV"):
        read_data(bad_csv)
    with pytest.raises(InputError, match=r"unknown data format '.txt'"):
        (tmp_path / "x.txt").write_text("1 2 3")
        read_data(tmp_path / "x.txt")
    np.save(tmp_path / "nan.npy", np.array([[1.0, np.nan]]))
    with pytest.raises(InputError, match="nan.npy contains NaN"):
        read_data(tmp_path / "nan.npy")


def test_written_results(tmp_path, mne_setup):
    rec = reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1, exponent=1.25)
    path = write_reconstruction(
        tmp_path / "r.npz", rec, times=TIMES, positions=np.zeros((4, 3)), extra={"pm_snr_db": 0}
    )
    saved = np.load(path)
    np.testing.assert_array_equal(saved["z"], rec.z)
    np.testing.assert_array_equal(saved["amplitude"], rec.amplitude(3))
    assert float(saved["exponent"]) == 1.25 and str(saved["smoother"]) == "none"
    assert str(saved["skf_ref_version"]) and float(saved["log_likelihood"]) == rec.log_likelihood
    with pytest.raises(InputError, match=r"r.csv: must end in .npz, got '.csv'"):
        write_reconstruction(tmp_path / "r.csv", rec)
    evoked = mne_setup["make_epochs"](target=300, seed=5).average()
    stc = apply_skf(evoked, mne_setup["forward"], noise_std=1e-6)
    for name in ("est.stc", "est.h5"):
        (written,) = write_stc(tmp_path / name, stc)
        again = mne.read_source_estimate(written)
        np.testing.assert_allclose(again.data, stc.data, rtol=1e-6)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["est-stc.h5", "est-vl.stc", "r.npz"]


# --- only what is asked for is read; what is not an archive is told so -------------------


def test_an_unused_array_of_an_npz_is_never_decompressed(tmp_path):
    import tracemalloc

    path = tmp_path / "y.npz"
    unused = np.zeros(8_000_000)  # 64 MB, compressed to a few kB
    np.savez_compressed(path, Y=Y, times=TIMES, ch_names=np.array(NAMES), unused=unused)
    tracemalloc.start()
    try:
        read = read_data(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    np.testing.assert_array_equal(read.data, Y)
    assert peak < unused.nbytes / 16, peak


@pytest.mark.parametrize("content", [b"not an archive", b"\x93NUMPY\x01\x00garbage", b""])
@pytest.mark.parametrize("reader", [read_data, read_leadfield])
def test_a_file_named_npz_that_is_no_archive_is_told_so(tmp_path, content, reader):
    path = tmp_path / "x.npz"
    path.write_bytes(content)
    with pytest.raises(InputError, match=r"x.npz: not an .npz archive") as info:
        reader(path)
    assert "pickle" not in str(info.value)  # numpy's advice to load it unsafely: never
    if content.startswith(b"\x93NUMPY"):
        assert "it is a NumPy .npy array (name it .npy)" in str(info.value)


@pytest.mark.parametrize("fmt", ["npy", "npz"])
def test_pickled_objects_are_refused_as_such(tmp_path, fmt):
    objects = np.array([{"a": 1}, None], dtype=object)
    path = tmp_path / f"x.{fmt}"
    if fmt == "npy":
        np.save(path, objects, allow_pickle=True)
    else:
        np.savez(path, Y=objects)
    with pytest.raises(InputError, match=r"holds Python objects \(a pickle\), which skf_ref") as e:
        read_data(path)
    assert "allow_pickle" not in str(e.value)


# --- MATLAB matrices keep their dimensions ---------------------------------------------------


@pytest.mark.parametrize("v73", [False, True], ids=["v5", "v7.3"])
@pytest.mark.parametrize("shape", [(5, 1), (1, 7), (1, 1)])
def test_a_mat_matrix_with_one_column_or_row_stays_a_matrix(tmp_path, v73, shape):
    path = tmp_path / "x.mat"
    matrix = RNG.standard_normal(shape)
    if v73:
        _v73(path, L=matrix)
    else:
        savemat(path, {"L": matrix})
    read = read_leadfield(path)
    assert read.data.shape == shape
    np.testing.assert_array_equal(read.data, matrix)
    assert read_data(path).data.shape == shape


def test_mat_times_and_names_are_vectors(tmp_path):
    path = tmp_path / "y.mat"
    savemat(path, {"Y": Y, "times": TIMES[None], "ch_names": np.array(NAMES, dtype=object)})
    read = read_data(path)
    np.testing.assert_array_equal(read.times, TIMES)
    assert read.ch_names == NAMES


# --- channel names: one per row, none twice --------------------------------------------------


@pytest.mark.parametrize("fmt", ["npz", "mat"])
@pytest.mark.parametrize(
    "names, match",
    [
        (["E0", "E1", "E2", "E1", "E4"], r"ch_names holds 'E1' twice \(positions 2 and 4\)"),
        (["E0", "E1", "E2", "E3"], r"4 names in ch_names for 5 rows"),
        (["E0", "E1", " ", "E3", "E4"], r"ch_names has an empty name at position 3"),
    ],
)
def test_channel_names_named_twice_or_miscounted_are_refused(tmp_path, fmt, names, match):
    path = tmp_path / f"x.{fmt}"
    if fmt == "npz":
        np.savez(path, Y=Y, L=L, ch_names=np.array(names))
    else:
        savemat(path, {"Y": Y, "L": L, "ch_names": np.array(names, dtype=object)})
    for reader, key in ((read_data, "Y"), (read_leadfield, "L")):
        with pytest.raises(InputError, match=match):
            reader(path, key=key)


# --- writers: their arguments checked, errors naming the user's path ------------------------


def test_every_writer_names_a_swapped_or_wrong_argument(tmp_path, mne_setup):
    from skf_ref.conformance import build, cases, export, write_case
    from skf_ref.io import stc_to_zarr, to_zarr
    from skf_ref.study._sweep import run_sweep

    def small_grid():
        axes = ("snr_db", "ep_snr_db", "pm_snr_db", "exponent", "smoother", "seed")
        return dict(zip(axes, ([20.0], [0.0], [0.0], [0.5], [None], [0]), strict=True))

    rec = reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1)
    stc = apply_skf(mne_setup["make_epochs"](target=300, seed=5).average(),
                    mne_setup["forward"], noise_std=1e-6)  # fmt: skip
    path = tmp_path / "x"
    calls = {
        "write_stc(stc, path)": (lambda: write_stc(stc, path.with_suffix(".stc")), "path"),
        "write_stc(path, rec)": (lambda: write_stc(path.with_suffix(".stc"), rec), "stc"),
        "write_reconstruction(rec, path)": (
            lambda: write_reconstruction(rec, path.with_suffix(".npz")),
            "path",
        ),
        "write_reconstruction(path, stc)": (
            lambda: write_reconstruction(path.with_suffix(".npz"), stc),
            "reconstruction",
        ),
        "to_zarr(path, rec)": (lambda: to_zarr(path.with_suffix(".zarr"), rec), "path"),
        "to_zarr(rec, 3)": (lambda: to_zarr(rec, 3), "path"),
        "stc_to_zarr(rec, src, None, ...)": (
            lambda: stc_to_zarr(rec, mne_setup["forward"]["src"], None, 0.0, 1e-3),
            "path",
        ),
        "write_case(path, case)": (
            lambda: write_case(path.with_suffix(".npz"), cases()[0]),
            "path",
        ),  # fmt: skip
        "export(3)": (lambda: export(3), "directory"),
        "build(None)": (lambda: build(None), "directory"),
        "run_sweep(grid, 3)": (lambda: run_sweep(small_grid(), 3, verbose=False), "out"),
    }
    for call, (write, name) in calls.items():
        with pytest.raises(TypeError, match=f"^{name} must be ") as info:
            write()
        assert "got" in str(info.value), call
    assert not any(tmp_path.iterdir())


def test_a_reconstruction_written_where_it_cannot_be_names_the_user_s_path(tmp_path):
    rec = reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1)
    missing = tmp_path / "nodir" / "o.npz"
    with pytest.raises(InputError, match=f"^{missing}: the folder {missing.parent} does not"):
        write_reconstruction(missing, rec)
    folder = tmp_path / "o.npz"
    folder.mkdir()
    with pytest.raises(InputError, match=f"^{folder} is a folder; give a file name"):
        write_reconstruction(folder, rec)
    assert [p.name for p in tmp_path.iterdir()] == ["o.npz"] and not any(folder.iterdir())


def test_a_vector_estimate_is_refused_as_stc_before_anything_is_written(tmp_path, mne_setup):
    from skf_ref.io._files import stc_files

    evoked = mne_setup["make_epochs"](target=300, seed=5).average()
    vector = apply_skf(evoked, mne_setup["forward"], noise_std=1e-6, pick_ori="vector")
    with pytest.raises(
        InputError, match=r"est.stc: MNE writes a VolVectorSourceEstimate to .h5 only"
    ):
        write_stc(tmp_path / "est.stc", vector)
    assert not any(tmp_path.iterdir())
    (written,) = write_stc(tmp_path / "est.h5", vector)
    assert written.name == "est-stc.h5"
    assert [p.name for p in stc_files(tmp_path / "a-vl.stc", "SourceEstimate")] == [
        "a-lh.stc",
        "a-rh.stc",
    ]
    with pytest.raises(InputError, match="MNE writes several volumes to .h5 only"):
        stc_files(tmp_path / "a.stc", "VolSourceEstimate", n_volumes=2)


def test_write_stc_removes_what_a_killed_writer_left_and_nothing_else(tmp_path, mne_setup):
    import subprocess
    import sys

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".est-vl.stc.skf-tmp-{dead.pid}-abcd1234"
    stale.mkdir()
    (stale / ".skf_ref_temporary").touch()
    (stale / "est-vl.stc").write_bytes(b"half an estimate")
    look_alike = tmp_path / f".est-vl.stc.skf-tmp-{dead.pid}-user"  # no mark: the user's
    look_alike.mkdir()
    (look_alike / "notes.txt").write_text("kept")
    evoked = mne_setup["make_epochs"](target=300, seed=5).average()
    stc = apply_skf(evoked, mne_setup["forward"], noise_std=1e-6)
    for _ in range(2):  # a rerun leaves nothing either
        assert [p.name for p in write_stc(tmp_path / "est.stc", stc)] == ["est-vl.stc"]
        names = sorted(p.name for p in tmp_path.iterdir())
        assert names == [look_alike.name, "est-vl.stc"]
