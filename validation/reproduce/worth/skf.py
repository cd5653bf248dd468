"""The one place the study calls the SKF: a prepared model per priors and length, applied.

The study needs the SKF as a linear map on whitened data (noise standard deviation 1): a
spectral model prepared once per lead field, priors and number of samples
(:class:`skf_ref.method.SpectralModel`), applied to many data sets with each
setting's exponent, smoother and standardization.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Prepared"]


def _spectral_model():
    from skf_ref.method import SpectralModel

    return SpectralModel


_BASES = {}


def _basis(L):
    """The whitening and SVD of ``L`` with unit white noise, computed once per lead field."""
    from skf_ref.method import SpectralBasis

    key = (id(L), L.shape)
    if key not in _BASES:
        _BASES.clear()  # one lead field at a time: a process holds one head
        _BASES[key] = (L, SpectralBasis(L, np.eye(L.shape[0])))
    return _BASES[key][1]


class Prepared:
    """The SKF with fixed priors on a whitened lead field, for one number of samples.

    Parameters
    ----------
    L : ndarray, shape (n_channels, n_columns)
        Lead field in whitened units (white noise of standard deviation 1).
    priors : (float, float)
        (EP-SNR, PM-SNR) in dB, gain convention (``priors_from_snr``).
    n_times : int
    theta0, q : float, optional
        The priors themselves instead (``priors`` is then ignored).
    """

    def __init__(self, L, priors, n_times, theta0=None, q=None):
        from skf_ref.method import StateSpaceModel, priors_from_snr

        if theta0 is None:
            ep, pm = priors
            theta0, q = priors_from_snr(L, 1.0, pm, ep, n_times)
        model = StateSpaceModel.create(L, noise_std=1.0, theta0=theta0, q=q)
        self.L, self.n_times = L, n_times
        self.spectral = _spectral_model()(model, n_times, basis=_basis(L))

    def reconstruction(self, Y, setting):
        """The reconstruction of whitened data ``Y`` (n_channels, n_times) by ``setting``."""
        smoother = None if setting.smoother == "none" else setting.smoother
        kwargs = {}
        if setting.standardize != "column":
            kwargs = dict(standardize=setting.standardize, n_orient=3)
        return self.spectral.apply(Y, setting.exponent, smoother, **kwargs)

    def z(self, Y, setting):
        """The standardized estimate, shape (n_columns, n_times)."""
        return np.asarray(self.reconstruction(Y, setting).z)

    def state(self, Y, smooths):
        """The state estimate: the filtered means, or the RTS-smoothed state."""
        smoother = "rts-state" if smooths else None
        rec = self.spectral.apply(Y, 0.5, smoother)
        return np.asarray(rec.x if smooths else rec.x_filtered)
