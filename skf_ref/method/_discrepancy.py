"""Morozov's discrepancy principle for the process noise (docs/model.md §4).

At a given PM-SNR, the EP-SNR at which the whitened residual of the filtered means, ``sum_t
||C^{-1} (y_t - L x_{t|t})||^2``, equals its expected value under the noise model, ``n_channels *
n_times``; over a range of PM-SNRs, the one of largest marginal likelihood along the curve of those
solutions. :func:`skf_ref.tune` (``criterion="discrepancy"``) calls
:func:`choose_on_curve` with the residual and the likelihood of
:class:`skf_ref.method.SpectralBasis`; the functions here see only SNRs in dB
and the values of those two sums, batched over (PM, EP) pairs.
"""

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

_Curve = Callable[[NDArray[np.float64]], NDArray[np.float64]]
_Range = tuple[float, float]

__all__ = ["choose_on_curve", "discrepancy_ep", "roots"]

#: Width (dB) of the last bracket of the discrepancy's EP-SNR: the residual then meets its
#: target to about 1e-11 relative (its slope is below 1 per dB).
ROOT_TOL_DB = 1e-10
#: Steps of the root search at most (it takes about 10 on the P20/N20 data).
ROOT_STEPS = 200
#: Tolerance (dB) of the PM-SNR along the curve (Brent's bounded search).
PM_TOL_DB = 1e-4


def choose_on_curve(
    log_likelihoods: _Curve,
    excess: _Curve,
    pm_axis: NDArray[np.float64],
    ranges: Sequence[_Range],
) -> tuple[NDArray[np.float64], float, Any]:
    """The discrepancy's EP-SNR at each PM-SNR, and the PM-SNR of largest likelihood.

    The PM-SNRs considered are those whose EP-SNR solves the principle inside its range
    (all of them when none of the grid's does): the grid's, then Brent's bounded search
    between the best one's neighbours, a neighbour replaced by the PM-SNR between them at
    which the solution reaches an end of the EP range when the neighbour has none.

    Parameters
    ----------
    log_likelihoods, excess : callable
        (K, 2) array of (PM, EP) pairs in dB -> (K,): the log-likelihood, and the residual
        energy minus its target ``n_channels * n_times``.
    pm_axis : ndarray, shape (n_pm,)
        The PM-SNRs of the coarse grid (dB), increasing; one value for a fixed PM-SNR.
    ranges : ((float, float), (float, float))
        The PM and EP ranges (dB); ``lo == hi`` for a fixed SNR.

    Returns
    -------
    best : ndarray, shape (2,)
        The chosen (PM, EP).
    log_likelihood : float
        Its log-likelihood.
    curve : pandas.DataFrame
        Over ``pm_axis``: ``pm_snr_db``, ``ep_snr_db`` (the solution, or the nearest end of
        the EP range), ``log_likelihood`` and ``solved`` (whether the range held a root).
    """
    import pandas as pd
    from scipy.optimize import minimize_scalar

    pm_range, ep_range = ranges

    def along(
        pm: Any,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
        pm = np.asarray(pm, dtype=float)
        ep, solved = discrepancy_ep(excess, pm, ep_range)
        points = np.column_stack([pm, ep])
        return points, log_likelihoods(points), solved

    points, values, solved = along(pm_axis)
    usable = solved if solved.any() else np.ones(len(pm_axis), dtype=bool)
    k = int(np.argmax(np.where(usable, values, -np.inf)))
    best, best_value = points[k], float(values[k])
    if pm_range[0] < pm_range[1]:
        ends = []
        for i in (max(k - 1, 0), min(k + 1, len(pm_axis) - 1)):
            edge = points[i, 1] if not usable[i] else None  # the EP end it stopped at
            ends.append(
                pm_axis[i] if edge is None else _edge(excess, pm_axis[k], pm_axis[i], edge)
            )
        if ends[0] < ends[1]:
            solution = minimize_scalar(
                lambda pm: -along([pm])[1][0],
                bounds=ends,
                method="bounded",
                options=dict(xatol=PM_TOL_DB),
            )
            ends.append(solution.x)
        # Brent never evaluates the ends; where the curve leaves the EP range, EP-SNR is
        # that end to within the root's tolerance: the point is on the curve
        candidates, candidate_values, _ = along(ends)
        j = int(np.argmax(candidate_values))
        if candidate_values[j] > best_value:  # else the grid's point, maybe on a bound
            best, best_value = candidates[j], float(candidate_values[j])
    curve = pd.DataFrame(
        dict(pm_snr_db=points[:, 0], ep_snr_db=points[:, 1], log_likelihood=values, solved=solved)
    )
    return best, best_value, curve


def discrepancy_ep(
    excess: _Curve, pm: NDArray[np.float64], ep_range: _Range
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The EP-SNR at which ``excess`` (residual minus its target) vanishes, at each PM-SNR.

    Where the ends of the EP range bracket a sign change, :func:`roots` (all PM-SNRs at
    once); elsewhere the end of smaller ``|excess|``, where the residual comes nearest to
    its target (it falls as EP-SNR grows: the root lies below the range when the lower end
    is already under the target, above it when the upper end is still over it).

    Parameters
    ----------
    excess : callable
        (K, 2) array of (PM, EP) pairs in dB -> (K,).
    pm : ndarray, shape (K,)
    ep_range : (float, float)
        ``lo == hi`` for a fixed EP-SNR, which is returned as it is, as solved.

    Returns
    -------
    ep : ndarray, shape (K,)
    solved : ndarray of bool, shape (K,)
        Whether the range held a sign change.
    """
    low, high = ep_range
    if low == high:
        return np.full(len(pm), low), np.ones(len(pm), dtype=bool)
    f_low = excess(np.column_stack([pm, np.full(len(pm), low)]))
    f_high = excess(np.column_stack([pm, np.full(len(pm), high)]))
    out = np.where(np.abs(f_low) <= np.abs(f_high), low, high)
    solved = np.sign(f_low) != np.sign(f_high)
    rows = np.flatnonzero(solved)
    if rows.size:
        out[rows] = roots(
            lambda ep: excess(np.column_stack([pm[rows], ep])),
            np.full(rows.size, low),
            np.full(rows.size, high),
        )
    return out, solved


def _edge(excess: _Curve, solved_pm: float, unsolved_pm: float, ep_end: float) -> float:
    """The PM-SNR between the two where the discrepancy's EP-SNR reaches ``ep_end``."""
    pms = np.array([solved_pm, unsolved_pm])
    signs = np.sign(excess(np.column_stack([pms, [ep_end, ep_end]])))
    if signs[0] == signs[1]:  # no crossing on this side: keep the grid's point
        return solved_pm
    low, high = min(pms), max(pms)
    (root,) = roots(
        lambda pm: excess(np.column_stack([pm, [ep_end]])), np.array([low]), np.array([high])
    )
    return root


def roots(
    f: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Where ``f`` changes sign in each bracket ``[low, high]``, to ``ROOT_TOL_DB``.

    Regula falsi with the Illinois modification, all brackets at once: like bisection, each
    step keeps a sign change inside the bracket, so it cannot leave it, but the brackets
    close superlinearly (an end that stays twice has its value halved), in about ten
    steps instead of bisection's forty over 60 dB.

    Parameters
    ----------
    f : callable
        (K,) points -> (K,) values, vectorized.
    low, high : ndarray, shape (K,)
        Brackets, ``f(low)`` and ``f(high)`` of opposite signs (or one of them 0).

    Returns
    -------
    ndarray, shape (K,)

    Examples
    --------
    >>> x = roots(lambda x: x**2 - np.array([2.0, 9.0]), np.zeros(2), np.full(2, 5.0))
    >>> bool(np.allclose(x, [np.sqrt(2), 3.0], rtol=0, atol=1e-10))
    True
    """
    f_low, f_high = f(low), f(high)
    x = np.where(np.abs(f_low) <= np.abs(f_high), low, high)
    moved = np.zeros(len(low))  # which end the last step replaced: -1 low, +1 high
    for _ in range(ROOT_STEPS):
        open_ = (high - low > ROOT_TOL_DB) & (f_low != 0) & (f_high != 0)
        if not open_.any():
            break
        secant = (low * f_high - high * f_low) / np.where(open_, f_high - f_low, 1.0)
        x = np.where(open_, np.clip(secant, low, high), x)
        f_x = f(x)
        to_high = open_ & (np.sign(f_x) == np.sign(f_high))  # x replaces the upper end
        to_low = open_ & ~to_high
        f_low = np.where(to_high & (moved == 1), f_low / 2, f_low)
        f_high = np.where(to_low & (moved == -1), f_high / 2, f_high)
        high, f_high = np.where(to_high, x, high), np.where(to_high, f_x, f_high)
        low, f_low = np.where(to_low, x, low), np.where(to_low, f_x, f_low)
        moved = np.where(to_high, 1.0, np.where(to_low, -1.0, moved))
    return np.where(f_low == 0, low, np.where(f_high == 0, high, x))
