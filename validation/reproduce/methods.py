"""Every method of the study on one condition and design, as amplitude maps.

Each method maps sensor data ``Y`` (n_channels, n_times) to amplitudes (n_positions,
n_times): the norm of each position's three components. The SKF runs on the whitened data
and lead field with unit noise (the package's spectral path, priors in the gain convention);
MNE's methods take the covariance themselves.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np

from .design import IRMXNE_ALPHA, LCMV_REG, PM_SNR_DB


def _norms(z):
    return np.linalg.norm(np.asarray(z).reshape(-1, 3, z.shape[-1]), axis=1)


class SKF:
    """The SKF on a condition's whitened lead field for one design's length and rate."""

    def __init__(self, condition, design):
        from skf_ref.method import SpectralBasis

        self.Lw, self.W = condition.Lw, condition.W
        self.design = design
        self.basis = SpectralBasis(self.Lw, np.eye(self.Lw.shape[0]))
        self._models = {}

    def model(self, kind, value, n_times=None):
        """The spectral model of a prior (``("walk", ep_db)`` or ``("ar", tau_ms)``)."""
        from skf_ref.method import SpectralModel, StateSpaceModel, ar1_priors, priors_from_snr

        n_times = self.design.n_times if n_times is None else n_times
        key = (kind, value, n_times)
        if key not in self._models:
            if kind == "walk":
                theta0, q = priors_from_snr(self.Lw, 1.0, PM_SNR_DB, value, n_times)
                a = 1.0
            else:
                theta0, q, a = ar1_priors(self.Lw, 1.0, PM_SNR_DB, value, self.design.sfreq)
            model = StateSpaceModel.create(
                self.Lw, noise_std=1.0, theta0=theta0, q=q, transition=a
            )
            if len(self._models) > 8:
                self._models.clear()
            self._models[key] = SpectralModel(model, n_times, basis=self.basis)
        return self._models[key]

    def time_constant(self, Yw):
        """The time constant (ms) of largest marginal likelihood, and whether on a bound."""
        from skf_ref import tune

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = tune(
                self.Lw, Yw, noise_std=1.0, pm_snr_db=PM_SNR_DB, time_constant_ms="auto",
                sfreq=self.design.sfreq,
            )  # fmt: skip
        return float(result.time_constant_ms), bool(result.at_bound) or bool(caught)

    def amplitudes(self, Y, settings):
        """``{setting: amplitudes}`` for sensor data ``Y``, and the chosen time constant."""
        Yw = self.W @ Y
        tau = bound = None
        out = {}
        for setting in settings:
            kind, value = setting.prior()
            if value == "auto":
                if tau is None:
                    tau, bound = self.time_constant(Yw)
                value = tau
            out[setting] = self.apply(self.model(kind, value), Yw, setting)
        return out, tau, bound

    @staticmethod
    def apply(model, Yw, setting):
        """A setting's amplitudes from a prepared model."""
        smoother = None if setting.smoother == "none" else setting.smoother
        kwargs = (
            {} if setting.standardize == "column" else dict(standardize="position", n_orient=3)
        )
        return model.apply(Yw, setting.exponent, smoother, **kwargs).amplitude(3)

    def memoryless_kernel(self, setting):
        """Each step alone (T = 1 priors): the linear map of one whitened sample, (3N, rank)."""
        model = self.model("walk", 0.0, n_times=1)
        smoother = None
        kwargs = (
            {} if setting.standardize == "column" else dict(standardize="position", n_orient=3)
        )
        r = self.Lw.shape[0]
        return np.column_stack(
            [
                np.asarray(model.apply(e[:, None], setting.exponent, smoother, **kwargs).z)[:, 0]
                for e in np.eye(r)
            ]
        )

    def window(self, setting, tau_ms, direction):
        """The setting's effective window along a whitened direction, (n_times, n_times)."""
        kind, value = setting.prior()
        model = self.model(kind, tau_ms if value == "auto" else value)
        smooths = setting.smoother != "none"
        u = direction / np.linalg.norm(direction)
        T = self.design.n_times
        h = np.empty((T, T))
        for tau in range(T):
            Yw = np.zeros((len(u), T))
            Yw[:, tau] = u
            rec = model.apply(Yw, 0.5, "rts-state" if smooths else None)
            x = np.asarray(rec.x if smooths else rec.x_filtered)
            h[:, tau] = u @ (self.Lw @ x)
        return h / h.sum(axis=1, keepdims=True)


def _evoked(condition, Y, sfreq, tmin):
    import mne

    return mne.EvokedArray(Y, condition.info.copy(), tmin=tmin, verbose=False)


@functools.lru_cache(maxsize=16)
def _kernel(condition, method, lambda2):
    from mne.minimum_norm import apply_inverse, prepare_inverse_operator

    n = condition.n_channels
    evoked = _evoked(condition, np.eye(n), 1000.0, 0.0)
    inverse = _inverse(condition)
    inverse = prepare_inverse_operator(inverse, 1, lambda2, method, verbose=False)
    stc = apply_inverse(
        evoked, inverse, lambda2, method, pick_ori="vector", prepared=True, verbose=False
    )
    return np.asarray(stc.data).reshape(-1, n)


@functools.lru_cache(maxsize=2)
def _inverse(condition):
    from mne.minimum_norm import make_inverse_operator

    return make_inverse_operator(
        condition.info, condition.fwd, condition.cov, loose=1.0, depth=None,
        rank=condition.rank_arg, verbose=False,
    )  # fmt: skip


def matched_lambda2(condition):
    """MNE's lambda2 equal to the SKF's PM-SNR: ``10^(-PM/10) rank / n_channels``."""
    return 10.0 ** (-PM_SNR_DB / 10.0) * condition.rank / condition.n_channels


def lambda2_of(condition, label):
    """``"1/9"`` or ``"matched"`` as a number."""
    return 1.0 / 9.0 if label == "1/9" else matched_lambda2(condition)


def minimum_norm(condition, method, label, Y):
    """MNE's ``method`` at lambda2 ``label`` (its kernel, computed once by ``apply_inverse``)."""
    return _norms(_kernel(condition, method, lambda2_of(condition, label)) @ Y)


def lcmv(condition, Y, design):
    """MNE's LCMV: free orientation, unit-noise-gain, the data set's own data covariance."""
    import mne
    from mne.beamformer import apply_lcmv, make_lcmv

    evoked = _evoked(condition, Y, design.sfreq, design.tmin)
    centred = Y - Y.mean(axis=1, keepdims=True)
    data_cov = mne.Covariance(
        centred @ centred.T / Y.shape[1], condition.info.ch_names, bads=[], projs=[],
        nfree=Y.shape[1], verbose=False,
    )  # fmt: skip
    filters = make_lcmv(
        condition.info, condition.fwd, data_cov, reg=LCMV_REG, noise_cov=condition.cov,
        pick_ori="vector", weight_norm="unit-noise-gain", rank="info", verbose=False,
    )  # fmt: skip
    stc = apply_lcmv(evoked, filters, verbose=False)
    return _norms(np.asarray(stc.data).reshape(-1, Y.shape[1]))


def irmxne(condition, Y, design):
    """MNE's irMxNE (``mixed_norm``, 10 reweightings, alpha 25 % of alpha_max)."""
    from mne.inverse_sparse import mixed_norm

    from skf_ref.study._baselines import amplitude_on_positions

    evoked = _evoked(condition, Y, design.sfreq, design.tmin)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        stc = mixed_norm(
            evoked, condition.fwd, condition.cov, alpha=IRMXNE_ALPHA, loose=1.0, depth=0.9,
            n_mxne_iter=10, rank=condition.rank_arg, verbose=False,
        )  # fmt: skip
    return amplitude_on_positions(stc, condition.head)
