"""Priors chosen by the data: PM-SNR and EP-SNR by one of two criteria (docs/model.md §4).

The Kalman filter gives the marginal likelihood of the data, ``log p(Y | theta0, q)``, as the sum
of its innovations' log densities, and the filtered residual ``y_t - L x_{t|t}`` whose whitened
energy the discrepancy principle matches to the noise's. In the singular basis of the whitened lead
field both need only the rank-r recursions
(:class:`skf_ref.method.SpectralBasis`): one SVD, then a few hundred
microseconds per prior pair at the paper's scale, with no n-dimensional array at all, so a whole
grid of priors costs little more than one reconstruction.

A searched SNR chosen on (within ``BOUND_TOL_DB``, 0.01 dB, of) an end of its range is reported:
the criterion would have gone further, so the range, not the data, made the choice.
:func:`tune` then warns (``UserWarning``) naming the parameter and the bound, and
``at_bound`` of the :class:`TuneResult` records it.
"""

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils.checks import (
    MAX_DB,
    InputError,
    check_choice,
    check_db,
    check_int,
    check_real,
    describe,
)
from .._utils.log import caller_stacklevel
from .._utils.reprs import html_table
from ._discrepancy import choose_on_curve
from ._model import StateSpaceModel
from ._paths.singular_basis import SpectralBasis, whitener
from ._priors import (
    CONVENTIONS,
    evolution_variance,
    lead_field_amplitude,
    prior_variance,
    priors_from_snr,
)

__all__ = ["AUTO_RANGE_DB", "BOUND_TOL_DB", "CRITERIA", "TuneResult", "choose_priors", "tune"]

#: The SNRs searched for ``"auto"`` (dB): the span of the paper's finer map.
AUTO_RANGE_DB = (-20.0, 40.0)
#: The criteria :func:`tune` can maximize or solve (docs/model.md §4).
CRITERIA = ("likelihood", "discrepancy")
#: A searched SNR this close (dB) to an end of its range is on that bound.
BOUND_TOL_DB = 0.01
_ENDS = ("lower", "upper")


@dataclass(frozen=True, eq=False)
class TuneResult:
    """The priors a criterion chose, and the likelihood over the grid.

    Parameters
    ----------
    pm_snr_db, ep_snr_db : float
        The chosen SNRs (dB).
    theta0, q : float
        The priors they give (docs/model.md §4), in the units of ``L`` and ``Y`` (for the
        "toolbox" convention, of ``Y / max|Y|``).
    log_likelihood : float
        Its value there: ``reconstruct(...).log_likelihood`` at ``theta0``, ``q``.
    landscape : pandas.DataFrame
        The coarse grid: columns ``pm_snr_db``, ``ep_snr_db``, ``theta0``, ``q``,
        ``log_likelihood``.
    convention : str
        The amplitude convention of the SNRs.
    criterion : {"likelihood", "discrepancy"}
        How the SNRs were chosen.
    at_bound : dict
        ``"pm_snr_db"`` and/or ``"ep_snr_db"`` -> ``"lower"`` or ``"upper"``: the searched
        SNRs chosen on (within 0.01 dB, ``BOUND_TOL_DB``, of) an end of their range. Empty when
        every searched SNR is inside its range; a fixed SNR is never listed.
    residual_energy : float
        ``sum_t ||C^{-1} (y_t - L x_{t|t})||^2`` at the chosen priors (``R = C C^T``): the
        discrepancy principle sets it to ``n_channels * n_times``.
    curve : pandas.DataFrame or None
        For ``"discrepancy"``: the PM-SNRs of the coarse grid, the EP-SNR the principle
        gives each (``ep_snr_db``) and the log-likelihood there. None for ``"likelihood"``.
    """

    pm_snr_db: float
    ep_snr_db: float
    theta0: float
    q: float
    log_likelihood: float
    landscape: Any
    convention: str
    criterion: str = "likelihood"
    at_bound: dict[str, str] = field(default_factory=dict)
    residual_energy: float = math.nan
    curve: Any = None

    def __repr__(self) -> str:
        bounds = ", ".join(f"{name} on its {end} bound" for name, end in self.at_bound.items())
        return (
            f"<TuneResult | PM-SNR {self.pm_snr_db:.2f} dB, EP-SNR {self.ep_snr_db:.2f} dB, "
            f"log-likelihood {self.log_likelihood:.6g}, by {self.criterion}"
            f"{'; ' + bounds if bounds else ''}>"
        )

    def _repr_html_(self) -> str:
        """The choice as a table, for notebooks (the grid stays in ``landscape``)."""
        bounds = ", ".join(f"{name}: {end}" for name, end in self.at_bound.items())
        rows = {
            "PM-SNR (dB)": f"{self.pm_snr_db:.2f}",
            "EP-SNR (dB)": f"{self.ep_snr_db:.2f}",
            "theta0": f"{self.theta0:.6g}",
            "q": f"{self.q:.6g}",
            "Log-likelihood": f"{self.log_likelihood:.6g}",
            "Criterion": self.criterion,
            "Convention": self.convention,
            "On a bound": bounds or "none",
            "Grid cells": len(self.landscape),
        }
        return html_table("TuneResult", rows)


def _search_range(name: str, value: Any) -> tuple[float, float]:
    """A fixed SNR (one number), a search range (lo, hi), lo < hi, or "auto"."""
    if isinstance(value, str) and value == "auto":
        return AUTO_RANGE_DB
    if np.ndim(value) == 0:
        return (check_db(name, value),) * 2
    if isinstance(value, str) or len(value) != 2:
        raise InputError(f"{name} must be a number or a range (lo, hi), got {describe(value)}")
    low, high = (check_db(f"{name}[{i}]", v) for i, v in enumerate(value))
    if not low < high:
        raise InputError(
            f"{name} must be a range (lo, hi) with lo < hi, got ({low:g}, {high:g}); give one "
            "number to fix it"
        )
    return low, high


def tune(
    L: ArrayLike,
    Y: ArrayLike,
    *,
    noise_std: float | None = None,
    noise_cov: ArrayLike | None = None,
    pm_snr_db: float | tuple[float, float] | str = AUTO_RANGE_DB,
    ep_snr_db: float | tuple[float, float] | str = AUTO_RANGE_DB,
    transition: float = 1.0,
    convention: str = "gain",
    grid: int = 13,
    criterion: str = "likelihood",
) -> TuneResult:
    r"""PM-SNR and EP-SNR chosen from the data by the marginal likelihood or the discrepancy.

    ``criterion="likelihood"`` (default): the SNRs that maximize the marginal likelihood of
    the data. A coarse grid of ``grid`` values per searched SNR, then a bounded refinement
    (``scipy.optimize.minimize``, L-BFGS-B, from the best cell). The likelihood judges the
    model ``y = L x + r`` with its priors; it cannot choose the standardization exponent or
    the smoother: they change the estimate shown, not the model, and leave the likelihood
    unchanged.

    ``criterion="discrepancy"``: Morozov's discrepancy principle for the process noise. At
    each PM-SNR, the EP-SNR at which the whitened residual of the filtered means equals
    its expected value under the noise model,

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

    A searched SNR chosen within 0.01 dB (``BOUND_TOL_DB``) of an end of its range raises a
    ``UserWarning`` that names it and the bound (widen the range to let the criterion
    decide), and is listed in the result's ``at_bound``. A fixed SNR never warns.

    Parameters
    ----------
    L : array_like, shape (n_channels, n_sources)
    Y : array_like, shape (n_channels, n_times)
    noise_std : float, optional
    noise_cov : array_like, shape (n_channels, n_channels), optional
        Give exactly one, as for :func:`skf_ref.reconstruct`.
    pm_snr_db, ep_snr_db : (float, float) or float or "auto"
        The range searched, in dB; a single number fixes that SNR; ``"auto"`` is the
        default range, (-20, 40) dB (``AUTO_RANGE_DB``).
    transition : float
        ``A = transition I``.
    convention : {"gain", "toolbox"}
        "gain" (default): SNRs of the whitened lead field, unit free. "toolbox": as the
        toolbox (docs/model.md §4): needs ``noise_std``; the data are divided by ``max|Y|``
        and ``theta0``, ``q`` and the likelihood are those of ``Y / max|Y|``.
    grid : int
        Values per searched SNR on the coarse grid, >= 2.
    criterion : {"likelihood", "discrepancy"}
        What chooses the SNRs (see above).

    Returns
    -------
    TuneResult

    Warns
    -----
    UserWarning
        When a searched SNR is chosen on a bound of its range.

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
    """
    check_choice("criterion", criterion, CRITERIA)
    check_choice("convention", convention, CONVENTIONS)
    grid = check_int("grid", grid, minimum=2)
    ranges = [_search_range("pm_snr_db", pm_snr_db), _search_range("ep_snr_db", ep_snr_db)]
    if np.ndim(transition) != 0:
        raise InputError(f"transition must be a scalar for tune, got {describe(transition)}")
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
    priors = _priors(model, basis, convention, data.shape[1])
    a = float(model.transition)

    def log_likelihoods(points: NDArray[np.float64]) -> NDArray[np.float64]:
        return basis.log_likelihood(data, *priors(points), a)

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
            return basis.residual_energy(data, *priors(points), a) - target

        best, best_value, curve = choose_on_curve(log_likelihoods, excess, axes[0], ranges)
    residual = basis.residual_energy(data, *priors(best[None]), a)[0]
    at_bound = _at_bound(best, ranges)
    _warn_at_bound(at_bound, best, ranges, criterion)
    return _result(
        cells, values, priors, best, best_value, convention, criterion, at_bound, residual, curve
    )


def _priors(
    model: StateSpaceModel, basis: SpectralBasis, convention: str, n_steps: int
) -> Callable[[ArrayLike], tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """(PM, EP) dB pairs (K, 2) -> theta0 (K,), q (K,), vectorized over the pairs."""
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

    def priors(points: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        pm, ep = np.asarray(points, dtype=float).T
        if convention == "toolbox":
            pm = np.minimum(pm, snr_db - 1.0)  # the toolbox's clamp
        theta0 = unit_theta0 * 10 ** (pm / 10)
        return theta0, unit_q * 10 ** (ep / 10) * theta0

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


def _at_bound(best: NDArray[np.float64], ranges: list[tuple[float, float]]) -> dict[str, str]:
    """Searched SNRs within BOUND_TOL_DB of an end of their range -> "lower" or "upper"."""
    out = {}
    for name, value, (low, high) in zip(("pm_snr_db", "ep_snr_db"), best, ranges, strict=True):
        if low < high:
            for end, bound in zip(_ENDS, (low, high), strict=True):
                if abs(value - bound) <= BOUND_TOL_DB:
                    out[name] = end
    return out


def _warn_at_bound(
    at_bound: dict[str, str],
    best: NDArray[np.float64],
    ranges: list[tuple[float, float]],
    criterion: str,
) -> None:
    """One UserWarning per SNR on a bound, pointing at the first caller outside skf_ref."""
    names = ("pm_snr_db", "ep_snr_db")
    for name, end in at_bound.items():
        i = names.index(name)
        low, high = ranges[i]
        bound = (low, high)[_ENDS.index(end)]
        if criterion == "discrepancy" and name == "ep_snr_db":
            why = "the filtered residual meets its expected value only there or beyond"
        elif criterion == "discrepancy":
            why = "the likelihood along the discrepancy curve is largest there or beyond"
        else:
            why = "the marginal likelihood is largest there or beyond"
        further = "below" if end == "lower" else "above"
        wider = (max(low - 20, -MAX_DB), high) if end == "lower" else (low, min(high + 20, MAX_DB))
        warnings.warn(
            f"tune: {name} = {best[i]:.2f} dB lies on the {end} bound {bound:g} dB of its "
            f"search range ({low:g}, {high:g}): {why}; widen {name} {further} {bound:g} dB "
            f"to let the data choose: {name}=({wider[0]:g}, {wider[1]:g}) in Python (tune, "
            f"apply_skf, make_skf_operator) or --{name.replace('_', '-')}="
            f"{wider[0]:g},{wider[1]:g} on the command line",
            UserWarning,
            stacklevel=caller_stacklevel(),
        )


def _result(
    cells: NDArray[np.float64],
    values: NDArray[np.float64],
    priors: Callable[[ArrayLike], tuple[NDArray[np.float64], NDArray[np.float64]]],
    best: NDArray[np.float64],
    best_value: float,
    convention: str,
    criterion: str,
    at_bound: dict[str, str],
    residual: float,
    curve: Any,
) -> TuneResult:
    import pandas as pd

    theta0, q = priors(cells)
    landscape = pd.DataFrame(
        dict(
            pm_snr_db=cells[:, 0],
            ep_snr_db=cells[:, 1],
            theta0=theta0,
            q=q,
            log_likelihood=values,
        )
    )
    (best_theta0,), (best_q,) = priors(best[None])
    return TuneResult(
        pm_snr_db=float(best[0]),
        ep_snr_db=float(best[1]),
        theta0=float(best_theta0),
        q=float(best_q),
        log_likelihood=best_value,
        landscape=landscape,
        convention=convention,
        criterion=criterion,
        at_bound=at_bound,
        residual_energy=float(residual),
        curve=curve,
    )


def choose_priors(
    L: ArrayLike,
    Y: ArrayLike,
    *,
    noise_std: float | None = None,
    noise_cov: ArrayLike | None = None,
    pm_snr_db: float | str | tuple[float, float],
    ep_snr_db: float | str | tuple[float, float],
    convention: str = "gain",
    criterion: str = "likelihood",
) -> tuple[float, float, TuneResult | None]:
    """``theta0, q`` from two SNRs, either of which may be ``"auto"``, and how they were chosen.

    The SNRs are those of the whitened lead field (docs/model.md §4): with ``noise_std``,
    exactly :func:`skf_ref.priors_from_snr`.

    Parameters
    ----------
    L : array_like, shape (n_channels, n_sources)
    Y : array_like, shape (n_channels, n_times)
    noise_std : float, optional
    noise_cov : array_like, shape (n_channels, n_channels), optional
        Give exactly one.
    pm_snr_db, ep_snr_db : float or "auto" or (float, float)
        A number fixes the SNR; ``"auto"`` or a range ``(low, high)`` is searched by
        :func:`tune`.
    convention : {"gain", "toolbox"}
        "toolbox" needs ``noise_std``.
    criterion : {"likelihood", "discrepancy"}
        How :func:`tune` chooses an ``"auto"`` SNR.

    Returns
    -------
    theta0, q : float
    tuning : TuneResult or None
        None when both SNRs were numbers.
    """
    check_choice("criterion", criterion, CRITERIA)
    if any(isinstance(v, str) or np.ndim(v) > 0 for v in (pm_snr_db, ep_snr_db)):
        result = tune(
            L,
            Y,
            noise_std=noise_std,
            noise_cov=noise_cov,
            pm_snr_db=pm_snr_db,
            ep_snr_db=ep_snr_db,
            convention=convention,
            criterion=criterion,
        )
        return result.theta0, result.q, result
    n_times = np.shape(Y)[-1]
    pm, ep = cast(float, pm_snr_db), cast(float, ep_snr_db)  # numbers: "auto" went to tune
    if noise_cov is None:
        return *priors_from_snr(L, cast(float, noise_std), pm, ep, n_times, convention), None
    if convention != "gain":
        raise InputError(f"convention={convention!r} needs noise_std, not noise_cov")
    model = StateSpaceModel.create(L, noise_cov=noise_cov, theta0=1.0, q=1.0)
    whitened = whitener(model.R)[0](model.L)
    return *priors_from_snr(whitened, 1.0, pm, ep, n_times), None
