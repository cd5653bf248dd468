"""skf_ref: reference implementation of the Standardized Kalman Filter for EEG sources.

Equations and numbering follow shared/SKF_SPEC.md, i.e. Prasikala et al. (2025), "The Effect
of Prior Parameters on Standardized Kalman Filter-Based EEG Source Localization", and
Lahtinen et al., Clin. Neurophysiol. 168 (2024).
"""

from .kalman import StandardizedKalmanFilter
from .priors import evolution_variance, lead_field_amplitude, prior_variance, priors_from_snr
from .reconstruct import reconstruct
from .result import Reconstruction

__version__ = "0.1.0"

__all__ = [
    "StandardizedKalmanFilter",
    "Reconstruction",
    "reconstruct",
    "prior_variance",
    "evolution_variance",
    "lead_field_amplitude",
    "priors_from_snr",
]
