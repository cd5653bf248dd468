"""Priors chosen by the data: PM-SNR and EP-SNR (or a time constant) by one of two criteria.

The Kalman filter gives the marginal likelihood of the data, ``log p(Y | theta0, q)``, as the sum
of its innovations' log densities, and the filtered residual ``y_t - L x_{t|t}`` whose whitened
energy the discrepancy principle matches to the noise's (docs/model.md §4). In the singular basis
of the whitened lead field both need only the rank-r recursions
(:class:`skf_ref.method.SpectralBasis`): one SVD, then a few hundred
microseconds per prior pair at the paper's scale, with no n-dimensional array at all, so a whole
grid of priors costs little more than one reconstruction. The same holds for the stationary
AR(1) prior (:func:`skf_ref.ar1_priors`): its time constant sets the transition ``rho`` and ``q``
of each pair, and the recursions run one transition per pair.

A searched prior chosen on (within ``BOUND_TOL_DB``, 0.01 dB, of) an end of its range is reported
(``skf_ref.method._search``): the criterion would have gone further, so the range, not the data,
made the choice. :func:`tune` then warns (``UserWarning``) naming the parameter and the bound, and
``at_bound`` of the :class:`TuneResult` records it.
"""

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils.checks import (
    InputError,
    check_choice,
    check_int,
    check_real,
    describe,
)
from .._utils.reprs import html_table
from ._discrepancy import choose_on_curve
from ._model import StateSpaceModel
from ._paths.singular_basis import SpectralBasis, whitener
from ._priors import (
    CONVENTIONS,
    DEFAULT_EP_SNR_DB,
    ar1_coefficients,
    ar1_priors,
    evolution_variance,
    lead_field_amplitude,
    prior_variance,
    priors_from_snr,
)
from ._search import (
    AUTO_RANGE_DB,
    AUTO_TIME_CONSTANT_MS,
    BOUND_TOL_DB,
    at_bound,
    check_one_evolution_prior,
    check_time_constant,
    search_range,
    time_constant_levels,
    warn_at_bound,
)

__all__ = [
    "AUTO_RANGE_DB",
    "AUTO_TIME_CONSTANT_MS",
    "BOUND_TOL_DB",
    "CRITERIA",
    "TuneResult",
    "choose_priors",
    "tune",
]

#: The criteria :func:`tune` can maximize or solve (docs/model.md §4).
CRITERIA = ("likelihood", "discrepancy")

#: (PM, EP) or (PM, time-constant level) pairs (K, 2) -> theta0, q and the transition.
_Priors = Callable[[ArrayLike], tuple[NDArray[np.float64], NDArray[np.float64], Any]]


@dataclass(frozen=True, eq=False)
class TuneResult:
    """The priors a criterion chose, and the likelihood over the grid.

    Parameters
    ----------
    pm_snr_db : float
        The chosen PM-SNR (dB).
    ep_snr_db : float or None
        The chosen EP-SNR (dB) of the paper's random walk; None for the AR(1) prior.
    theta0, q : float
        The priors they give (docs/model.md §4), in the units of ``L`` and ``Y`` (for the
        "toolbox" convention, of ``Y / max|Y|``).
    log_likelihood : float
        Its value there: ``reconstruct(...).log_likelihood`` at ``theta0``, ``q`` and
        ``transition``.
    landscape : pandas.DataFrame
        The coarse grid: columns ``pm_snr_db``, ``ep_snr_db`` (or ``time_constant_ms`` and
        ``transition`` for the AR(1) prior), ``theta0``, ``q``, ``log_likelihood``.
    convention : str
        The amplitude convention of the SNRs.
    criterion : {"likelihood", "discrepancy"}
        How the priors were chosen.
    at_bound : dict
        ``"pm_snr_db"`` and/or ``"ep_snr_db"`` (or ``"time_constant_ms"``) -> ``"lower"`` or
        ``"upper"``: the searched priors chosen on (within 0.01 dB, ``BOUND_TOL_DB``, of; for
        a time constant within 0.23 %) an end of their range. Empty when every searched
        prior is inside its range; a fixed one is never listed.
    residual_energy : float
        ``sum_t ||C^{-1} (y_t - L x_{t|t})||^2`` at the chosen priors (``R = C C^T``): the
        discrepancy principle sets it to ``n_channels * n_times``.
    curve : pandas.DataFrame or None
        For ``"discrepancy"``: the PM-SNRs of the coarse grid, the EP-SNR the principle
        gives each (``ep_snr_db``) and the log-likelihood there. None for ``"likelihood"``.
    time_constant_ms : float or None
        The chosen time constant (ms) of the stationary AR(1) prior
        (:func:`skf_ref.ar1_priors`); None for the random walk.
    transition : float
        ``A = transition I``: ``exp(-dt / tau)`` for the AR(1) prior, else the one given.
        Pass ``theta0``, ``q`` and ``transition`` to :func:`skf_ref.reconstruct`.
    """

    pm_snr_db: float
    ep_snr_db: float | None
    theta0: float
    q: float
    log_likelihood: float
    landscape: Any
    convention: str
    criterion: str = "likelihood"
    at_bound: dict[str, str] = field(default_factory=dict)
    residual_energy: float = math.nan
    curve: Any = None
    time_constant_ms: float | None = None
    transition: float = 1.0

    def _evolution(self) -> str:
        if self.time_constant_ms is None:
            return f"EP-SNR {self.ep_snr_db:.2f} dB"
        return f"time constant {self.time_constant_ms:.3g} ms"

    def __repr__(self) -> str:
        bounds = ", ".join(f"{name} on its {end} bound" for name, end in self.at_bound.items())
        return (
            f"<TuneResult | PM-SNR {self.pm_snr_db:.2f} dB, {self._evolution()}, "
            f"log-likelihood {self.log_likelihood:.6g}, by {self.criterion}"
            f"{'; ' + bounds if bounds else ''}>"
        )

    def _repr_html_(self) -> str:
        """The choice as a table, for notebooks (the grid stays in ``landscape``)."""
        bounds = ", ".join(f"{name}: {end}" for name, end in self.at_bound.items())
        rows: dict[str, Any] = {"PM-SNR (dB)": f"{self.pm_snr_db:.2f}"}
        if self.time_constant_ms is None:
            rows["EP-SNR (dB)"] = f"{self.ep_snr_db:.2f}"
        else:
            rows["Time constant (ms)"] = f"{self.time_constant_ms:.4g}"
            rows["Transition"] = f"{self.transition:.6g}"
        rows |= {
            "theta0": f"{self.theta0:.6g}",
            "q": f"{self.q:.6g}",
            "Log-likelihood": f"{self.log_likelihood:.6g}",
            "Criterion": self.criterion,
            "Convention": self.convention,
            "On a bound": bounds or "none",
            "Grid cells": len(self.landscape),
        }
        return html_table("TuneResult", rows)


def tune(
    L: ArrayLike,
    Y: ArrayLike,
    *,
    noise_std: float | None = None,
    noise_cov: ArrayLike | None = None,
    pm_snr_db: float | tuple[float, float] | str = AUTO_RANGE_DB,
    ep_snr_db: float | tuple[float, float] | str | None = None,
    time_constant_ms: float | tuple[float, float] | str | None = None,
    sfreq: float | None = None,
    transition: float = 1.0,
    convention: str = "gain",
    grid: int = 13,
    criterion: str = "likelihood",
) -> TuneResult:
    r"""PM-SNR and EP-SNR (or a time constant) chosen from the data by the marginal likelihood.

    ``criterion="likelihood"`` (default): the priors that maximize the marginal likelihood of
    the data. A coarse grid of ``grid`` values per searched prior, then a bounded refinement
    (``scipy.optimize.minimize``, L-BFGS-B, from the best cell). The likelihood judges the
    model ``y = L x + r`` with its priors; it cannot choose the standardization exponent or
    the smoother: they change the estimate shown, not the model, and leave the likelihood
    unchanged.

    The evolution prior is the paper's random walk with its EP-SNR (default), or, with
    ``time_constant_ms``, the stationary AR(1) prior of :func:`skf_ref.ar1_priors`
    (``A = rho I``, ``rho = exp(-dt / tau)``, ``q = (1 - rho^2) theta0``): its time constant
    is searched in ``log(tau)`` beside the PM-SNR, on the same grid and refinement
    (``"auto"``: 1 to 1000 ms).

    ``criterion="discrepancy"`` (random walk only): Morozov's discrepancy principle for the
    process noise. At each PM-SNR, the EP-SNR at which the whitened residual of the filtered
    means equals its expected value under the noise model,

    .. math:: \sum_t \|C^{-1} (y_t - L x_{t|t})\|^2 = m T, \qquad R = C C^T,

    with ``m = n_channels`` (the rows of the whitened data ``C^{-1} Y``) and ``T = n_times``,
    found by a bracketing root search in dB within the EP-SNR range, to 1e-10 dB
    (``skf_ref.method._discrepancy``); where the residual does not cross ``m T`` inside the
    range, the end where it comes nearest. The principle says nothing of the PM-SNR: a
    number fixes it; over a range, the PM-SNR is the one of largest marginal likelihood
    along the curve of those solutions (the ``grid`` PM-SNRs whose solution lies inside
    the EP range, or all of them if none does; then Brent's bounded search between the
    best one's neighbours). A fixed EP-SNR leaves the principle nothing to solve: the
    PM-SNR is then chosen by the likelihood at that EP-SNR.

    A searched prior chosen within 0.01 dB (``BOUND_TOL_DB``; a time constant within
    0.23 %) of an end of its range raises a ``UserWarning`` that names it and the bound
    (widen the range to let the criterion decide), and is listed in the result's
    ``at_bound``. A fixed prior never warns.

    Parameters
    ----------
    L : array_like, shape (n_channels, n_sources)
    Y : array_like, shape (n_channels, n_times)
    noise_std : float, optional
    noise_cov : array_like, shape (n_channels, n_channels), optional
        Give exactly one, as for :func:`skf_ref.reconstruct`.
    pm_snr_db : (float, float) or float or "auto"
        The range searched, in dB; a single number fixes it; ``"auto"`` is the default
        range, (-20, 40) dB (``AUTO_RANGE_DB``).
    ep_snr_db : (float, float) or float or "auto", optional
        The same for the EP-SNR of the random walk; default (None) ``"auto"``, unless
        ``time_constant_ms`` is given: give one of the two.
    time_constant_ms : (float, float) or float or "auto", optional
        The stationary AR(1) prior's time constant in ms: a range searched in ``log(tau)``,
        a number to fix it, or ``"auto"``, (1, 1000) ms (``AUTO_TIME_CONSTANT_MS``).
    sfreq : float, optional
        The sampling rate of ``Y`` in Hz; required by ``time_constant_ms``.
    transition : float
        ``A = transition I`` of the random walk's model (the AR(1) prior sets its own).
    convention : {"gain", "toolbox"}
        "gain" (default): SNRs of the whitened lead field, unit free. "toolbox": as the
        toolbox (docs/model.md §4): needs ``noise_std``; the data are divided by ``max|Y|``
        and ``theta0``, ``q`` and the likelihood are those of ``Y / max|Y|``.
    grid : int
        Values per searched prior on the coarse grid, >= 2.
    criterion : {"likelihood", "discrepancy"}
        What chooses the priors (see above).

    Returns
    -------
    TuneResult
        With ``time_constant_ms``, its ``time_constant_ms`` and ``transition`` are the
        chosen ones, and ``ep_snr_db`` is None.

    Warns
    -----
    UserWarning
        When a searched prior is chosen on a bound of its range.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> L = rng.standard_normal((8, 20))
    >>> X = np.cumsum(0.3 * rng.standard_normal((20, 50)), axis=1)
    >>> Y = L @ X + 0.5 * rng.standard_normal((8, 50))
    >>> result = tune(L, Y, noise_std=0.5, grid=7)
    >>> result.landscape.shape, result.at_bound
    ((49, 5), {})
    >>> bool(result.log_likelihood >= result.landscape["log_likelihood"].max())
    True

    The discrepancy principle puts the filtered residual at its expected value, 8 x 50:

    >>> result = tune(L, Y, noise_std=0.5, pm_snr_db=10.0, criterion="discrepancy")
    >>> round(result.residual_energy, 6), result.at_bound
    (400.0, {})

    The stationary AR(1) prior, its time constant chosen in 1 .. 1000 ms at 500 Hz:

    >>> result = tune(L, Y, noise_std=0.5, time_constant_ms="auto", sfreq=500.0, grid=7)
    >>> result.ep_snr_db is None, 1.0 < result.time_constant_ms < 1000.0
    (True, True)
    >>> bool(np.isclose(result.transition, np.exp(-2.0 / result.time_constant_ms)))
    True
    """
    check_choice("criterion", criterion, CRITERIA)
    check_choice("convention", convention, CONVENTIONS)
    grid = check_int("grid", grid, minimum=2)
    check_one_evolution_prior(ep_snr_db, time_constant_ms)
    if np.ndim(transition) != 0:
        raise InputError(f"transition must be a scalar for tune, got {describe(transition)}")
    pm_range = search_range("pm_snr_db", pm_snr_db)
    tau_ends = None  # the time constants' range: in levels and in ms
    if time_constant_ms is None:
        sfreq = None
        evolution = search_range("ep_snr_db", "auto" if ep_snr_db is None else ep_snr_db)
    else:
        sfreq = _check_ar1(time_constant_ms, sfreq, transition, criterion)
        tau = check_time_constant(time_constant_ms)
        evolution = time_constant_levels(tau)
        milliseconds = AUTO_TIME_CONSTANT_MS if tau == "auto" else tau
        tau_ends = (evolution, milliseconds if isinstance(milliseconds, tuple) else (tau, tau))
    ranges = [pm_range, evolution]
    model = StateSpaceModel.create(
        L, noise_std=noise_std, noise_cov=noise_cov, theta0=1.0, q=1.0, transition=transition
    )
    data = model.check_data(Y)
    if convention == "toolbox":
        if noise_std is None:
            raise InputError("convention='toolbox' needs noise_std (relative to max|Y|)")
        scale = np.max(np.abs(data))
        relative_std = check_real("noise_std", noise_std) / scale
        model = StateSpaceModel.create(
            model.L, noise_std=relative_std, theta0=1.0, q=1.0, transition=transition
        )
        data = data / scale
    basis = SpectralBasis(model.L, model.R)
    priors = _priors(model, basis, convention, data.shape[1], sfreq)
    names = ("pm_snr_db", "ep_snr_db" if sfreq is None else "time_constant_ms")
    projected = (*basis.project(data), np.isnan(data[0]))  # once: then rank-r work only

    def log_likelihoods(points: NDArray[np.float64]) -> NDArray[np.float64]:
        return basis.sums(*projected, *priors(points))[0]

    axes = [
        np.linspace(low, high, grid) if low < high else np.array([low]) for low, high in ranges
    ]
    cells = np.array(np.meshgrid(*axes, indexing="ij")).reshape(2, -1).T
    values = log_likelihoods(cells)
    curve = None
    if criterion == "likelihood":
        best = _refine(log_likelihoods, cells[np.argmax(values)], ranges)
        best_value = float(log_likelihoods(best[None])[0])
        if best_value < values.max():  # the refinement did not improve on the grid
            best, best_value = cells[np.argmax(values)], float(values.max())
    else:
        # m T over the observed steps: E||C^{-1} r_t||^2 = m at every one
        target = data.shape[0] * np.count_nonzero(~np.isnan(data[0]))

        def excess(points: NDArray[np.float64]) -> NDArray[np.float64]:
            return basis.sums(*projected, *priors(points))[1] - target

        best, best_value, curve = choose_on_curve(log_likelihoods, excess, axes[0], ranges)
    residual = basis.sums(*projected, *priors(best[None]))[1][0]
    bounds = at_bound(names, best, ranges)
    warn_at_bound(bounds, names, best, ranges, criterion)
    chosen = (best, best_value, bounds, residual, curve, tau_ends)
    return _result(cells, values, priors, names, convention, criterion, *chosen)


def _check_ar1(time_constant_ms: Any, sfreq: Any, transition: Any, criterion: str) -> float:
    """The AR(1) prior's checks beyond the time constant's own: its sampling rate, and no
    transition or criterion that contradicts it. Returns ``sfreq``."""
    if sfreq is None:
        raise InputError(
            f"time_constant_ms={time_constant_ms!r} needs sfreq, the sampling rate of Y in Hz "
            "(the transition is exp(-1 / (sfreq tau)))"
        )
    sfreq = check_real("sfreq", sfreq, positive=True)
    if transition != 1.0:
        raise InputError(
            "give transition or time_constant_ms, not both: the time constant sets the "
            f"transition, exp(-dt / tau); got transition={transition!r}"
        )
    if criterion != "likelihood":
        raise InputError(
            f"criterion={criterion!r} solves for the EP-SNR of the random walk; the time "
            "constant of the AR(1) prior is chosen by criterion='likelihood'"
        )
    return sfreq


def _priors(
    model: StateSpaceModel,
    basis: SpectralBasis,
    convention: str,
    n_steps: int,
    sfreq: float | None,
) -> _Priors:
    """(PM, EP) dB pairs, or (PM, ``10 log10 tau``) with ``sfreq``, (K, 2) -> theta0 (K,),
    q (K,) and the transition (a float, or (K,) for the AR(1) prior), vectorized."""
    if convention == "gain":
        # the whitened lead field with noise std 1: the same as priors_from_snr(L, sigma)
        amplitude = lead_field_amplitude(basis.whiten(model.L), "gain")
        sigma = 1.0
    else:
        amplitude = lead_field_amplitude(model.L, "toolbox")
        sigma = float(np.sqrt(model.R[0, 0]))
        snr_db = -20 * np.log10(sigma)
    unit_theta0 = prior_variance(0.0, sigma, amplitude, model.n_sources)
    unit_q = evolution_variance(0.0, 1.0, n_steps)
    a = float(cast(float, model.transition))

    def priors(points: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], Any]:
        pm, level = np.asarray(points, dtype=float).T
        if convention == "toolbox":
            pm = np.minimum(pm, snr_db - 1.0)  # the toolbox's clamp
        theta0 = unit_theta0 * 10 ** (pm / 10)
        if sfreq is None:  # the random walk: q = 10**(EP/10) theta0 / K, eq. (10)
            return theta0, unit_q * 10 ** (level / 10) * theta0, a
        # the AR(1) prior: rho = exp(-dt / tau), q = (1 - rho^2) theta0 (ar1_priors)
        rho, rest = ar1_coefficients(10 ** (level / 10), sfreq)
        return theta0, rest * theta0, rho

    return priors


# L-BFGS-B also stops when one line search barely reduces -log p (its relative-reduction
# test), which a change of the log-likelihood in its 15th digit can cause, with the
# gradient still 2 per dB (test_tune): it starts again from where it stopped until it
# stays there.
_RESTARTS = 5


def _refine(
    log_likelihoods: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    start: NDArray[np.float64],
    ranges: list[tuple[float, float]],
    step_db: float = 1e-3,
) -> NDArray[np.float64]:
    """L-BFGS-B on -log p over the searched SNRs, gradients by one batched evaluation."""
    from scipy.optimize import minimize

    free = [i for i, (low, high) in enumerate(ranges) if low < high]
    if not free:
        return np.asarray(start, dtype=float)

    def objective(x: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        point = np.asarray(start, dtype=float).copy()
        point[free] = x
        shifted = np.repeat(point[None], 1 + len(free), axis=0)
        for k, i in enumerate(free):
            shifted[1 + k, i] += step_db
        values = -log_likelihoods(shifted)
        return values[0], (values[1:] - values[0]) / step_db

    bounds = [ranges[i] for i in free]
    x = np.asarray(start, dtype=float)[free]
    for _ in range(_RESTARTS):
        solution = minimize(objective, x, jac=True, method="L-BFGS-B", bounds=bounds)
        if np.array_equal(solution.x, x):
            break
        x = solution.x
    best = np.asarray(start, dtype=float).copy()
    best[free] = x
    return best


def _milliseconds(levels: NDArray[np.float64], ends: Any) -> NDArray[np.float64]:
    """Time constants (ms) of levels ``10 log10 tau``; ``ends``: the range's levels and its
    ms, which the ends' levels give exactly (``10**(level / 10)`` can round past them)."""
    tau = 10 ** (levels / 10)
    for level, end in zip(ends[0], ends[1], strict=True):
        tau = np.where(levels == level, end, tau)
    return tau


def _result(
    cells: NDArray[np.float64],
    values: NDArray[np.float64],
    priors: _Priors,
    names: tuple[str, str],
    convention: str,
    criterion: str,
    best: NDArray[np.float64],
    best_value: float,
    bounds: dict[str, str],
    residual: float,
    curve: Any,
    tau_ends: Any,
) -> TuneResult:
    import pandas as pd

    theta0, q, a = priors(cells)
    columns = dict(pm_snr_db=cells[:, 0])
    if names[1] == "ep_snr_db":
        columns |= dict(ep_snr_db=cells[:, 1])
    else:  # the levels of the time constants, in ms again
        columns |= dict(time_constant_ms=_milliseconds(cells[:, 1], tau_ends), transition=a)
    landscape = pd.DataFrame(columns | dict(theta0=theta0, q=q, log_likelihood=values))
    (best_theta0,), (best_q,), best_a = priors(best[None])
    ar1 = names[1] == "time_constant_ms"
    return TuneResult(
        pm_snr_db=float(best[0]),
        ep_snr_db=None if ar1 else float(best[1]),
        theta0=float(best_theta0),
        q=float(best_q),
        log_likelihood=best_value,
        landscape=landscape,
        convention=convention,
        criterion=criterion,
        at_bound=bounds,
        residual_energy=float(residual),
        curve=curve,
        time_constant_ms=float(_milliseconds(best[1:], tau_ends)[0]) if ar1 else None,
        transition=float(np.ravel(best_a)[0]),
    )


def choose_priors(
    L: ArrayLike,
    Y: ArrayLike,
    *,
    noise_std: float | None = None,
    noise_cov: ArrayLike | None = None,
    pm_snr_db: float | str | tuple[float, float],
    ep_snr_db: float | str | tuple[float, float] | None = None,
    time_constant_ms: float | str | tuple[float, float] | None = None,
    sfreq: float | None = None,
    convention: str = "gain",
    criterion: str = "likelihood",
) -> tuple[float, float, float, TuneResult | None]:
    """``theta0, q, transition`` from the priors given, any of which may be ``"auto"``.

    The SNRs are those of the whitened lead field (docs/model.md §4): with ``noise_std``,
    exactly :func:`skf_ref.priors_from_snr` (the paper's random walk, transition 1), or with
    ``time_constant_ms`` :func:`skf_ref.ar1_priors` (the stationary AR(1) prior).

    Parameters
    ----------
    L : array_like, shape (n_channels, n_sources)
    Y : array_like, shape (n_channels, n_times)
    noise_std : float, optional
    noise_cov : array_like, shape (n_channels, n_channels), optional
        Give exactly one.
    pm_snr_db, ep_snr_db : float or "auto" or (float, float)
        A number fixes the SNR; ``"auto"`` or a range ``(low, high)`` is searched by
        :func:`tune`. ``ep_snr_db`` None (not given): 0 dB, or the AR(1) prior with
        ``time_constant_ms``.
    time_constant_ms : float or "auto" or (float, float), optional
        The AR(1) prior's time constant (ms); give it or ``ep_snr_db``, not both.
    sfreq : float, optional
        The sampling rate of ``Y`` (Hz), for ``time_constant_ms``.
    convention : {"gain", "toolbox"}
        "toolbox" needs ``noise_std``.
    criterion : {"likelihood", "discrepancy"}
        How :func:`tune` chooses an ``"auto"`` prior.

    Returns
    -------
    theta0, q, transition : float
    tuning : TuneResult or None
        None when every prior was a number.
    """
    check_choice("criterion", criterion, CRITERIA)
    check_one_evolution_prior(ep_snr_db, time_constant_ms)
    if ep_snr_db is None and time_constant_ms is None:
        ep_snr_db = DEFAULT_EP_SNR_DB  # the random walk at the study's rule's EP-SNR
    given = [v for v in (pm_snr_db, ep_snr_db, time_constant_ms) if v is not None]
    if any(isinstance(v, str) or np.ndim(v) > 0 for v in given):
        result = tune(
            L,
            Y,
            noise_std=noise_std,
            noise_cov=noise_cov,
            pm_snr_db=pm_snr_db,
            ep_snr_db=ep_snr_db,
            time_constant_ms=time_constant_ms,
            sfreq=sfreq,
            convention=convention,
            criterion=criterion,
        )
        return result.theta0, result.q, result.transition, result
    n_times = np.shape(Y)[-1]
    if noise_cov is None:
        whitened, sigma = L, cast(float, noise_std)
    elif convention != "gain":
        raise InputError(f"convention={convention!r} needs noise_std, not noise_cov")
    else:
        model = StateSpaceModel.create(L, noise_cov=noise_cov, theta0=1.0, q=1.0)
        whitened, sigma = whitener(model.R)[0](model.L), 1.0
    pm = cast(float, pm_snr_db)  # numbers: "auto" and ranges went to tune
    if time_constant_ms is None:
        ep = cast(float, ep_snr_db)
        return *priors_from_snr(whitened, sigma, pm, ep, n_times, convention), 1.0, None
    tau, rate = cast(float, time_constant_ms), cast(float, sfreq)
    return *ar1_priors(whitened, sigma, pm, tau, rate, convention), None
