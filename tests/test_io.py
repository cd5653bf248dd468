"""Readers and writers: every format gives the same arrays, and a bad file names itself."""

import h5py
import mne
import numpy as np
import pandas as pd
import pytest
from scipy.io import savemat

from skf_ref import InputError, apply_skf, reconstruct
from skf_ref.io import read_data, read_leadfield, write_reconstruction, write_stc

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
        ("x.npy", b"not numpy", "cannot be read as a NumPy array"),
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
    with pytest.raises(InputError, match="written to .npz"):
        write_reconstruction(tmp_path / "r.csv", rec)
    evoked = mne_setup["make_epochs"](target=300, seed=5).average()
    stc = apply_skf(evoked, mne_setup["forward"], noise_std=1e-6)
    for name in ("est.stc", "est.h5"):
        (written,) = write_stc(tmp_path / name, stc)
        again = mne.read_source_estimate(written)
        np.testing.assert_allclose(again.data, stc.data, rtol=1e-6)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["est-stc.h5", "est-vl.stc", "r.npz"]


# --- CSV layouts, read off the content ------------------------------------------------------


def _csv_files(folder):
    """Y written the ways people write it: (file, names expected, times expected)."""
    frame = pd.DataFrame(Y, index=NAMES, columns=TIMES)
    files = {
        "names and times": (frame.to_csv, True, True),
        "numbers only (np.savetxt)": (lambda p: np.savetxt(p, Y, delimiter=","), False, False),
        "times, no names (index=False)": (lambda p: frame.to_csv(p, index=False), False, True),
        "names, no times (header=False)": (lambda p: frame.to_csv(p, header=False), True, False),
        "UTF-8 BOM": (lambda p: frame.to_csv(p, encoding="utf-8-sig"), True, True),
    }
    for i, (name, (write, names, times)) in enumerate(files.items()):
        path = folder / f"y{i}.csv"
        write(path)
        yield name, path, names, times


def test_csv_layouts_are_read_off_the_content(tmp_path):
    for layout, path, names, times in _csv_files(tmp_path):
        read = read_data(path)
        np.testing.assert_allclose(read.data, Y, rtol=1e-15, err_msg=layout)
        assert read.ch_names == (NAMES if names else None), layout
        if times:
            np.testing.assert_allclose(read.times, TIMES, err_msg=layout)
        else:
            assert read.times is None, layout


@pytest.mark.parametrize(
    "content",
    [
        "Fp1,Fp2,Cz\n1.0,2.0,3.0\n4.0,5.0,6.0\n",  # channels in columns (times x channels)
        "0.0,0.1\n1.0,2.0\n3.0,4.0\n",  # two samples: a row of times, or of data?
        ",0.0,0.1,0.2\nE1,1,2,3\n4,5,6,7\n",  # named and unnamed rows
        "",
    ],
)
def test_a_csv_that_fits_no_layout_is_refused_showing_the_layout(tmp_path, content):
    path = tmp_path / "x.csv"
    path.write_text(content)
    with pytest.raises(InputError, match=r"x.csv: .*expected channels in rows and times in"):
        read_data(path)
