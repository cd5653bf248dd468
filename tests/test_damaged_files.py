"""A damaged or hand-made file is refused, naming it and what is wrong (issue 44).

An operator file carries the sha256 of its fields and every field is checked, alone and
against the others (items 3, 11); a stream store carries a checksum per chunk, a missing
chunk is an error and never an estimate of zeros, and every attribute the reader uses is
checked (items 1, 2, 10, 12).
"""

import shutil
from pathlib import Path

import h5io
import h5py
import mne
import numpy as np
import pytest

from skf_ref import (
    InputError,
    apply_skf,
    apply_skf_raw,
    make_skf_operator,
    read_skf_operator,
    read_skf_stream,
    write_skf_operator,
)
from skf_ref.io import _operator_file as operator_file
from skf_ref.io import _zarr_dask as zarr_dask

zarr = pytest.importorskip("zarr")


@pytest.fixture(scope="module")
def sample():
    """biosemi16 on a sphere, a 40 mm grid, ten epochs of noise and a source."""
    montage = mne.channels.make_standard_montage("biosemi16")
    info = mne.create_info(montage.ch_names, 200.0, "eeg").set_montage(montage)
    sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    src = mne.setup_volume_source_space(sphere=sphere, pos=40.0, verbose=False)
    forward = mne.make_forward_solution(info, None, src, sphere, verbose=False)
    rng = np.random.default_rng(4)
    data = 1e-6 * rng.standard_normal((10, 16, 40))
    data += forward["sol"]["data"][:, [10]][None] * 1e-8 * np.hanning(40)
    epochs = mne.EpochsArray(data, info, tmin=-0.05, verbose=False)
    epochs.set_eeg_reference("average", projection=True, verbose=False)
    operator = make_skf_operator(epochs.info, forward, noise_std=1e-6, verbose=False)
    return operator, epochs


@pytest.fixture(scope="module")
def written_once(sample, tmp_path_factory):
    return write_skf_operator(tmp_path_factory.mktemp("operator") / "op-skf.h5", sample[0])


@pytest.fixture
def written(written_once, tmp_path):
    """A copy of the operator's file for each test to damage (written once: 0.3 s a write)."""
    return Path(shutil.copy(written_once, tmp_path / "op-skf.h5"))


def _content(path):
    return h5io.read_hdf5(path, title="skf_ref", slash="replace")


def _rewrite(path, content, digest=True):
    """The file with ``content``, its digest made anew (a file made by hand, consistently)."""
    content = dict(content)
    if digest:
        content.pop("sha256", None)
        h5io.write_hdf5(path, content, overwrite=True, title="skf_ref", slash="replace")
        content["sha256"] = operator_file.content_digest(_content(path))
    h5io.write_hdf5(path, content, overwrite=True, title="skf_ref", slash="replace")
    return path


# --- operators (items 3, 11) --------------------------------------------------------------


def test_an_operator_file_with_changed_bytes_is_refused(sample, written):
    # item 3: 64 bytes of the gain changed gave an estimate 0.2 relative off, accepted
    operator, epochs = sample
    with h5py.File(written, "r+") as h5:
        gain = h5["skf_ref"]["key_gain"]
        values = gain[...]
        values.flat[:8] *= 3.0
        gain[...] = values
    match = r"op-skf.h5: its contents are not those written \(their sha256 differs .*\): "
    with pytest.raises(InputError, match=match + "the file was changed or damaged"):
        read_skf_operator(written)


@pytest.mark.parametrize("field", ["ch_names", "pm_snr_db", "info", "forward_fif", "sha256"])
def test_any_field_changed_breaks_the_digest(sample, written, field):
    content = _content(written)
    change = {
        "ch_names": lambda c: c[::-1],
        "pm_snr_db": lambda c: c + 1.0,
        "info": lambda c: {**c, "sfreq": 201.0},
        "forward_fif": lambda c: np.concatenate([c[:-1], [c[-1] ^ 1]]).astype(np.uint8),
        "sha256": lambda c: "0" * 64,
    }[field]
    content[field] = change(content[field])
    _rewrite(written, content, digest=False)
    with pytest.raises(InputError, match=r"sha256 differs from the one stored"):
        read_skf_operator(written)
    del content["sha256"]
    _rewrite(written, content, digest=False)
    with pytest.raises(InputError, match=r"format version 2 holds its sha256, and this one has "
                       "none: the file is damaged"):  # fmt: skip
        read_skf_operator(written)


# one field of each kind of check in the default run; the others of a kind are slow ones
SLOW = pytest.mark.slow


@pytest.mark.parametrize(
    "change, match",
    [
        (lambda c: c.pop("gain"), r"it lacks gain: the file is damaged"),
        pytest.param(lambda c: c.pop("whitener"),
                     r"it lacks whitener", marks=SLOW),
        pytest.param(lambda c: c.pop("ch_names"),
                     r"it lacks ch_names", marks=SLOW),
        (lambda c: c.update(whitener=c["whitener"][:, :-1]),
         r"whitener has shape \(15, 15\), expected \(rank, 16\)"),
        pytest.param(lambda c: c.update(whitener=c["whitener"][:0]),
                     r"whitener has shape \(0, 16\)", marks=SLOW),
        pytest.param(lambda c: c.update(gain=c["gain"][:-1]),
                     r"gain has shape \(15, \d+\), expected \(16,", marks=SLOW),
        pytest.param(lambda c: c.update(gain=c["gain"].astype(np.float32)),
                     r"gain must be a float64 matrix", marks=SLOW),
        (lambda c: c.update(gain=np.full_like(c["gain"], np.nan)), r"gain is not finite"),
        (lambda c: c.update(ch_names=c["ch_names"][::-1]),
         r"ch_names \(16: \['O2', 'Oz', 'O1'\] ...\) are not the channels of its info in order "
         r"\(16: \['Fp1', 'Fp2', 'F4'\] ...\)"),
        (lambda c: c.update(ch_names=[*c["ch_names"][:-1], c["ch_names"][0]]),
         r"ch_names must name each channel once"),
        pytest.param(lambda c: c.update(ch_names="Fp1"),
                     r"ch_names must be a list of channel names", marks=SLOW),
        (lambda c: c.update(fixed="no"), r"fixed must be True or False"),
        pytest.param(lambda c: c.update(fixed=True),
                     r"its forward has a lead field of shape", marks=SLOW),
        (lambda c: c.update(dropped=["Oz"]), r"dropped must map reasons to channel names"),
        (lambda c: c.update(info={"sfreq": "x"}), r"its info is not an mne.Info"),
        (lambda c: c.update(forward_fif=np.zeros(10, np.uint8)),
         r"its forward_fif is not a forward MNE reads"),
        (lambda c: c.update(pm_snr_db="loud"), r"pm_snr_db must be a number \(dB\), 'auto'"),
    ],
)  # fmt: skip
def test_every_field_is_checked_alone_and_against_the_others(written, change, match):
    # item 11: a file lacking a field raised KeyError, a short whitener numpy's matmul
    # message, and ch_names reversed against the info was accepted (channels misordered)
    content = _content(written)
    change(content)
    _rewrite(written, content)  # a consistent digest: only the checks of the fields remain
    with pytest.raises(InputError, match=r"op-skf.h5: .*" + match):
        read_skf_operator(written)


def test_a_version_1_file_is_read_with_a_warning(sample, written):
    # skf_ref 0.3.0 wrote format version 1, without a digest: still read, every field
    # checked; the warning says a change cannot be detected
    operator, epochs = sample
    content = _content(written)
    del content["sha256"]
    content["version"] = 1
    _rewrite(written, content, digest=False)
    with pytest.warns(UserWarning, match=r"format version 1, written without a digest .* "
                      r"cannot be detected; write the operator again"):  # fmt: skip
        read = read_skf_operator(written)
    evoked = epochs.average()
    # the file holds the operator's arrays bit for bit: the same calls on them, by construction
    np.testing.assert_array_equal(apply_skf(evoked, read).data, apply_skf(evoked, operator).data)
    content["ch_names"] = content["ch_names"][::-1]
    _rewrite(written, content, digest=False)
    with pytest.warns(UserWarning), pytest.raises(InputError, match="not the channels of its"):
        read_skf_operator(written)


# --- streams (items 1, 2, 10, 12) ----------------------------------------------------------


@pytest.fixture(scope="module")
def raw(sample):
    operator, epochs = sample
    data = np.concatenate(list(epochs.get_data()), axis=1)
    return mne.io.RawArray(data, epochs.info, verbose=False), operator


def _store(raw, folder, name="run-skf.zarr", **kwargs):
    recording, operator = raw
    apply_skf_raw(recording, operator, out=folder / name, **kwargs)
    return folder / name


def _shards(store):
    return sorted(p for p in (store / "data" / "c").rglob("*") if p.is_file())


def test_a_missing_shard_is_an_error_never_zeros(raw, tmp_path):
    # item 1: a shard file deleted was read as zarr's fill value, zeros: "no activity"
    store = _store(raw, tmp_path)
    whole = read_skf_stream(store)
    (shard,) = _shards(store)
    shard.unlink()
    with pytest.raises(InputError, match=r"run-skf.zarr: the file data/c/0/0 \(positions 0-\d+, "
                       r"samples 0-399\) is missing: the store is incomplete"):  # fmt: skip
        read_skf_stream(store, tmin=0.5, tmax=1.0)
    # zarr itself reads a missing chunk as NaN, no estimate, in a store of this package
    array = zarr.open_group(store, mode="r")["data"]
    assert np.isnan(array[:]).all() and whole.data.shape == array.shape


@pytest.mark.parametrize("damage", ["changed", "cut short"])
def test_a_damaged_chunk_is_named_with_its_store(raw, tmp_path, damage):
    # item 2: 8 bytes changed read back as other finite values (-0.96 for 4.43); item 12:
    # a shard cut short gave zarr's bare "Stored and computed checksum do not match"
    store = _store(raw, tmp_path)
    (shard,) = _shards(store)
    data = bytearray(shard.read_bytes())
    if damage == "changed":
        data[1000:1008] = bytes(8)
    else:
        data = data[:-100]
    shard.write_bytes(bytes(data))
    match = (r"run-skf.zarr: the chunk of positions 0-\d+, samples 0-399 in the file "
             r"data/c/0/0 is damaged: its checksum does not match its bytes \(the file was "
             r"changed or cut short\)")  # fmt: skip
    with pytest.raises(InputError, match=match):
        read_skf_stream(store)
    with pytest.raises(InputError, match=r"the store .*run-skf.zarr: the chunk of"):
        read_skf_stream(zarr.open_group(store, mode="r"))


def test_a_vector_store_is_checked_too(raw, tmp_path):
    store = _store(raw, tmp_path, name="v-skf.zarr", pick_ori="vector")
    assert read_skf_stream(store).data.shape[1] == 3
    (shard,) = _shards(store)
    shard.write_bytes(shard.read_bytes()[:-1])
    with pytest.raises(InputError, match=r"v-skf.zarr: the chunk of .* is damaged: its checksum"):
        read_skf_stream(store, tmax=0.1)


def test_a_store_written_without_checksums_is_still_read(raw, tmp_path, monkeypatch):
    # stores written before the checksums: the same numbers; a missing shard is an error
    monkeypatch.setattr(zarr_dask, "_checked_chunks", lambda: dict(compressors=None))
    old = _store(raw, tmp_path, name="old-skf.zarr")
    monkeypatch.undo()
    new = _store(raw, tmp_path)
    # the same computation written twice, only the chunks' codec differs: equal by construction
    np.testing.assert_array_equal(read_skf_stream(old).data, read_skf_stream(new).data)
    _shards(old)[0].unlink()
    with pytest.raises(InputError, match=r"old-skf.zarr: the file data/c/0/0 .* is missing"):
        read_skf_stream(old)


def _set_attributes(store, **change):
    import json

    meta_file = store / "zarr.json"
    meta = json.loads(meta_file.read_text())
    for key, value in change.items():
        if value is _DELETE:
            del meta["attributes"][key]
        else:
            meta["attributes"][key] = value
    meta_file.write_text(json.dumps(meta))


_DELETE = object()


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(tstep=0), r"its tstep must be finite and > 0, got 0"),
        (dict(tstep=-0.005), r"its tstep must be finite and > 0, got -0.005"),
        (dict(tstep="0.005"), r"its tstep must be a number of seconds, got '0.005' \(str\)"),
        (dict(tmin=_DELETE), r"it lacks the attribute\(s\) tmin"),
        (dict(tmin=float("nan")), r"its tmin must be finite, got nan"),
        (dict(vertices=_DELETE), r"it lacks the attribute\(s\) vertices"),
        (dict(stc_class="Evoked"), r"it names an unknown source estimate class 'Evoked'"),
        (dict(stc_class="VolVectorSourceEstimate"),
         r"its array 'data' is float64 of shape \(\d+, 400\); its vertices and class "
         r"\(VolVectorSourceEstimate\) ask float64 of shape \(\d+, 3, n_times\)"),
        (dict(stc_class="SourceEstimate"), r"its vertices do not make an SourceEstimate"),
        (dict(vertices=[[0, 1]]), r"its array 'data' is float64 of shape \(\d+, 400\); its"),
        (dict(vertices=[[2, 1]]), r"its vertices must be increasing numbers >= 0"),
        (dict(vertices="all"), r"its vertices must be lists of integers, got 'all'"),
        (dict(subject=3), r"its subject must be a name or null, got 3 \(int\)"),
    ],
)  # fmt: skip
def test_every_attribute_the_reader_uses_is_checked(raw, tmp_path, change, match):
    # item 10: tstep 0 raised ZeroDivisionError, a store without tmin KeyError
    store = _store(raw, tmp_path)
    _set_attributes(store, **change)
    with pytest.raises(InputError, match=r"run-skf.zarr: " + match):
        read_skf_stream(store, tmin=0.1)
