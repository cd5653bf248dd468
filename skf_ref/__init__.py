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
  memory, files and provenance;
- **the study**: the head model (:mod:`skf_ref.head`), the P20/N20 scenario
  (:mod:`skf_ref.simulate`), regions and metrics (:mod:`skf_ref.regions`,
  :mod:`skf_ref.metrics`), figures (:mod:`skf_ref.plots`), sweeps (:mod:`skf_ref.sweep`)
  and the command line (:mod:`skf_ref.cli`).

The study imports the method, never the reverse: ``import skf_ref`` and a reconstruction
import neither matplotlib, nor a head model, nor pandas.
"""

from .checks import InputError, InputTypeError
from .inverse import reconstruct
from .kalman import StandardizedKalmanFilter
from .priors import evolution_variance, lead_field_amplitude, prior_variance, priors_from_snr
from .result import Reconstruction
from .version import __version__

__all__ = [
    "InputError",
    "InputTypeError",
    "StandardizedKalmanFilter",
    "Reconstruction",
    "reconstruct",
    "prior_variance",
    "evolution_variance",
    "lead_field_amplitude",
    "priors_from_snr",
    "__version__",
]
