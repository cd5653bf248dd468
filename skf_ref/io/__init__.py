"""MNE-Python objects and files in, source estimates and files out.

- :func:`~skf_ref.make_skf_operator`: the SKF prepared once for an info, a forward and a
  noise covariance (channels, reference and whitening done as MNE does), an
  :class:`~skf_ref.SKFOperator`, applied to an ``mne.Evoked`` (:func:`~skf_ref.apply_skf`, which
  also takes a forward and a noise covariance in one call), to epochs
  (:func:`~skf_ref.apply_skf_epochs`) or along a continuous recording
  (:func:`~skf_ref.apply_skf_raw`); an estimate beside each evoked of MNE-BIDS-pipeline's
  derivatives (:func:`~skf_ref.apply_skf_bids`); the noise covariance from an evoked's
  baseline (:func:`baseline_covariance`);
- operators saved and read (:func:`~skf_ref.write_skf_operator`,
  :func:`~skf_ref.read_skf_operator`); a store written by :func:`~skf_ref.apply_skf_raw`
  read back as a source estimate over a span of time (:func:`~skf_ref.read_skf_stream`);
- a reconstruction as an MNE source estimate (:func:`make_stc`);
- lead fields and data from ``.npy``, ``.npz``, ``.mat``, ``.csv`` and MNE's ``.fif``
  (:func:`read_leadfield`, :func:`read_data`, :func:`read_variables`); reconstructions
  written to ``.npz``, ``.stc``/``.h5`` (:func:`write_reconstruction`, :func:`write_stc`);
- outputs larger than memory, streamed to zarr or computed on Dask (:func:`to_zarr`,
  :func:`to_dask`, :func:`stc_to_zarr`).

The top level exports the first two groups (``skf_ref.apply_skf``); this package declares
the rest. MNE-Python, zarr and Dask are optional (the extras ``mne``, ``zarr``, ``dask``):
they load when a function needs them. Names load on first use; the modules (leading
underscore) are the implementation, whose paths may change.
"""

from .._utils.lazy import attach

_HOMES = {
    "LeadField": "_files",
    "Recording": "_files",
    "read_data": "_files",
    "read_leadfield": "_files",
    "read_variables": "_variables",
    "write_reconstruction": "_files",
    "write_stc": "_files",
    "SKFOperator": "_operator",
    "make_skf_operator": "_make_operator",
    "read_skf_operator": "_operator_file",
    "write_skf_operator": "_operator_file",
    "read_skf_stream": "_stream",
    "apply_skf": "_apply",
    "apply_skf_epochs": "_apply",
    "apply_skf_raw": "_raw",
    "apply_skf_bids": "_bids",
    "baseline_covariance": "_noise_cov",
    "make_stc": "_stc",
    "stc_to_zarr": "_zarr_dask",
    "to_dask": "_zarr_dask",
    "to_zarr": "_zarr_dask",
}

#: Names the top level exports (``skf_ref.apply_skf``): declared there, reachable here.
_AT_THE_TOP = {
    "SKFOperator",
    "apply_skf",
    "apply_skf_bids",
    "apply_skf_epochs",
    "apply_skf_raw",
    "make_skf_operator",
    "read_skf_operator",
    "read_skf_stream",
    "write_skf_operator",
}

__all__ = [name for name in _HOMES if name not in _AT_THE_TOP]

__getattr__, __dir__ = attach(__name__, _HOMES)
