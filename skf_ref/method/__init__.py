"""The method: the SKF's model, priors, paths and result, in numpy, scipy and filterpy.

The names below are the method's public API; the top level (``import skf_ref``) exports
the ones most scripts need. Its modules (leading underscore) are the implementation:

- ``_model``: the state-space model and its checks (docs/model.md §1);
- ``_priors``: PM-SNR and EP-SNR to ``theta0`` and ``q`` (§4), or PM-SNR and a time constant
  to the stationary AR(1) prior's ``theta0``, ``q`` and transition; ``_tuning`` and
  ``_discrepancy``: priors chosen by the data;
- ``_standardization``: the standardization weights, the one home of eq. (7);
- ``_paths``: the three computational paths: ``dense`` (the readable statement of the
  algorithm, one equation a line), ``filterpy_skf`` (a subclass of filterpy's
  ``KalmanFilter``) and ``spectral`` (exact and fast for isotropic priors, with
  ``singular_basis``, ``recursions``, ``weights``, ``tiles`` and ``spectral_rows``);
  docs/model.md §9 says why they agree;
- ``_settings``: the recommended setting and the paper's, and the one check of a run's
  settings; ``_reconstruct``: the entry point that checks once and picks a path;
- ``_result``: the result type every path returns; ``_outputs``: the names of its outputs
  and what computes them on demand.

It imports nothing from the layers above it (MNE objects and files, the cross-check tools,
the study, the command line). Names load on first use.
"""

from .._utils.lazy import attach

#: Public name -> the module that defines it.
_HOMES = {
    "PAPER_SETTING": "_settings",
    "RECOMMENDED_SETTING": "_settings",
    "Reconstruction": "_result",
    "SpectralBasis": "_paths.singular_basis",
    "SpectralModel": "_paths.spectral",
    "StandardizedKalmanFilter": "_paths.filterpy_skf",
    "StateSpaceModel": "_model",
    "TuneResult": "_tuning",
    "amplitude_from_components": "_result",
    "ar1_priors": "_priors",
    "evolution_variance": "_priors",
    "lead_field_amplitude": "_priors",
    "prior_variance": "_priors",
    "priors_from_snr": "_priors",
    "reconstruct": "_reconstruct",
    "tune": "_tuning",
}

#: Names the top level exports (``skf_ref.reconstruct``): declared there, reachable here
#: too, since the layers above import the method's names from this package.
_AT_THE_TOP = {
    "PAPER_SETTING",
    "RECOMMENDED_SETTING",
    "Reconstruction",
    "StandardizedKalmanFilter",
    "ar1_priors",
    "evolution_variance",
    "lead_field_amplitude",
    "prior_variance",
    "priors_from_snr",
    "reconstruct",
    "tune",
}

__all__ = sorted(set(_HOMES) - _AT_THE_TOP)
__getattr__, __dir__ = attach(__name__, _HOMES)
