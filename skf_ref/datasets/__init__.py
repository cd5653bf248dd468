"""Real recordings as MNE-Python objects, and the steps to make your own.

Median-nerve somatosensory evoked potentials (SEPs), the paradigm of the paper's simulated
study, recorded:

- the feCNN repository's three subjects' averages (73 channels, 10-10 labels), one of them
  (A0206) with its own FEM lead field: :func:`load_fecnn_evoked`, :func:`load_fecnn_forward`.
  The files are found, or downloaded on request, by :func:`data_path`;
- an average of about 6000 stimuli on a 256-channel cap, from the package ``spharapy``:
  :func:`load_sep256_evoked`, and a forward on a sphere fitted to the cap
  (:func:`sphere_forward`).

The same steps for any evoked without its own forward or noise covariance:
:func:`forward_from_leadfield` (a lead field computed elsewhere, as an ``mne.Forward``),
:func:`sphere_forward` (a sphere fitted to the electrodes), :func:`baseline_noise_cov`
(the noise covariance from an average's pre-stimulus samples, in MNE's convention).
docs/real_data.md is the recipe; validation/report/real/REAL.md what the SKF and MNE's
methods make of these recordings. The modules of this package are its implementation;
the names below (``__all__``) are its API.

MNE-Python (the extra ``mne``), ``spharapy`` and ``pooch`` (the extra ``datasets``) load
when a function needs them.
"""

from ._covariance import baseline_noise_cov
from ._fecnn import load_fecnn_evoked, load_fecnn_forward
from ._forward import forward_from_leadfield, sphere_forward
from ._paths import data_path
from ._sep256 import load_sep256_evoked

__all__ = [
    "baseline_noise_cov",
    "data_path",
    "forward_from_leadfield",
    "load_fecnn_evoked",
    "load_fecnn_forward",
    "load_sep256_evoked",
    "sphere_forward",
]
