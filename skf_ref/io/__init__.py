"""MNE-Python objects and files in, source estimates and files out.

- :mod:`.make_operator`: :func:`make_skf_operator`, the SKF prepared once for an info, a
  forward and a noise covariance (channels, reference and whitening done as MNE does);
  :mod:`.operator`: :class:`SKFOperator`, what it prepared, applied;
- :mod:`.apply`: :func:`apply_skf` on an ``mne.Evoked`` (with an operator, or a forward and
  a noise covariance in one call) and :func:`apply_skf_epochs`; :mod:`.raw`:
  :func:`apply_skf_raw` along a continuous recording; :mod:`.bids`: :func:`apply_skf_bids`,
  an estimate beside each evoked of MNE-BIDS-pipeline's derivatives;
- :mod:`.channels` and :mod:`.noise_cov`: the channels an operator uses, their reference,
  and the noise covariance it whitens with;
- :mod:`.operator_file`: operators saved and read (:func:`write_skf_operator`,
  :func:`read_skf_operator`); :mod:`.stream`: a store written by :func:`apply_skf_raw`
  read back as a source estimate over a span of time (:func:`read_skf_stream`);
- :mod:`.stc`: a reconstruction as an MNE source estimate;
- :mod:`.files`: lead fields and data from ``.npy``, ``.npz``, ``.mat``, ``.csv`` and MNE's
  ``.fif``; reconstructions written to ``.npz``, ``.stc``/``.h5``; :mod:`.variables`: the
  variables of ``.npz`` and ``.mat`` files, read when used; :mod:`.tables`: CSV layouts;
- :mod:`.zarr_dask`: outputs larger than memory, streamed to zarr or computed on Dask.

MNE-Python, zarr and Dask are optional (the extras ``mne``, ``zarr``, ``dask``): they load
when a function needs them. The names below (``__all__``) are the public API and load on
first use; the modules above are their implementation, whose paths may change.
"""

import importlib

_HOMES = {
    "LeadField": "files",
    "Recording": "files",
    "read_data": "files",
    "read_leadfield": "files",
    "read_variables": "variables",
    "write_reconstruction": "files",
    "write_stc": "files",
    "SKFOperator": "operator",
    "make_skf_operator": "make_operator",
    "read_skf_operator": "operator_file",
    "write_skf_operator": "operator_file",
    "read_skf_stream": "stream",
    "apply_skf": "apply",
    "apply_skf_epochs": "apply",
    "apply_skf_raw": "raw",
    "apply_skf_bids": "bids",
    "baseline_covariance": "noise_cov",
    "make_stc": "stc",
    "stc_to_zarr": "zarr_dask",
    "to_dask": "zarr_dask",
    "to_zarr": "zarr_dask",
}

__all__ = list(_HOMES)


def __getattr__(name):
    if name not in _HOMES:
        raise AttributeError(f"module 'skf_ref.io' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted({*globals(), *_HOMES})
