"""Real recordings as MNE-Python objects, and the steps to make your own.

Median-nerve somatosensory evoked potentials (SEPs), the paradigm of the paper's simulated
study, recorded:

- :mod:`.fecnn`: three subjects' averages (73 channels, 10-10 labels), one of them (A0206)
  with its own FEM lead field: :func:`load_fecnn_evoked`, :func:`load_fecnn_forward`. The
  files are found, or downloaded on request, by :func:`data_path` (:mod:`.paths`).
- :mod:`.sep256`: an average of about 6000 stimuli on a 256-channel cap, from the package
  ``spharapy``: :func:`load_sep256_evoked`, and a forward on a sphere fitted to the cap
  (:func:`sphere_forward`).

The same steps for any evoked without its own forward or noise covariance:
:func:`forward_from_leadfield` (a lead field computed elsewhere, as an ``mne.Forward``),
:func:`sphere_forward` (a sphere fitted to the electrodes), :func:`baseline_noise_cov`
(the noise covariance from an average's pre-stimulus samples, in MNE's convention).
docs/real_data.md is the recipe; validation/report/real/REAL.md what the SKF and MNE's
methods make of these recordings.

MNE-Python (the extra ``mne``), ``spharapy`` and ``pooch`` (the extra ``datasets``) load
when a function needs them. The names below load on first use.
"""

import importlib

_HOMES = {
    "DATA_ENV": "paths",
    "FECNN_FILES": "paths",
    "data_path": "paths",
    "FECNN_SUBJECTS": "fecnn",
    "load_fecnn_evoked": "fecnn",
    "load_fecnn_forward": "fecnn",
    "load_sep256_evoked": "sep256",
    "baseline_noise_cov": "covariance",
    "forward_from_leadfield": "forward",
    "sphere_forward": "forward",
}

__all__ = list(_HOMES)


def __getattr__(name):
    if name not in _HOMES:
        raise AttributeError(f"module 'skf_ref.datasets' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted({*globals(), *_HOMES})
