"""skf_ref: reference implementation of the Standardized Kalman Filter for EEG sources.

The model, its equations (numbered as in Prasikala et al. (2025), "The Effect of Prior
Parameters on Standardized Kalman Filter-Based EEG Source Localization", with the paper's
section: §2.2 for the filter, §2.3 for the smoother, §3.1 for the priors) and the study are
written out in docs/model.md. The original SKF is Lahtinen et al., Clin. Neurophysiol. 168
(2024).

The package in layers, each importing only those listed before it:

- ``skf_ref._utils``: private helpers (input checks, atomic files, memory, provenance,
  the log);
- :mod:`skf_ref.method`: the SKF itself in numpy, scipy and filterpy: :func:`reconstruct`,
  its three paths, the result type, the priors and their tuning, the standardization;
- :mod:`skf_ref.io`: MNE-Python objects and files: :func:`make_skf_operator` and
  :func:`apply_skf` (evoked), :func:`apply_skf_epochs`, :func:`apply_skf_raw`, source estimates,
  readers and writers, outputs larger than memory (MNE, zarr and Dask are optional);
- :mod:`skf_ref.conformance`: cross-checking another implementation: the cases,
  :func:`compare` and the catalogue of known mistakes;
- :mod:`skf_ref.study`: the paper's P20/N20 study: head models, the scenario, metrics,
  figures, sweeps, MNE's inverse methods beside the SKF, the demo;
- :mod:`skf_ref.cli`: the ``skf-ref`` command line.

``import skf_ref`` and a reconstruction import neither matplotlib, nor MNE, nor pandas.
Public names are loaded on first use. The module paths of 0.2 (``skf_ref.method.paths.dense``,
``skf_ref.method.tuning``, ...) still import, with a ``FutureWarning`` naming the new home.
"""

import importlib
import sys
import types

from ._utils.moved import install as _install_moved
from .version import __version__

# Public names and the module that defines each: imported on first use, so that importing a
# submodule (the command line's, say) does not load numpy, scipy and filterpy first.
_HOMES = {
    "InputError": "_utils.checks",
    "InputTypeError": "_utils.checks",
    "StandardizedKalmanFilter": "method.paths.filterpy_skf",
    "Reconstruction": "method.result",
    "reconstruct": "method.reconstruct",
    "tune": "method.tuning",
    "PAPER_SETTING": "method.settings",
    "RECOMMENDED_SETTING": "method.settings",
    "prior_variance": "method.priors",
    "evolution_variance": "method.priors",
    "lead_field_amplitude": "method.priors",
    "priors_from_snr": "method.priors",
    "apply_skf": "io.apply",
    "apply_skf_epochs": "io.apply",
    "apply_skf_raw": "io.raw",
    "make_skf_operator": "io.operator",
    "SKFOperator": "io.operator",
    "compare": "conformance.compare",
    "sys_info": "_utils.sys_info",
}

__all__ = [*_HOMES, "__version__"]


def __getattr__(name):
    if name not in _HOMES:
        raise AttributeError(f"module 'skf_ref' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted({*globals(), *_HOMES})


class _Package(types.ModuleType):
    """skf_ref's module type: a public function keeps its name when the old module path of
    the same name is imported (``skf_ref.tune`` is the function; ``from skf_ref.tune import
    tune``, the 0.2 path, binds nothing over it)."""

    def __setattr__(self, name, value):
        if name in _HOMES and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
_install_moved()
