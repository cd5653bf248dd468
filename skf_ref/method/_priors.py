"""Prior parameters from signal-to-noise ratios (docs/model.md §4; the paper's §3.1 eqs. 8-10).

::

    theta0 = 10**(PM/10) * sigma**2 * amplitude**2 / N      PM-SNR = dB(sqrt(theta_tot))
    q      = 10**(EP/10) * theta0 / K                      EP-SNR = dB(kappa)      (10)

``N`` is the number of columns of L, ``K`` the number of time steps. dB of an amplitude is
``20 log10``, so ``theta_tot = 10**(PM/10)`` and ``kappa**2 = 10**(EP/10)``. Both SNRs must
lie within +-300 dB, and the variances they give must be normal doubles: a request outside
that range is refused, naming the parameter, instead of returning 0 or inf.

Beyond the paper, a stationary first-order (AR(1)) prior sets the memory of the state in
physical time, a time constant ``tau`` in milliseconds, in place of the EP-SNR
(:func:`ar1_priors`)::

    A = rho I,  rho = exp(-dt / tau),  dt = 1 / sfreq
    Q = q I,    q = (1 - rho**2) theta0,   P_0 = theta0 I

so that every ``x_t`` has the prior variance ``theta0``, whatever ``t`` and ``K``.
"""

from collections.abc import Callable
from typing import Any

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

__all__ = [
    "DEFAULT_EP_SNR_DB",
    "DEFAULT_TIME_CONSTANT_MS",
    "ar1_coefficients",
    "ar1_priors",
    "evolution_variance",
    "lead_field_amplitude",
    "prior_variance",
    "priors_from_snr",
]

CONVENTIONS = ("gain", "toolbox")
#: The random walk's EP-SNR (dB) where neither an EP-SNR nor a time constant is given and no
#: sampling rate is known (bare arrays): the study v2's rule (validation/archive/report-v2/).
DEFAULT_EP_SNR_DB = 0.0
#: The evolution prior where neither is given and the sampling rate is known (the MNE routes,
#: the command line's MNE route, the demo): the stationary AR(1) prior, its time constant
#: chosen by the data's marginal likelihood (the evidence study v3's rule,
#: validation/reproduce/PREREGISTRATION.md).
DEFAULT_TIME_CONSTANT_MS = "auto"


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
    given = dict(pm_snr_db=pm_snr_db, ep_snr_db=ep_snr_db)
    theta0 = _initial_variance(L, noise_std, pm_snr_db, convention, "priors_from_snr", given)
    return theta0, evolution_variance(ep_snr_db, theta0, n_steps)


def _initial_variance(
    L: ArrayLike,
    noise_std: float,
    pm_snr_db: float,
    convention: str,
    caller: str,
    given: dict[str, Any],
) -> float:
    """``theta0`` of :func:`priors_from_snr` and :func:`ar1_priors` (docs/model.md §4)."""
    noise_std = check_real("noise_std", noise_std, positive=True)
    auto = [k for k, value in given.items() if isinstance(value, str) and value.strip() == "auto"]
    if auto:
        raise InputError(
            f"{caller} takes numbers, got {' and '.join(auto)}='auto': priors chosen by the "
            "data ('auto') are skf_ref.tune's: tune(L, Y, noise_std=...) gives them"
        )
    pm_snr_db = check_db("pm_snr_db", pm_snr_db)
    amplitude = lead_field_amplitude(L, convention)
    if convention == "toolbox":
        snr_db = -20 * np.log10(noise_std)
        pm_snr_db = min(pm_snr_db, snr_db - 1.0)
    return prior_variance(pm_snr_db, noise_std, amplitude, np.shape(L)[1])


def ar1_coefficients(time_constant_ms: ArrayLike, sfreq: float) -> tuple[Any, Any]:
    """``rho = exp(-dt / tau)`` and ``1 - rho**2`` of time constants, ``dt = 1 / sfreq``.

    ``1 - rho**2`` is computed as ``-expm1(-2 dt / tau)``: to full precision when ``tau`` is
    many samples long and ``rho`` near 1. Unchecked: the callers check ``tau`` and ``sfreq``.

    Parameters
    ----------
    time_constant_ms : float or ndarray, shape (K,)
        ``tau`` in milliseconds, > 0.
    sfreq : float
        Sampling rate in Hz, > 0.

    Returns
    -------
    rho, one_minus_rho_sq : float or ndarray, shape (K,)

    Examples
    --------
    >>> rho, rest = ar1_coefficients(10.0, sfreq=1000.0)   # dt / tau = 1 ms / 10 ms
    >>> bool(np.isclose(rho, np.exp(-0.1))), bool(np.isclose(rest, 1 - np.exp(-0.2)))
    (True, True)
    """
    steps = 1000.0 / (sfreq * np.asarray(time_constant_ms, dtype=float))  # dt / tau
    rho, rest = np.exp(-steps), -np.expm1(-2 * steps)
    if np.ndim(rho) == 0:
        return float(rho), float(rest)
    return rho, rest


def ar1_priors(
    L: ArrayLike,
    noise_std: float,
    pm_snr_db: float,
    time_constant_ms: float,
    sfreq: float,
    convention: str = "gain",
) -> tuple[float, float, float]:
    r"""``(theta0, q, transition)`` of the stationary AR(1) prior with a time constant in ms.

    Beyond the paper (whose random walk is :func:`priors_from_snr`'s): the state decays
    towards 0 with the time constant ``tau`` and is renewed by just enough process noise to
    keep its prior variance ``theta0`` at every step,

    .. math::

        x_t = \rho x_{t-1} + w_t, \quad \rho = e^{-\Delta t / \tau}, \quad
        \Delta t = 1 / f_s, \quad w_t \sim N(0, q I), \quad q = (1 - \rho^2) \theta_0,
        \quad P_0 = \theta_0 I,

    with ``theta0`` from the PM-SNR exactly as :func:`priors_from_snr` computes it (docs/model.md
    §4). Then ``Var x_t = rho**2 theta0 + q = theta0`` whatever ``t`` and the number of steps,
    so the filtered estimate at a step does not depend on how many steps follow; the memory
    is ``tau`` in milliseconds whatever the sampling rate. ``tau -> inf`` is the static prior
    (``rho -> 1``, ``q -> 0``); ``tau -> 0`` makes each step stand alone.

    Parameters
    ----------
    L : ndarray, shape (n_channels, n_sources)
    noise_std : float
        Noise standard deviation, as for :func:`priors_from_snr`.
    pm_snr_db : float
        PM-SNR in dB.
    time_constant_ms : float
        The time constant ``tau`` of the state, in milliseconds, > 0.
    sfreq : float
        The sampling rate of the data, in Hz, > 0.
    convention : {"gain", "toolbox"}
        See :func:`lead_field_amplitude` and :func:`priors_from_snr`.

    Returns
    -------
    theta0 : float
        Prior variance of every step: ``P_0 = theta0 I``.
    q : float
        Process noise variance: ``Q = q I``, ``(1 - rho**2) theta0``.
    transition : float
        ``rho``: ``A = rho I``. Pass all three to :func:`skf_ref.reconstruct` as they are.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> L = rng.standard_normal((32, 500))
    >>> theta0, q, rho = ar1_priors(L, 0.1, pm_snr_db=0.0, time_constant_ms=20.0, sfreq=500.0)
    >>> round(rho, 12)                           # exp(-2 ms / 20 ms)
    0.904837418036
    >>> bool(np.isclose(rho**2 * theta0 + q, theta0, rtol=1e-15))   # Var x_1 = Var x_0
    True
    >>> bool(theta0 == priors_from_snr(L, 0.1, 0.0, 0.0, n_steps=1)[0])
    True
    """
    given = dict(pm_snr_db=pm_snr_db, time_constant_ms=time_constant_ms)
    theta0 = _initial_variance(L, noise_std, pm_snr_db, convention, "ar1_priors", given)
    time_constant_ms = check_real("time_constant_ms", time_constant_ms, positive=True)
    sfreq = check_real("sfreq", sfreq, positive=True)
    rho, rest = ar1_coefficients(time_constant_ms, sfreq)
    q = _variance("q", lambda: rest * theta0, "(1 - rho^2) theta0")
    return theta0, q, rho
