"""Operators saved and read back, and streamed estimates read back over a span of time.

An operator read from its file gives the estimates of the one written, bit for bit; the
file is HDF5 without pickles, with a format version a reader checks. A store written by
``apply_skf_raw(out=...)`` is read back as the MNE source estimate of any span, reading
only the chunks that hold it.
"""

import h5py
import mne
import numpy as np
import pytest

from skf_ref import (
    InputError,
    apply_skf,
    apply_skf_epochs,
    apply_skf_raw,
    make_skf_operator,
    read_skf_operator,
    read_skf_stream,
    write_skf_operator,
)
from skf_ref.io import _operator_file as operator_file

zarr = pytest.importorskip("zarr")


@pytest.fixture(scope="module")
def sample():
    """biosemi32 on a sphere, a 25 mm grid (free and fixed orientation), ten epochs."""
    montage = mne.channels.make_standard_montage("biosemi32")
    info = mne.create_info(montage.ch_names, 200.0, "eeg").set_montage(montage)
    sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    src = mne.setup_volume_source_space(sphere=sphere, pos=25.0, verbose=False)
    forward = mne.make_forward_solution(info, None, src, sphere, verbose=False)
    rng = np.random.default_rng(11)
    data = 1e-6 * rng.standard_normal((10, 32, 50))
    data += forward["sol"]["data"][:, [40]][None] * 1e-8 * np.hanning(50)
    epochs = mne.EpochsArray(data, info, tmin=-0.05, verbose=False)
    epochs.set_eeg_reference("average", projection=True, verbose=False)
    cov = mne.compute_covariance(epochs, verbose=False)
    return forward, epochs, cov


@pytest.mark.filterwarnings("ignore:tune. (pm|ep)_snr_db|tune. time_constant_ms")  # read or not
@pytest.mark.parametrize(
    "settings",
    [
        dict(),
        # a searched range is chosen on each data set, as "auto" is (fixed-auto): slow ones
        pytest.param(dict(pm_snr_db=(-30.0, 30.0)), marks=pytest.mark.slow),
        dict(ep_snr_db="auto", fixed=True),
        dict(time_constant_ms=15.0),
        pytest.param(
            dict(time_constant_ms=(2.0, 200.0), pm_snr_db="auto"), marks=pytest.mark.slow
        ),
    ],
    ids=["free", "range", "fixed-auto", "time-constant", "time-constant-range"],
)
def test_an_operator_read_gives_the_estimates_bit_for_bit(sample, tmp_path, settings):
    forward, epochs, cov = sample
    settings = dict(settings)
    if settings.pop("fixed", False):
        forward = mne.convert_forward_solution(forward, force_fixed=True, verbose=False)
    info = epochs.info.copy()
    info["bads"] = ["Oz"]
    written = make_skf_operator(info, forward, cov, verbose=False, **settings)
    path = write_skf_operator(tmp_path / "sample-skf.h5", written)
    read = read_skf_operator(path)
    assert repr(read) == repr(written) and read.dropped == {"bad": ["Oz"]}
    assert read.ch_names == written.ch_names and read.ch_types == written.ch_types
    assert mne.utils.object_diff(read.info, written.info) == ""
    np.testing.assert_array_equal(read.whitener, written.whitener)
    np.testing.assert_array_equal(read.leadfield, written.leadfield)
    evoked = epochs.average()
    evoked.info["bads"] = ["Oz"]
    for pick_ori in (None, "vector") if written.n_components == 3 else (None,):
        a = apply_skf(evoked, written, pick_ori=pick_ori)
        b = apply_skf(evoked, read, pick_ori=pick_ori)
        # the file holds the operator's arrays bit for bit, and the same calls run on them:
        # equal by construction (on one machine, as docs/mne.md promises)
        np.testing.assert_array_equal(a.data, b.data)
        assert type(a) is type(b) and a.subject == b.subject
        np.testing.assert_array_equal(a.vertices[0], b.vertices[0])
    for a, b in zip(
        apply_skf_epochs(epochs, written), apply_skf_epochs(epochs, read), strict=True
    ):
        np.testing.assert_array_equal(a.data, b.data)


def test_the_file_is_hdf5_without_pickles_and_versioned(sample, tmp_path):
    forward, epochs, cov = sample
    operator = make_skf_operator(epochs.info, forward, cov, verbose=False)
    path = write_skf_operator(tmp_path / "a-skf.h5", operator)
    with h5py.File(path, "r") as h5:
        group = h5["skf_ref"]
        names = set(group)
        assert {"key_format", "key_version", "key_whitener", "key_gain", "key_info"} <= names

        def no_pickle(name, item):
            kind = item.attrs.get("TITLE", b"")
            assert b"pickle" not in (kind if isinstance(kind, bytes) else kind.encode())

        group.visititems(no_pickle)
    with pytest.raises(InputError, match="a-skf.h5 exists: give overwrite=True"):
        write_skf_operator(path, operator)
    assert write_skf_operator(path, operator, overwrite=True) == path
    with pytest.raises(InputError, match=r"fname must end in .h5 .* got '.*a-skf.fif'"):
        write_skf_operator(tmp_path / "a-skf.fif", operator)
    with pytest.raises(InputError, match="the folder .*nodir does not exist"):
        write_skf_operator(tmp_path / "nodir" / "a-skf.h5", operator)
    with pytest.raises(InputError, match="operator must be an SKFOperator"):
        write_skf_operator(tmp_path / "b-skf.h5", forward)


def test_a_time_constant_is_held_in_place_of_the_ep_snr(sample, tmp_path):
    # format 2 for every operator (its digest); the evolution prior is one of the two fields
    forward, epochs, cov = sample
    for settings, field in (
        (dict(ep_snr_db=0.0), "ep_snr_db"),
        (dict(time_constant_ms=20.0), "time_constant_ms"),
        (dict(), "time_constant_ms"),  # the default: the AR(1) prior, "auto"
    ):
        operator = make_skf_operator(epochs.info, forward, cov, verbose=False, **settings)
        path = write_skf_operator(tmp_path / f"{field}-skf.h5", operator, overwrite=True)
        with h5py.File(path, "r") as h5:
            assert h5["skf_ref/key_version"][()] == 2
            assert ("key_time_constant_ms" in h5["skf_ref"]) == (field == "time_constant_ms")
            assert ("key_ep_snr_db" in h5["skf_ref"]) == (field == "ep_snr_db")
        read = read_skf_operator(path)
        assert (read.ep_snr_db, read.time_constant_ms) == (
            operator.ep_snr_db,
            operator.time_constant_ms,
        )


def test_a_file_of_a_later_version_or_another_kind_is_refused(sample, tmp_path, monkeypatch):
    forward, epochs, cov = sample
    operator = make_skf_operator(epochs.info, forward, cov, verbose=False)
    monkeypatch.setattr(operator_file, "OPERATOR_FORMAT_VERSION", 3)
    path = write_skf_operator(tmp_path / "new-skf.h5", operator)
    monkeypatch.undo()
    with pytest.raises(InputError, match=r"format version 3 .* reads versions up to 2: upgrade"):
        read_skf_operator(path)
    monkeypatch.undo()
    with h5py.File(tmp_path / "other.h5", "w") as h5:
        h5["data"] = np.zeros(3)
    with pytest.raises(InputError, match="other.h5 is not an SKF operator file"):
        read_skf_operator(tmp_path / "other.h5")
    with pytest.raises(InputError, match="none.h5: no such file"):
        read_skf_operator(tmp_path / "none.h5")


# --- streams ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def stream(sample, tmp_path_factory):
    forward, epochs, cov = sample
    raw = mne.io.RawArray(
        np.concatenate(list(epochs.get_data()), axis=1), epochs.info, verbose=False
    )
    operator = make_skf_operator(raw.info, forward, cov, verbose=False)
    folder = tmp_path_factory.mktemp("stream")
    whole = apply_skf_raw(raw, operator)
    vector = apply_skf_raw(raw, operator, pick_ori="vector")
    apply_skf_raw(raw, operator, out=folder / "run-skf.zarr")
    apply_skf_raw(raw, operator, pick_ori="vector", out=folder / "vector-skf.zarr")
    return folder, whole, vector


def test_a_stream_reads_back_as_the_estimate_over_any_span(stream):
    folder, whole, vector = stream
    stc = read_skf_stream(folder / "run-skf.zarr")
    assert type(stc) is type(whole) and stc.data.shape == whole.data.shape
    np.testing.assert_allclose(stc.data, whole.data, rtol=1e-12, atol=0)
    np.testing.assert_allclose(stc.times, whole.times)
    span = read_skf_stream(folder / "run-skf.zarr", tmin=0.5, tmax=1.25)
    cropped = whole.copy().crop(0.5, 1.25)
    assert span.data.shape == cropped.data.shape and span.tmin == pytest.approx(cropped.tmin)
    np.testing.assert_allclose(span.data, cropped.data, rtol=1e-12, atol=0)
    vec = read_skf_stream(zarr.open_group(folder / "vector-skf.zarr", mode="r"), tmax=0.1)
    assert isinstance(vec, mne.VolVectorSourceEstimate)
    np.testing.assert_allclose(vec.data, vector.copy().crop(None, 0.1).data, rtol=1e-12)


class _Counting(zarr.storage.WrapperStore):
    """A store that records the bytes of the array's chunks read (not their indexes)."""

    def __init__(self, store):
        super().__init__(store)
        self.chunk_bytes = 0

    async def get(self, key, prototype, byte_range=None):
        value = await self._store.get(key, prototype, byte_range)
        index = isinstance(byte_range, zarr.abc.store.SuffixByteRequest)
        if value is not None and "/c/" in key and not index:
            self.chunk_bytes += len(value)
        return value


def test_a_span_reads_only_its_chunks(sample, tmp_path):
    # a store long enough to be cut in time: 5 s of its 100 s read 2 of its 22 chunks of
    # time in each of its shards (blocks of positions), and nothing else
    forward, epochs, cov = sample
    rng = np.random.default_rng(0)
    data = 1e-6 * rng.standard_normal((32, 20000))
    raw = mne.io.RawArray(data - data.mean(axis=0), epochs.info, verbose=False)
    operator = make_skf_operator(raw.info, forward, cov, verbose=False)
    apply_skf_raw(raw, operator, out=tmp_path / "long-skf.zarr")
    counting = _Counting(zarr.storage.LocalStore(tmp_path / "long-skf.zarr", read_only=True))
    stc = read_skf_stream(zarr.open_group(counting, mode="r"), tmin=50.0, tmax=54.995)
    np.testing.assert_allclose(
        stc.data, read_skf_stream(tmp_path / "long-skf.zarr").data[:, 10000:11000], rtol=0, atol=0
    )
    array = zarr.open_group(tmp_path / "long-skf.zarr", mode="r")["data"]
    rows, times = array.chunks
    shards = -(-array.shape[0] // array.shards[0])
    first, last = 10000 // times, 10999 // times
    assert stc.data.shape[1] == 1000 and (first, last) == (10, 11) and shards == 2
    # each chunk is its values and its CRC-32C (4 bytes)
    assert counting.chunk_bytes == shards * (last - first + 1) * (rows * times * 8 + 4)
    assert counting.chunk_bytes < array.nbytes / 5


def test_what_is_not_an_estimates_store_is_refused(stream, tmp_path):
    folder, whole, vector = stream
    with pytest.raises(InputError, match=r"tmin must be <= tmax, got tmin=1 and tmax=0.5"):
        read_skf_stream(folder / "run-skf.zarr", tmin=1.0, tmax=0.5)
    with pytest.raises(InputError, match=r"tmax=99 s is outside the store's times, 0 to 2.495"):
        read_skf_stream(folder / "run-skf.zarr", tmax=99.0)
    with pytest.raises(InputError, match="nothing.zarr: no such zarr store"):
        read_skf_stream(tmp_path / "nothing.zarr")
    zarr.open_group(tmp_path / "other.zarr", mode="w").create_array("x", shape=(2,), dtype="f8")
    with pytest.raises(InputError, match="is not a complete source estimate store"):
        read_skf_stream(tmp_path / "other.zarr")
