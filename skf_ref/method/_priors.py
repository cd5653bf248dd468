"""Prior parameters from signal-to-noise ratios (docs/model.md §4; the paper's §3.1 eqs. 8-10).

::

    theta0 = 10**(PM/10) * sigma**2 * amplitude**2 / N      PM-SNR = dB(sqrt(theta_tot))
    q      = 10**(EP/10) * theta0 / K                      EP-SNR = dB(kappa)      (10)

``N`` is the number of columns of L, ``K`` the number of time steps. dB of an amplitude is
``20 log10``, so ``theta_tot = 10**(PM/10)`` and ``kappa**2 = 10**(EP/10)``. Both SNRs must
lie within +-300 dB, and the variances they give must be normal doubles: a request outside
that range is refused, naming the parameter, instead of returning 0 or inf.
"""

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from .._utils.checks import (
    InputError,
    check_choice,
    check_db,
    check_int,
    check_leadfield,
    check_real,
)

__all__ = ["prior_variance", "evolution_variance", "lead_field_amplitude", "priors_from_snr"]

CONVENTIONS = ("gain", "toolbox")


def _variance(name: str, compute: Callable[[], float], formula: str) -> float:
    """``compute()`` in double precision if it is a normal double, else an error."""
    with np.errstate(over="ignore", under="ignore"):
        value = compute()
    if not np.finfo(float).tiny <= value <= np.finfo(float).max:
        raise InputError(
            f"{name} = {formula} = {value:.3g} is outside double precision: the SNRs or the "
            "scales of the noise and the lead field are out of range (rescale them, e.g. to "
            "other units)"
        )
    return float(value)


def prior_variance(pm_snr_db: float, noise_std: float, amplitude: float, n_sources: int) -> float:
    """Initial prior variance ``theta0`` from the PM-SNR.

    Parameters
    ----------
    pm_snr_db : float
        Prior-over-measurement SNR in dB.
    noise_std : float
        Noise standard deviation sigma, in data units.
    amplitude : float
        Measurement amplitude (see :func:`lead_field_amplitude`).
    n_sources : int
        Number of columns of the lead field, N.

    Returns
    -------
    float
        ``10**(PM/10) * sigma**2 * amplitude**2 / N``.

    Examples
    --------
    >>> prior_variance(0.0, noise_std=2.0, amplitude=3.0, n_sources=9)
    4.0
    >>> prior_variance(20.0, noise_std=2.0, amplitude=3.0, n_sources=9)
    400.0
    """
    pm_snr_db = check_db("pm_snr_db", pm_snr_db)
    noise_std = check_real("noise_std", noise_std, positive=True)
    amplitude = check_real("amplitude", amplitude, positive=True)
    n_sources = check_int("n_sources", n_sources)
    theta_tot = 10 ** (pm_snr_db / 10)
    return _variance(
        "theta0",
        lambda: theta_tot * np.float64(noise_std) ** 2 * np.float64(amplitude) ** 2 / n_sources,
        "10**(PM/10) sigma^2 amplitude^2 / N",
    )


def evolution_variance(ep_snr_db: float, theta0: float, n_steps: int) -> float:
    """Per-step evolution (process noise) variance ``q`` from the EP-SNR, eq. (10).

    Parameters
    ----------
    ep_snr_db : float
        Evolution-prior SNR in dB.
    theta0 : float
        Initial prior variance.
    n_steps : int
        Number of time steps K of the Markov chain.

    Returns
    -------
    float
        ``10**(EP/10) * theta0 / K``.

    Examples
    --------
    >>> evolution_variance(20.0, theta0=4.0, n_steps=40)
    10.0
    """
    ep_snr_db = check_db("ep_snr_db", ep_snr_db)
    theta0 = check_real("theta0", theta0, positive=True)
    n_steps = check_int("n_steps", n_steps)
    kappa_sq = 10 ** (ep_snr_db / 10)
    return _variance(
        "q", lambda: kappa_sq * np.float64(theta0) / n_steps, "10**(EP/10) theta0 / K"
    )


def lead_field_amplitude(L: ArrayLike, convention: str = "gain") -> float:
    """Measurement amplitude of a lead field.

    Parameters
    ----------
    L : ndarray, shape (n_channels, n_sources)
    convention : {"gain", "toolbox"}
        ``"gain"``: ``sqrt(n_channels) / rms_j ||L_j||``, which makes PM-SNR the
        prior-predicted SNR ``E||L x||^2 / E||r||^2`` and is independent of the units of L.
        ``"toolbox"``: ``mean_j ||L_j||**(-1/2)``, as the Zeffiro Kalman plug-in computes
        it; it depends on the units of L.

    Returns
    -------
    float

    Examples
    --------
    >>> L = np.array([[3.0, 0.0], [4.0, 1.0]])
    >>> round(lead_field_amplitude(L), 12)   # sqrt(2) / sqrt((25 + 1) / 2)
    0.392232270276
    >>> lead_field_amplitude(L, "toolbox")   # (5**-0.5 + 1**-0.5) / 2
    0.7236067977499789
    """
    L = check_leadfield(L)
    check_choice("convention", convention, CONVENTIONS)
    # a power of four near max|L|: dividing by it (and by its square root) is exact, and the
    # norms of L / scale can neither overflow nor underflow to 0
    exponent = np.frexp(np.max(np.abs(L)))[1]
    scale = np.ldexp(1.0, exponent + exponent % 2)
    norms = np.linalg.norm(L / scale, axis=0)
    if convention == "gain":
        return float(np.sqrt(L.shape[0]) / np.sqrt(np.mean(norms**2)) / scale)
    return float(np.mean(norms**-0.5) / np.sqrt(scale))


def priors_from_snr(
    L: ArrayLike,
    noise_std: float,
    pm_snr_db: float,
    ep_snr_db: float,
    n_steps: int,
    convention: str = "gain",
) -> tuple[float, float]:
    """``(theta0, q)`` for a lead field, noise level and the two prior SNRs.

    Parameters
    ----------
    L : ndarray, shape (n_channels, n_sources)
    noise_std : float
        Noise standard deviation. For ``convention="toolbox"`` it is relative to
        ``max|Y|`` (the toolbox divides the data by their maximum first).
    pm_snr_db, ep_snr_db : float
        PM-SNR and EP-SNR in dB. Priors chosen by the data are :func:`skf_ref.tune`'s.
    n_steps : int
        Number of time steps K.
    convention : {"gain", "toolbox"}
        See :func:`lead_field_amplitude`. ``"toolbox"`` also clamps the exponent as the
        toolbox does, so that ``SNR - PM >= 1`` dB with ``SNR = -20 log10(noise_std)``.

    Returns
    -------
    theta0 : float
        Initial variance: ``P_0 = theta0 I``.
    q : float
        Evolution variance: ``Q = q I``.

    Examples
    --------
    With the "gain" convention PM-SNR is the prior-predicted SNR of the data:

    >>> rng = np.random.default_rng(0)
    >>> L = rng.standard_normal((32, 500))
    >>> theta0, q = priors_from_snr(L, 0.1, pm_snr_db=0.0, ep_snr_db=20.0, n_steps=41)
    >>> prior_power = theta0 * np.sum(L**2)          # E||L x||^2 with x ~ N(0, theta0 I)
    >>> noise_power = 0.1**2 * 32                   # E||r||^2
    >>> float(round(prior_power / noise_power, 12)), round(q / theta0 * 41, 12)
    (1.0, 100.0)
    """
    noise_std = check_real("noise_std", noise_std, positive=True)
    if any(isinstance(value, str) and value.strip() == "auto" for value in (pm_snr_db, ep_snr_db)):
        raise InputError(
            "priors_from_snr takes SNRs in dB; priors chosen by the data ('auto') are "
            "skf_ref.tune's: tune(L, Y, noise_std=...) gives theta0 and q"
        )
    pm_snr_db = check_db("pm_snr_db", pm_snr_db)
    amplitude = lead_field_amplitude(L, convention)
    if convention == "toolbox":
        snr_db = -20 * np.log10(noise_std)
        pm_snr_db = min(pm_snr_db, snr_db - 1.0)
    theta0 = prior_variance(pm_snr_db, noise_std, amplitude, np.shape(L)[1])
    return theta0, evolution_variance(ep_snr_db, theta0, n_steps)
