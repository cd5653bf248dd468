"""skf_ref: reference implementation of the Standardized Kalman Filter for EEG sources.

The model, its equations (numbered as in Prasikala et al. (2025), "The Effect of Prior
Parameters on Standardized Kalman Filter-Based EEG Source Localization", with the paper's
section: §2.2 for the filter, §2.3 for the smoother, §3.1 for the priors) and the study are
written out in docs/model.md. The original SKF is Lahtinen et al., Clin. Neurophysiol. 168
(2024).

Two layers, and the arrows point one way:

- **the method**: :func:`reconstruct` and its paths (:mod:`skf_ref.dense`,
  :mod:`skf_ref.kalman`, :mod:`skf_ref.spectral`), the result type (:mod:`skf_ref.result`),
  the model (:mod:`skf_ref.model`), the priors (:mod:`skf_ref.priors`), the
  standardization (:mod:`skf_ref.standardization`), input checks (:mod:`skf_ref.checks`),
  memory, files and provenance, and the conformance cases with their comparison
  (:mod:`skf_ref.conformance`, :func:`compare`, :mod:`skf_ref.suspects`);
- **the study**: the head model (:mod:`skf_ref.head`), the P20/N20 scenario
  (:mod:`skf_ref.simulate`), regions and metrics (:mod:`skf_ref.regions`,
  :mod:`skf_ref.metrics`), figures (:mod:`skf_ref.plots`), sweeps (:mod:`skf_ref.sweep`)
  and the command line (:mod:`skf_ref.cli`).

The study imports the method, never the reverse: ``import skf_ref`` and a reconstruction
import neither matplotlib, nor a head model, nor pandas. Public names are loaded on first
use.
"""

import importlib

from .version import __version__

# Public names and the module that defines each: imported on first use, so that importing a
# submodule (the command line's, say) does not load numpy, scipy and filterpy first.
_HOMES = {
    "InputError": "checks",
    "InputTypeError": "checks",
    "StandardizedKalmanFilter": "kalman",
    "Reconstruction": "result",
    "reconstruct": "inverse",
    "PAPER_SETTING": "settings",
    "RECOMMENDED_SETTING": "settings",
    "apply_skf": "apply",
    "prior_variance": "priors",
    "evolution_variance": "priors",
    "lead_field_amplitude": "priors",
    "priors_from_snr": "priors",
    "compare": "comparison",
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
