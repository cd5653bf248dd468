"""skf_ref: reference implementation of the Standardized Kalman Filter for EEG sources.

The model, its equations (numbered as in Prasikala et al. (2025), "The Effect of Prior
Parameters on Standardized Kalman Filter-Based EEG Source Localization", with the paper's
section: §2.2 for the filter, §2.3 for the smoother, §3.1 for the priors) and the study are
written out in docs/model.md. The original SKF is Lahtinen et al., Clin. Neurophysiol. 168
(2024).

The package in layers, each importing only those listed before it:

- ``skf_ref._utils``: private helpers (input checks, memory, provenance, the log, names
  loaded on first use);
- :mod:`skf_ref.method`: the SKF itself in numpy, scipy and filterpy: :func:`reconstruct`,
  its three paths, the result type, the priors and their tuning, the standardization;
- :mod:`skf_ref.io`: MNE-Python objects and files: :func:`make_skf_operator` and
  :func:`apply_skf` (evoked), :func:`apply_skf_epochs`, :func:`apply_skf_raw`, source estimates,
  readers and writers, MNE-BIDS-pipeline's derivatives (:func:`apply_skf_bids`), outputs
  larger than memory (MNE, zarr and Dask are optional);
- :mod:`skf_ref.conformance`: cross-checking another implementation: the cases,
  :func:`compare` and the catalogue of known mistakes;
- :mod:`skf_ref.datasets`: real median-nerve SEP recordings as MNE objects (evoked, forward,
  noise covariance), and the same steps for a user's own recording;
- :mod:`skf_ref.study`: the paper's P20/N20 study: head models, the scenario, metrics,
  figures, sweeps, MNE's inverse methods beside the SKF, the demo;
- :mod:`skf_ref.cli`: the ``skf-ref`` command line.

The public API is what these packages declare in ``__all__`` (docs/api.rst lists it); a
module whose name starts with an underscore, and the modules that the ``io``,
``conformance`` and ``cli`` packages list as their implementation, may change without
notice. ``import skf_ref`` and a reconstruction import neither matplotlib, nor MNE, nor
pandas: names load on first use.
"""

from ._utils.lazy import attach
from ._version import __version__

#: Public name -> the module that defines or declares it.
_HOMES = {
    "InputError": "_utils.checks",
    "InputTypeError": "_utils.checks",
    "PAPER_SETTING": "method",
    "RECOMMENDED_SETTING": "method",
    "Reconstruction": "method",
    "StandardizedKalmanFilter": "method",
    "ar1_priors": "method",
    "evolution_variance": "method",
    "lead_field_amplitude": "method",
    "prior_variance": "method",
    "priors_from_snr": "method",
    "reconstruct": "method",
    "tune": "method",
    "SKFOperator": "io",
    "apply_skf": "io",
    "apply_skf_epochs": "io",
    "apply_skf_raw": "io",
    "apply_skf_bids": "io",
    "make_skf_operator": "io",
    "read_skf_operator": "io",
    "read_skf_stream": "io",
    "write_skf_operator": "io",
    "compare": "conformance._compare",
    "sys_info": "_utils.sys_info",
}

__all__ = [*_HOMES, "__version__"]
__getattr__, __dir__ = attach(__name__, _HOMES)
