"""Conformance cases: small fixed problems and the dense path's answers, for any language.

The names below (``__all__``) are the public API; the modules (leading underscore) are
their implementation, whose paths may change.

A lab that writes the SKF in MATLAB, C++, Julia or on a GPU runs these cases and compares
its outputs with :func:`skf_ref.compare` (``skf-ref compare``). Each case is a few channels,
sources and steps, generated once from a fixed seed. The suite is pinned and versioned
(:data:`CONFORMANCE_VERSION`): its files are part of the package with their sha256 in
``manifest.json`` (:mod:`skf_ref.conformance._suite`), :func:`cases` reads them and
:func:`export` copies them, byte for byte, with a runner for MATLAB/Octave and one for
Python. docs/conformance.md describes the files for those who run them.

Every case file holds these, in MNE-Python's layout (docs/model.md §1):

=====================  =======================  =============================================
variable               shape                    meaning
=====================  =======================  =============================================
``L``                  (n_channels, n_sources)  lead field
``Y``                  (n_channels, n_times)    data; column ``t`` is ``y_t``
``noise_cov``          scalar or (m, m)         ``R``; a scalar ``c`` means ``c I`` (a variance)
``theta0``             scalar or (n, n)         ``P_0``; a scalar ``c`` means ``c I``
``q``                  scalar or (n, n)         ``Q``; a scalar ``c`` means ``c I``
``transition``         scalar or (n, n)         ``A``; a scalar ``c`` means ``c I``
``exponent``           scalar                   alpha of §2.2 eq. (7)
``smoother``           text                     ``"none"``, ``"rts-standardized"`` or
                                                ``"rts-state"`` (docs/model.md §3)
``z`` ...              (n_sources, n_times)     expected ``z``, ``z_filtered``, ``x``,
                                                ``x_filtered``, ``weights``
``log_likelihood``     scalar                   expected innovation log-likelihood
``case`` ...           text, scalars            ``case``, ``description``, ``exercises``,
                                                ``conformance_version``, ``tolerance``,
                                                ``skf_ref_version``
=====================  =======================  =============================================

Some cases hold more. The prior cases: ``pm_snr_db``, ``ep_snr_db``, ``convention`` and
``noise_std``, of which ``theta0`` and ``q`` are :func:`skf_ref.priors_from_snr` with
``n_steps = n_times`` (``noise_cov = noise_std**2``). The toolbox cases also
``Y_unscaled`` and ``data_scale``: ``Y = Y_unscaled / data_scale`` with
``data_scale = max|Y_unscaled|``, and ``noise_std`` is relative to it. The
average-referenced case: ``L_unreferenced``, of which ``L`` is each column minus its mean
over the channels.
"""

from ._case_files import read_case, write_case
from ._cases import CONFORMANCE_VERSION, FLOAT32_TOLERANCE, TOLERANCE, Case
from ._suite import build, cases, export, manifest, verify

__all__ = [
    "CONFORMANCE_VERSION",
    "FLOAT32_TOLERANCE",
    "TOLERANCE",
    "Case",
    "build",
    "cases",
    "export",
    "manifest",
    "read_case",
    "verify",
    "write_case",
]
