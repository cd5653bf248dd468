"""A source estimate streamed to disk, read back as an MNE source estimate over a span.

:func:`skf_ref.apply_skf_raw` with ``out=`` writes the estimate of a recording of any
length to a zarr store (:func:`skf_ref.io._zarr_dask.stc_to_zarr`): its array ``"data"``
holds what the source estimate would, one shard per block of positions, cut along time
into chunks; its attributes hold the vertices, ``tmin``, ``tstep``, the subject and the
class of MNE's estimate. :func:`read_skf_stream` reads the samples of a span of time
only (the chunks that hold them), and makes the MNE source estimate of that span.

What it reads is checked: every attribute it uses (a class MNE has, finite times with a
positive step, vertices that count the rows), each chunk against its CRC-32C checksum
(written with it since skf_ref 0.4.0's issue 44: a byte changed, a file cut short is an
error naming the store and the chunk), and that every shard file the span needs exists (a
missing one would read as the fill value, an estimate of nothing). A store written
before the checksums is still read, with the same checks but the checksum's.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from .._utils.checks import InputError, InputTypeError, check_real, describe
from .._utils.extras import optional
from ._stc import STC_CLASSES
from ._zarr_dask import STORE_MARK

__all__ = ["read_skf_stream"]


def _open(store: Any) -> tuple[Any, str]:
    """The zarr group of ``store`` (a path or a group), checked to be an estimate's store,
    and how messages name it."""
    zarr = optional("zarr", "zarr", "read_skf_stream")
    if isinstance(store, zarr.Group):
        group, name = store, f"the store {_group_name(store)}"
    else:
        if not isinstance(store, (str, Path)):
            raise InputTypeError(
                f"fname must be a path or a zarr group (apply_skf_raw(out=...) returns one), "
                f"got {describe(store)}"
            )
        path = Path(store)
        if not path.is_dir():
            what = "no such zarr store" if not os.path.lexists(path) else "not a zarr store"
            raise InputError(f"{path}: {what} (a folder written by apply_skf_raw)")
        try:
            group = zarr.open_group(path, mode="r")
        except Exception as err:  # zarr's own errors for a folder that is no store
            raise InputError(f"{path} is not a zarr store: {err}") from err
        name = str(path)
    attrs = group.attrs
    if attrs.get(STORE_MARK) != "complete" or "stc_class" not in attrs or "data" not in group:
        raise InputError(
            f"{name} is not a complete source estimate store written by skf_ref "
            "(apply_skf_raw(out=...) or skf_ref.io.stc_to_zarr)"
        )
    return group, name


def _group_name(group: Any) -> str:
    """A zarr group's store, as a user would name it (its folder, for a local store)."""
    root = getattr(group.store, "root", None)
    return str(root) if root is not None else str(group.store)


def _span(times: tuple[float, float, int], tmin: Any, tmax: Any) -> slice:
    """The samples from the one nearest ``tmin`` to the one nearest ``tmax``, inclusive."""
    start, step, n_times = times
    stop = start + (n_times - 1) * step
    first = 0 if tmin is None else round((check_real("tmin", tmin) - start) / step)
    last = n_times - 1 if tmax is None else round((check_real("tmax", tmax) - start) / step)
    if tmin is not None and tmax is not None and tmin > tmax:
        raise InputError(f"tmin must be <= tmax, got tmin={tmin:g} and tmax={tmax:g}")
    for name, index, value in (("tmin", first, tmin), ("tmax", last, tmax)):
        if not 0 <= index < n_times:
            raise InputError(
                f"{name}={value:g} s is outside the store's times, {start:g} to {stop:g} s"
            )
    return slice(first, last + 1)


def read_skf_stream(fname: Any, tmin: float | None = None, tmax: float | None = None) -> Any:
    """The MNE source estimate of a store written by ``apply_skf_raw(out=...)``, over a span.

    Only the chunks holding the samples from ``tmin`` to ``tmax`` are read: the span of a
    recording whose estimate does not fit in memory is read as quickly as its size allows.
    Each chunk read is checked against its checksum, and a chunk whose file is missing is
    an error: a damaged store is never read as other numbers, nor as zeros.

    Parameters
    ----------
    fname : path-like or zarr.Group
        The store (a folder), or the group ``apply_skf_raw`` returned.
    tmin, tmax : float, optional
        Seconds, as the estimate's times: the samples nearest to them and those between
        are read (as MNE's ``crop``, both included). Default: from the first sample, to the
        last.

    Returns
    -------
    mne.SourceEstimate or mne.VolSourceEstimate or mne.MixedSourceEstimate or vector kin
        The class, vertices and subject of the estimate the store holds; data (n_positions,
        n_samples), or (n_positions, 3, n_samples) for ``pick_ori="vector"``.

    Raises
    ------
    skf_ref.InputError
        Not a complete store of this package; an attribute missing or out of range; a
        chunk whose checksum does not match, or whose file is missing (naming the store
        and the chunk); ``tmin`` or ``tmax`` outside the store's times.

    Examples
    --------
    Read one second of a long recording's estimate::

        store = skf_ref.apply_skf_raw(raw, operator, out="run1-skf.zarr")
        stc = skf_ref.read_skf_stream("run1-skf.zarr", tmin=60.0, tmax=61.0)
    """
    mne = optional("mne", "mne", "read_skf_stream")
    group, name = _open(fname)
    data = group["data"]
    stored = _attributes(group.attrs, data, name)
    start, step = stored["tmin"], stored["tstep"]
    samples = _span((start, step, data.shape[-1]), tmin, tmax)
    _check_chunks_stored(data, samples, name)
    values = _read(data, samples, name)
    try:
        return getattr(mne, stored["stc_class"])(
            values,
            vertices=stored["vertices"],
            tmin=start + samples.start * step,
            tstep=step,
            subject=stored["subject"],
        )
    except ValueError as err:  # MNE's own check of vertices against its class
        raise InputError(
            f"{name}: its vertices do not make an {stored['stc_class']} ({err}): the store is "
            "damaged"
        ) from err


def _damaged(name: str, what: str) -> InputError:
    return InputError(f"{name}: {what}: the store is damaged (not as apply_skf_raw writes it)")


def _attributes(attrs: Any, data: Any, name: str) -> dict[str, Any]:
    """Every attribute :func:`read_skf_stream` uses, checked against each other and the
    array's shape."""
    stored: dict[str, Any] = {}
    missing = [key for key in ("tmin", "tstep", "vertices", "stc_class") if key not in attrs]
    if missing:
        raise _damaged(name, f"it lacks the attribute(s) {', '.join(missing)}")
    class_name = attrs["stc_class"]
    if class_name not in STC_CLASSES:
        raise _damaged(name, f"it names an unknown source estimate class {class_name!r}")
    stored["stc_class"] = class_name
    for key in ("tmin", "tstep"):
        value = attrs[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _damaged(name, f"its {key} must be a number of seconds, got {describe(value)}")
        if not np.isfinite(value) or (key == "tstep" and not value > 0):
            must = "finite" if key == "tmin" else "finite and > 0"
            raise _damaged(name, f"its {key} must be {must}, got {value!r}")
        stored[key] = float(value)
    vertices = attrs["vertices"]
    if not isinstance(vertices, list) or not all(
        isinstance(v, list) and all(isinstance(i, int) and not isinstance(i, bool) for i in v)
        for v in vertices
    ):
        raise _damaged(name, f"its vertices must be lists of integers, got {describe(vertices)}")
    stored["vertices"] = [np.asarray(v, dtype=np.int64) for v in vertices]
    if any(len(v) and (v.min() < 0 or np.any(np.diff(v) <= 0)) for v in stored["vertices"]):
        raise _damaged(name, "its vertices must be increasing numbers >= 0 in each source space")
    subject = attrs.get("subject")
    if subject is not None and not isinstance(subject, str):
        raise _damaged(name, f"its subject must be a name or null, got {describe(subject)}")
    stored["subject"] = subject
    n_positions = sum(len(v) for v in stored["vertices"])
    vector = "Vector" in class_name
    shape = (n_positions, 3, "n_times") if vector else (n_positions, "n_times")
    if (
        data.dtype != np.float64
        or data.ndim != len(shape)
        or data.shape[0] != n_positions
        or (vector and data.shape[1] != 3)
        or data.shape[-1] < 1
    ):
        raise _damaged(
            name,
            f"its array 'data' is {data.dtype} of shape {data.shape}; its vertices and class "
            f"({class_name}) ask float64 of shape {shape}".replace("'n_times'", "n_times"),
        )
    return stored


def _grid(data: Any) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """The shape of a shard (a file) and of a chunk of ``data``."""
    chunks = tuple(data.chunks)
    shards = getattr(data, "shards", None)
    return (tuple(shards) if shards is not None else chunks), chunks


def _key(data: Any, coords: tuple[int, ...]) -> str:
    """The store's key of the file of the shard (or chunk) at grid ``coords``."""
    key = data.metadata.encode_chunk_key(coords)
    return f"{data.path}/{key}" if data.path else key


def _where(data: Any, start: tuple[int, ...], size: tuple[int, ...]) -> str:
    """Positions and samples of the block of ``data`` at ``start`` (in words)."""
    rows = f"positions {start[0]}-{min(start[0] + size[0], data.shape[0]) - 1}"
    last = min(start[-1] + size[-1], data.shape[-1]) - 1
    return f"{rows}, samples {start[-1]}-{last}"


def _check_chunks_stored(data: Any, samples: slice, name: str) -> None:
    """Refuse a span whose shard files are not all in the store: zarr would read a missing
    one as its fill value (zeros, in stores written before NaN was), silently."""
    from zarr.core.sync import sync

    shard, _ = _grid(data)
    times = range(samples.start // shard[-1], (samples.stop - 1) // shard[-1] + 1)
    for row in range(-(-data.shape[0] // shard[0])):
        for time in times:
            coords = (row, *(0,) * (data.ndim - 2), time)
            key = _key(data, coords)
            if not sync(data.store.exists(key)):
                start = tuple(c * s for c, s in zip(coords, shard, strict=True))
                raise InputError(
                    f"{name}: the file {key} ({_where(data, start, shard)}) is missing: the "
                    "store is incomplete (a file deleted, or not copied); its estimate is "
                    "unknown there, and never read as zeros"
                )


def _read(data: Any, samples: slice, name: str) -> np.ndarray:
    """``data[..., samples]``; a chunk that fails its checksum (or cannot be decoded) is
    found and named."""
    try:
        return np.asarray(data[..., samples], dtype=np.float64)
    except Exception as err:  # zarr's errors for damaged bytes: find the chunk, name it
        cause = err
    shard, chunk = _grid(data)
    first, last = samples.start // chunk[-1], (samples.stop - 1) // chunk[-1]
    for row in range(0, data.shape[0], chunk[0]):
        for time in range(first * chunk[-1], (last + 1) * chunk[-1], chunk[-1]):
            try:
                data[row : row + chunk[0], ..., time : time + chunk[-1]]
            except Exception as err:
                coords = (row // shard[0], *(0,) * (data.ndim - 2), time // shard[-1])
                raise InputError(
                    f"{name}: the chunk of {_where(data, (row, time), chunk)} in the file "
                    f"{_key(data, coords)} is damaged: {_checksum_words(err)}"
                ) from err
    raise InputError(f"{name}: its array 'data' cannot be read: {cause}") from cause


def _checksum_words(err: Exception) -> str:
    if "checksum" in str(err).lower():
        return "its checksum does not match its bytes (the file was changed or cut short)"
    return f"zarr cannot decode it ({type(err).__name__}: {err})"
