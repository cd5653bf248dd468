"""The methods run data set by data set: LCMV, irMxNE and the priors chosen by the data.

LCMV depends on each run's data covariance, irMxNE is not linear, and priors tuned on each
data set make every method depend on it: these run on simulated data sets (in volts) built
from the same sources and noise pools as the linear study (:mod:`.measure`), and are
measured by :func:`measure_run` with the same definitions.
"""

from __future__ import annotations

import warnings
from types import SimpleNamespace

import numpy as np

from skf_ref.study.resolution import level_db, peak_errors, position_amplitudes, spatial_dispersion

from .measure import REGION_MM
from .sets import PEAK_MOMENT

__all__ = [
    "LCMV_REG",
    "discrepancy_lambda2",
    "irmxne",
    "lcmv",
    "measure_run",
    "minimum_norm_amplitude",
    "run_data",
]

#: LCMV's regularization (fraction of the data covariance's mean eigenvalue).
LCMV_REG = 0.05
#: irMxNE's reweighting iterations and depth (MNE's default depth).
IRMXNE_ITERATIONS = 10
IRMXNE_DEPTH = 0.9
#: lambda2 chosen by the discrepancy principle is rounded to this grid (dB of lambda2).
LAMBDA2_GRID_DB = 0.5
#: The range searched for lambda2 (dB of lambda2).
LAMBDA2_RANGE_DB = (-80.0, 40.0)


def run_data(head, sim_parts, sigma, noise):
    """A data set as the MNE objects need it: ``Y`` (V), times, its noise covariance.

    Parameters
    ----------
    head : HeadModel
    sim_parts : list of (gain, waveform)
        Each source's field (n_channels,) at unit moment and its waveform (A m).
    sigma : float
        Noise standard deviation (V).
    noise : ndarray, shape (n_channels, n_times)
        A unit noise draw.
    """
    Y = sigma * np.asarray(noise, dtype=float)
    for gain, wave in sim_parts:
        Y = Y + np.outer(gain, wave)
    n = head.n_channels
    times = np.arange(Y.shape[1]) / 1e4
    return SimpleNamespace(Y=Y, times=times, noise_cov=sigma**2 * np.eye(n), sigma=sigma)


def measure_run(amplitude, geometry, points, samples, deep_wave):
    """One run's readings from its amplitude (n_positions, n_times).

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_times)
    geometry : Geometry
    points : (ndarray or None, ndarray or None)
        The thalamic and the cortical source's exact point (None: absent).
    samples : (int, int)
        Thalamic and cortical peak samples.
    deep_wave : ndarray, shape (n_times,)

    Returns
    -------
    dict
        ``level``, ``ratio_db``, ``active`` (any thalamic activity at t_d), ``deep_error_mm``,
        ``superficial_error_mm``, ``deep_r``, ``dispersion_mm`` (of the present source), and
        ``deep_in_thalamus`` / ``superficial_in_thalamus`` (where each present source's
        maximum lies).
    """
    t_d, t_c = samples
    at_d = amplitude[:, t_d : t_d + 1]
    out = dict(
        level=float(at_d[geometry.thalamus].max()),
        ratio_db=float(level_db(at_d, geometry.thalamus)[0]),
        active=bool(at_d[geometry.thalamus].max() > 0),
        deep_error_mm=np.nan,
        superficial_error_mm=np.nan,
        deep_r=np.nan,
        dispersion_mm=np.nan,
    )
    deep, superficial = points
    if deep is not None:
        error, peak = peak_errors(at_d, geometry.positions, deep[None])
        out["deep_error_mm"] = float(error[0])
        out["deep_in_thalamus"] = bool(geometry.thalamus[peak[0]])
        out["dispersion_mm"] = float(spatial_dispersion(at_d, geometry.positions, deep[None])[0])
        region = np.linalg.norm(geometry.positions - deep, axis=1) * 1e3 <= REGION_MM + 1e-9
        course = amplitude[region].max(axis=0)
        if np.ptp(course) > 0:
            out["deep_r"] = float(np.corrcoef(course, np.abs(deep_wave))[0, 1])
    if superficial is not None:
        at_c = amplitude[:, t_c : t_c + 1]
        error, peak = peak_errors(at_c, geometry.positions, superficial[None])
        out["superficial_error_mm"] = float(error[0])
        out["superficial_in_thalamus"] = bool(geometry.thalamus[peak[0]])
        if deep is None:
            out["dispersion_mm"] = float(
                spatial_dispersion(at_c, geometry.positions, superficial[None])[0]
            )
    return out


def lcmv(head, sim):
    """LCMV's amplitude (n_positions, n_times): unit-noise-gain, free orientation."""
    import mne
    from mne.beamformer import apply_lcmv, make_lcmv

    from skf_ref.study.baselines import amplitude_on_positions, mne_data

    evoked, cov = mne_data(head, sim)
    second_moment = sim.Y @ sim.Y.T / sim.Y.shape[1]
    data_cov = mne.Covariance(
        second_moment, evoked.info.ch_names, [], [], sim.Y.shape[1], verbose=False
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        filters = make_lcmv(
            evoked.info, head.fwd, data_cov, reg=LCMV_REG, noise_cov=cov, pick_ori=None,
            weight_norm="unit-noise-gain", rank="info", verbose=False,
        )  # fmt: skip
        stc = apply_lcmv(evoked, filters, verbose=False)
    return amplitude_on_positions(stc, head)


def irmxne(head, sim, alpha):
    """irMxNE's amplitude (n_positions, n_times) and whitened residual ratio.

    ``mixed_norm`` with :data:`IRMXNE_ITERATIONS` reweightings; the ratio is
    ``||residual / sigma||_F^2 / (rank * n_times)``, rank = n_channels - 1 (average
    reference): 1 where the fit leaves the noise's expected energy.
    """
    from mne.inverse_sparse import mixed_norm

    from skf_ref.study.baselines import amplitude_on_positions, mne_data

    evoked, cov = mne_data(head, sim)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        stc, residual = mixed_norm(
            evoked, head.fwd, cov, alpha=alpha, loose=1.0, depth=IRMXNE_DEPTH,
            n_mxne_iter=IRMXNE_ITERATIONS, return_residual=True, verbose=False,
        )  # fmt: skip
    n, T = sim.Y.shape
    ratio = float(np.sum((residual.data / sim.sigma) ** 2) / ((n - 1) * T))
    if stc is None or (isinstance(stc, list) and not stc):
        return np.zeros((head.n_positions, T)), ratio
    return amplitude_on_positions(stc, head), ratio


def discrepancy_lambda2(L, Y, sigma):
    """MNE's lambda2 by the discrepancy principle on the minimum-norm fit (white noise).

    Whitened and average referenced (rank r = n - 1), the minimum norm's fitted data are
    ``U diag(s^2 / (s^2 + lambda2)) U^T y~`` with ``U s V^T`` the SVD of the whitened gain
    scaled as MNE scales it (squared Frobenius norm r); the residual energy
    ``sum_k (lambda2 / (s_k^2 + lambda2))^2 |eta_k|^2 + |y~_perp|^2`` rises with lambda2 and
    is set equal to ``r * n_times``.

    Returns
    -------
    lambda2 : float
        Rounded to :data:`LAMBDA2_GRID_DB`.
    bound : str or None
        ``"lower"`` / ``"upper"`` when the root lies outside :data:`LAMBDA2_RANGE_DB`.
    """
    from scipy.optimize import brentq

    n, T = Y.shape
    P = np.eye(n) - 1.0 / n
    lam, vectors = np.linalg.eigh(P)
    W = vectors[:, lam > 0.5].T / sigma  # the whitener on the average reference's range
    G, y = W @ L, W @ Y
    r = G.shape[0]
    G = G * np.sqrt(r / np.sum(G**2))
    U, s, _ = np.linalg.svd(G, full_matrices=False)
    eta = U.T @ y
    outside = np.sum(y**2) - np.sum(eta**2)

    def excess(db):
        lambda2 = 10.0 ** (db / 10.0)
        shrink = lambda2 / (s**2 + lambda2)
        return float(np.sum(shrink[:, None] ** 2 * eta**2) + outside - r * T)

    low, high = LAMBDA2_RANGE_DB
    if excess(low) >= 0:
        db, bound = low, "lower"
    elif excess(high) <= 0:
        db, bound = high, "upper"
    else:
        db, bound = brentq(excess, low, high, xtol=1e-6), None
    return 10.0 ** (np.round(db / LAMBDA2_GRID_DB) * LAMBDA2_GRID_DB / 10.0), bound


def minimum_norm_amplitude(K, Y, sigma):
    """A minimum-norm kernel (on whitened data) applied to ``Y`` (V): the amplitude."""
    return position_amplitudes(K @ (np.asarray(Y) / sigma), 3)


def lone_parts(gain, wave):
    """The (gain, waveform in A m) list of a lone source of unit-peak waveform."""
    return [(gain, PEAK_MOMENT * wave)]
