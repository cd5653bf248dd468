"""The conformance cases' definitions: each case's inputs, from its own seed.

Each builder takes a generator seeded with ``(11, seed)`` and returns the case's inputs (and
extras); :func:`skf_ref.conformance._cases.generate` computes the expected outputs. A
changed builder is a new suite version (:data:`~skf_ref.conformance.CONFORMANCE_VERSION`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..method import ar1_priors, priors_from_snr

__all__ = ["N_TIMES", "SPECS"]

#: Steps of most cases: a transposed output shows in its shape, except in ``square``.
N_TIMES = 7
#: Every case: (name, seed, description, what it exercises, builder), in the suite's order.
SPECS: list[tuple[str, int, str, tuple[str, ...], Callable[..., dict[str, Any]]]] = []


def _case(name, seed, description, *exercises):
    """Register a case builder: ``rng -> {input or extra name: value}``."""

    def register(builder):
        SPECS.append((name, seed, description, exercises, builder))
        return builder

    return register


def _data(rng, L, noise, scale=1.0, n_times=N_TIMES):
    """``L X + noise e`` with ``X`` a random walk (the model's own prior) times ``scale``."""
    X = scale * np.cumsum(rng.standard_normal((L.shape[1], n_times)), axis=1)
    return L @ X + noise @ rng.standard_normal((L.shape[0], n_times))


def _spd(rng, n, scale, floor):
    """A random symmetric positive definite matrix, eigenvalues above ``scale * floor``."""
    B = rng.standard_normal((n, n))
    return scale * (B @ B.T / n + floor * np.eye(n))


@_case("original_skf", 1, "The original SKF of Lahtinen et al. (2024).", "fixed orientation")
def _original_skf(rng):
    L = rng.standard_normal((6, 4))
    Y = _data(rng, L, 0.2 * np.eye(6))
    return dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.5, exponent=0.5, smoother=None)


@_case(
    "free_orientation",
    2,
    "Three positions of three columns each; every column is standardized on its own.",
    "free orientation (3 columns per position, MNE's order)",
)
def _free_orientation(rng):
    L = rng.standard_normal((6, 9))
    Y = _data(rng, L, 0.2 * np.eye(6))
    return dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.25, exponent=1.0, smoother=None)


@_case(
    "average_reference",
    3,
    "L and Y average referenced (rank n_channels - 1); L_unreferenced is L before it.",
    "average-referenced, rank-deficient lead field",
)
def _average_reference(rng):
    L_unreferenced = rng.standard_normal((6, 8)) + 1.0
    Y = _data(rng, L_unreferenced, 0.2 * np.eye(6))
    L, Y = L_unreferenced - L_unreferenced.mean(axis=0), Y - Y.mean(axis=0)
    inputs = dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.5, exponent=1.25)
    return inputs | dict(smoother="rts-standardized", L_unreferenced=L_unreferenced)


@_case("full_noise_cov", 4, "A full noise covariance R.")
def _full_noise_cov(rng):
    L = rng.standard_normal((6, 5))
    R = _spd(rng, 6, 0.02, 0.5)
    Y = _data(rng, L, np.linalg.cholesky(R))
    return dict(L=L, Y=Y, noise_cov=R, theta0=2.0, q=0.3, exponent=1.5, smoother="rts-state")


@_case("transition", 5, "A = 0.8 I instead of the random walk.")
def _transition(rng):
    L = rng.standard_normal((6, 5))
    Y = _data(rng, L, 0.2 * np.eye(6))
    inputs = dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.4, transition=0.8)
    return inputs | dict(exponent=1.25, smoother="rts-state")


@_case(
    "general_model",
    6,
    "Full matrices A, P_0 and Q: the general linear-Gaussian model (not the spectral path's).",
)
def _general_model(rng):
    L = rng.standard_normal((5, 4))
    R = _spd(rng, 5, 0.05, 0.5)
    Y = _data(rng, L, np.linalg.cholesky(R))
    A = 0.9 * np.eye(4) + 0.05 * rng.standard_normal((4, 4))
    theta0, q = _spd(rng, 4, 1.0, 0.5), _spd(rng, 4, 0.3, 0.2)
    inputs = dict(L=L, Y=Y, noise_cov=R, theta0=theta0, q=q, transition=A)
    return inputs | dict(exponent=1.0, smoother="rts-standardized")


def _priors(rng, convention, pm_snr_db, signal):
    """A lead field of order 1e2 and data of order 1e-6 (SI units), priors from the SNRs."""
    L = 100.0 * rng.standard_normal((6, 6))
    sigma = 1e-7
    Y = _data(rng, L, sigma * np.eye(6), scale=signal)
    extras = {}
    if convention == "toolbox":  # the toolbox divides the data by their maximum first
        scale = float(np.max(np.abs(Y)))
        extras = dict(data_scale=scale, Y_unscaled=Y)
        Y, sigma = Y / scale, sigma / scale
    theta0, q = priors_from_snr(L, sigma, pm_snr_db, 20.0, N_TIMES, convention)
    snrs = dict(pm_snr_db=float(pm_snr_db), ep_snr_db=20.0, convention=convention)
    return dict(L=L, Y=Y, noise_cov=sigma**2, theta0=theta0, q=q, noise_std=sigma) | snrs | extras


@_case(
    "priors_gain",
    7,
    "The paper's setting with the unit-free amplitude (docs/model.md §4).",
    "priors from PM-SNR 0 dB, EP-SNR 20 dB, gain convention",
)
def _priors_gain(rng):
    return _priors(rng, "gain", 0.0, 1e-8) | dict(exponent=1.25, smoother="rts-standardized")


@_case(
    "priors_toolbox",
    8,
    "The paper's setting as the toolbox computes it (docs/model.md §4).",
    "priors from PM-SNR 0 dB, EP-SNR 20 dB, toolbox convention",
    "toolbox data scaling (Y / max|Y|, noise_std relative to it)",
)
def _priors_toolbox(rng):
    return _priors(rng, "toolbox", 0.0, 1e-8) | dict(exponent=1.25, smoother="rts-standardized")


@_case(
    "priors_toolbox_clamped",
    9,
    "PM-SNR 20 dB on data of about 10 dB SNR: the toolbox lowers it to SNR - 1 dB.",
    "toolbox convention with PM-SNR clamped to SNR - 1 dB",
    "toolbox data scaling (Y / max|Y|, noise_std relative to it)",
)
def _priors_toolbox_clamped(rng):
    return _priors(rng, "toolbox", 20.0, 2e-10) | dict(exponent=0.5, smoother=None)


@_case(
    "diagonal_transition",
    10,
    "A = diag(1, 0.5, 0.9, 1, 0.7): diagonal but not a multiple of the identity; a code that "
    "takes any diagonal A for the identity passes every other case.",
    "diagonal transition, not a multiple of the identity",
)
def _diagonal_transition(rng):
    L = rng.standard_normal((6, 5))
    Y = _data(rng, L, 0.2 * np.eye(6))
    A = np.diag([1.0, 0.5, 0.9, 1.0, 0.7])
    inputs = dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.4, transition=A)
    return inputs | dict(exponent=1.5, smoother="rts-standardized")


@_case(
    "square",
    11,
    "As many sources as time steps: a transposed output keeps its shape, only its values show it.",
    "n_sources == n_times",
)
def _square(rng):
    L = rng.standard_normal((5, N_TIMES))
    Y = _data(rng, L, 0.2 * np.eye(5))
    return dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.3, exponent=0.75, smoother="rts-state")


@_case(
    "steady_state",
    12,
    "300 steps: the covariances reach the filter's steady state (the weights constant to "
    "rounding after about 30 steps) and stay there.",
    "long run to the steady state (300 steps)",
)
def _steady_state(rng):
    L = rng.standard_normal((4, 3))
    Y = _data(rng, L, 0.3 * np.eye(4), n_times=300)
    return dict(L=L, Y=Y, noise_cov=0.09, theta0=1.0, q=0.2, exponent=1.5, smoother=None)


@_case(
    "ill_conditioned",
    13,
    "Column norms of L from 1 down to 1e-6 (condition number about 1e6) and noise 1e-3: "
    "the weights span seven orders of magnitude. Double-precision implementations agree "
    "to 1e-10 here (against 50 significant digits), so the tolerance stays 1e-6; single "
    "precision is off by 1e-2 and cannot pass.",
    "ill-conditioned lead field (column norms spread over 1e6)",
)
def _ill_conditioned(rng):
    L = rng.standard_normal((6, 5))
    L *= np.logspace(0, -6, 5) / np.linalg.norm(L, axis=0)
    Y = _data(rng, L, 1e-3 * np.eye(6))
    inputs = dict(L=L, Y=Y, noise_cov=1e-6, theta0=1.0, q=0.5)
    return inputs | dict(exponent=1.25, smoother="rts-state")


def _oblique(rng, n_positions, n_channels, n_times):
    """A lead field of ``n_positions`` positions of three orientations (MNE's order: x, y, z
    of a position together), and data from one moment a position, oblique to every axis."""
    L = rng.standard_normal((n_channels, 3 * n_positions))
    moments = rng.standard_normal((n_positions, 3))
    moments /= np.linalg.norm(moments, axis=1, keepdims=True)
    amplitude = np.cumsum(rng.standard_normal((n_positions, n_times)), axis=1)
    X = (moments[:, :, None] * amplitude[:, None, :]).reshape(3 * n_positions, n_times)
    return L, L @ X + 0.2 * rng.standard_normal((n_channels, n_times))


@_case(
    "position",
    14,
    "Three positions of three orientations, each source oblique to every axis; each "
    "position standardized as a whole by its 3 x 3 block (docs/model.md §2): a code that "
    "standardizes each column, or orders the columns by orientation, fails it.",
    "standardization per position (n_orient 3, oblique sources)",
)
def _position(rng):
    L, Y = _oblique(rng, 3, 8, N_TIMES)
    inputs = dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.3, exponent=1.25)
    return inputs | dict(smoother="rts-state", standardize="position", n_orient=3)


@_case(
    "smoothed_weights",
    15,
    "The smoother standardized by its own variance (docs/model.md §3): the smoothed state "
    "over Sigma_t, the prior covariance of x_t, and the weights of Sigma_t - P^s_t.",
    "rts-smoothed-weights",
)
def _smoothed_weights(rng):
    L = rng.standard_normal((6, 5))
    Y = _data(rng, L, 0.2 * np.eye(6))
    inputs = dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.4, transition=0.9)
    return inputs | dict(exponent=0.75, smoother="rts-smoothed-weights")


@_case(
    "channels_as_steps",
    16,
    "As many channels as time steps: a transposed Y keeps its shape, only the outputs show it.",
    "n_channels == n_times",
)
def _channels_as_steps(rng):
    L = rng.standard_normal((N_TIMES, 5))
    Y = _data(rng, L, 0.2 * np.eye(N_TIMES))
    inputs = dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.3, exponent=1.5)
    return inputs | dict(smoother="rts-standardized")


@_case(
    "diagonal_transition_below_one",
    17,
    "A = diag(0.95, 0.5, 0.9, 0.8, 0.7): diagonal, no entry exactly 1. The toolbox skips A "
    "only when it is diagonal with some entry exactly 1 (diagonal_transition), and uses it "
    "here.",
    "diagonal transition without an entry 1",
)
def _diagonal_transition_below_one(rng):
    L = rng.standard_normal((6, 5))
    Y = _data(rng, L, 0.2 * np.eye(6))
    A = np.diag([0.95, 0.5, 0.9, 0.8, 0.7])
    inputs = dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.4, transition=A)
    return inputs | dict(exponent=1.5, smoother="rts-standardized")


def _ar1(rng, L, noise_std, pm_snr_db, time_constant_ms, sfreq, n_times):
    """Priors of the stationary AR(1) prior and data drawn from it (sources of variance
    ``theta0`` at every step, white noise of ``noise_std``)."""
    theta0, q, rho = ar1_priors(L, noise_std, pm_snr_db, time_constant_ms, sfreq)
    X = np.empty((L.shape[1], n_times))
    X[:, 0] = np.sqrt(theta0) * rng.standard_normal(L.shape[1])
    for t in range(1, n_times):
        X[:, t] = rho * X[:, t - 1] + np.sqrt(q) * rng.standard_normal(L.shape[1])
    Y = L @ X + noise_std * rng.standard_normal((L.shape[0], n_times))
    about = dict(pm_snr_db=float(pm_snr_db), convention="gain", noise_std=noise_std)
    about |= dict(time_constant_ms=float(time_constant_ms), sfreq=float(sfreq))
    return dict(L=L, Y=Y, noise_cov=noise_std**2, theta0=theta0, q=q, transition=rho) | about


@_case(
    "ar1_prior",
    18,
    "The stationary AR(1) prior (docs/model.md §4, beyond the paper): A = rho I with rho = "
    "exp(-dt / tau), q = (1 - rho^2) theta0 and theta0 from PM-SNR 0 dB (gain convention), "
    "tau = 20 ms at 500 Hz; two positions of three orientations standardized as wholes, no "
    "smoother, the setting the study's rule chose.",
    "stationary AR(1) prior from PM-SNR 0 dB and a time constant of 20 ms at 500 Hz",
)
def _ar1_prior(rng):
    L = 100.0 * rng.standard_normal((8, 6))  # SI units, as priors_gain
    inputs = _ar1(rng, L, 1e-7, 0.0, 20.0, 500.0, n_times=20)
    return inputs | dict(exponent=0.5, smoother=None, standardize="position", n_orient=3)


@_case(
    "ar1_prior_smoothed",
    19,
    "The stationary AR(1) prior with PM-SNR 10 dB and tau = 5 ms at 1000 Hz (rho = exp(-0.2)), "
    "and the paper's smoother over the standardized sequence, whose gains hold A.",
    "stationary AR(1) prior from PM-SNR 10 dB and a time constant of 5 ms at 1000 Hz",
)
def _ar1_prior_smoothed(rng):
    L = rng.standard_normal((6, 5))
    inputs = _ar1(rng, L, 0.2, 10.0, 5.0, 1000.0, n_times=N_TIMES)
    return inputs | dict(exponent=1.25, smoother="rts-standardized")
