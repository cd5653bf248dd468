"""A source estimate streamed to disk, read back as an MNE source estimate over a span.

:func:`skf_ref.apply_skf_raw` with ``out=`` writes the estimate of a recording of any
length to a zarr store (:func:`skf_ref.io.zarr_dask.stc_to_zarr`): its array ``"data"``
holds what the source estimate would, one shard per block of positions, cut along time
into chunks; its attributes hold the vertices, ``tmin``, ``tstep``, the subject and the
class of MNE's estimate. :func:`read_skf_stream` reads the samples of a span of time
only (the chunks that hold them), and makes the MNE source estimate of that span.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .._utils.checks import InputError, InputTypeError, check_real, describe
from .._utils.extras import optional
from .stc import STC_CLASSES
from .zarr_dask import STORE_MARK

__all__ = ["read_skf_stream"]


def _open(store: Any) -> Any:
    """The zarr group of ``store`` (a path or a group), checked to be an estimate's store."""
    zarr = optional("zarr", "zarr", "read_skf_stream")
    if isinstance(store, zarr.Group):
        group, name = store, "the store"
    else:
        if not isinstance(store, (str, Path)):
            raise InputTypeError(
                f"fname must be a path or a zarr group (apply_skf_raw(out=...) returns one), "
                f"got {describe(store)}"
            )
        path = Path(store)
        if not path.is_dir():
            raise InputError(f"{path}: no such zarr store (a folder written by apply_skf_raw)")
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
    return group


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

    Examples
    --------
    Read one second of a long recording's estimate::

        store = skf_ref.apply_skf_raw(raw, operator, out="run1-skf.zarr")
        stc = skf_ref.read_skf_stream("run1-skf.zarr", tmin=60.0, tmax=61.0)
    """
    mne = optional("mne", "mne", "read_skf_stream")
    group = _open(fname)
    attrs = group.attrs
    data = group["data"]
    class_name = attrs["stc_class"]
    if class_name not in STC_CLASSES:
        raise InputError(f"the store names an unknown source estimate class {class_name!r}")
    start, step = float(attrs["tmin"]), float(attrs["tstep"])
    samples = _span((start, step, data.shape[-1]), tmin, tmax)
    values = np.asarray(data[..., samples], dtype=np.float64)
    vertices = [np.asarray(v, dtype=np.int64) for v in attrs["vertices"]]
    return getattr(mne, class_name)(
        values,
        vertices=vertices,
        tmin=start + samples.start * step,
        tstep=step,
        subject=attrs.get("subject"),
    )
