"""Localization metrics for the P20/N20 scenario (docs/model.md §6).

``amplitude`` below is always a position amplitude ``a_t(p)``, shape (n_positions, n_times):
the Euclidean norm of a position's three standardized components
(:meth:`skf_ref.Reconstruction.amplitude`). ``positions`` are grid positions, shape
(n_positions, 3), and true positions shape (3,), both in metres; distances are reported in
mm. The region of a source is the set of grid positions within 15 mm of its exact position
(:mod:`skf_ref.study._regions`); a region "is detected" at a time when its maximum is within
``dynamic_range_db`` (6 dB, with dB = 20 log10 of an amplitude ratio) of the global maximum
at that time.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils.checks import InputError, check_array, check_real, check_vector
from ._regions import (
    DYNAMIC_RANGE_DB,
    as_amplitude,
    check_amplitude,
    check_positions,
    check_time_index,
    region_db,
    region_time_course,
)

__all__ = [
    "COLUMNS",
    "detected",
    "earth_movers_distance",
    "echo",
    "peak_localization_error",
    "separation",
    "summarize",
    "time_course_correlation",
]

#: Every column of :func:`summarize`: (name, meaning, unit, which way is better).
COLUMNS = (
    ("deep_error_mm", "distance from the deep source to the maximum at 1.5 ms", "mm", "lower"),
    (
        "superficial_error_mm",
        "distance from the superficial source to the maximum at 2.5 ms",
        "mm",
        "lower",
    ),
    (
        "deep_detected",
        "deep region within 6 dB of the global maximum at 1.5 ms",
        "bool",
        "true",
    ),
    (
        "superficial_detected",
        "superficial region within 6 dB of the global maximum at 2.5 ms",
        "bool",
        "true",
    ),
    ("deep_region_db", "deep region's maximum re. the global maximum at 1.5 ms", "dB", "higher"),
    (
        "superficial_region_db",
        "superficial region's maximum re. the global maximum at 2.5 ms",
        "dB",
        "higher",
    ),
    (
        "echo",
        "deep region's maximum at 2.5 ms over its maximum at 1.5 ms, minus the true ratio 0.25",
        "ratio",
        "closer to 0",
    ),
    (
        "deep_corr",
        "Pearson r of the deep region's maximum over time and |waveform|",
        "r",
        "higher",
    ),
    (
        "superficial_corr",
        "Pearson r of the superficial region's maximum over time and |waveform|",
        "r",
        "higher",
    ),
    (
        "separation",
        "deep detected at 1.5 ms, superficial at 2.5 ms, and deep not detected at 2.5 ms",
        "bool",
        "true",
    ),
    (
        "deep_region_at_superficial_peak_db",
        "deep region's maximum re. the global maximum at 2.5 ms (residual deep activity)",
        "dB",
        "lower",
    ),
)


def peak_localization_error(
    amplitude: ArrayLike, positions: ArrayLike, true_position: ArrayLike, peak_index: int
) -> float:
    """Distance (mm) from the true position to the amplitude's maximum at the peak time.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_times)
        The amplitude of each position at each time.
    positions : ndarray, shape (n_positions, 3)
        Grid positions in metres.
    true_position : ndarray, shape (3,)
        Exact source position in metres.
    peak_index : int
        Time index of the source's peak.

    Returns
    -------
    error_mm : float
        In mm; 0 when the maximum is at the true position.

    Examples
    --------
    >>> positions = np.array([[0.0, 0, 0], [0.02, 0, 0]])
    >>> peak_localization_error(np.array([[1.0], [3.0]]), positions, np.zeros(3), 0)
    20.0
    """
    grid = check_positions(positions)
    amp = check_amplitude(amplitude, len(grid))
    peak = check_time_index("peak_index", peak_index, amp.shape[1])
    true = check_vector("true_position", true_position, 3)
    best = grid[np.argmax(amp[:, peak])]
    return float(np.linalg.norm(best - true) * 1e3)


def detected(
    amplitude: ArrayLike,
    positions: ArrayLike,
    true_position: ArrayLike,
    index: int,
    dynamic_range_db: float = DYNAMIC_RANGE_DB,
) -> bool:
    """Whether a source's region is within `dynamic_range_db` of the global max at `index`.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_times)
        The amplitude of each position at each time.
    positions : ndarray, shape (n_positions, 3)
        Grid positions in metres.
    true_position : ndarray, shape (3,)
        Exact source position in metres.
    index : int
        Time index.
    dynamic_range_db : float
        Dynamic range in dB (amplitude dB, 20 log10).

    Returns
    -------
    detected : bool
        Whether the region's maximum is within the dynamic range.

    Examples
    --------
    >>> positions = np.array([[0.0, 0, 0], [0.1, 0, 0]])
    >>> detected(np.array([[0.6], [1.0]]), positions, np.zeros(3), 0)
    True
    >>> detected(np.array([[0.4], [1.0]]), positions, np.zeros(3), 0)
    False
    """
    dynamic_range = check_real("dynamic_range_db", dynamic_range_db, positive=True)
    return bool(region_db(amplitude, positions, true_position, index) >= -dynamic_range)


def echo(
    amplitude: ArrayLike,
    positions: ArrayLike,
    deep_position: ArrayLike,
    deep_peak_index: int,
    superficial_peak_index: int,
    true_ratio: float,
) -> float:
    """Deep region's max at the superficial peak over its max at the deep peak, minus truth.

    Zero for a reconstruction whose deep region follows the true deep waveform; positive when
    deep activity lingers ("echo"). NaN if the deep region's maximum at its peak is zero.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_times)
        The amplitude of each position at each time.
    positions : ndarray, shape (n_positions, 3)
        Grid positions in metres.
    deep_position : ndarray, shape (3,)
        Exact deep source position in metres.
    deep_peak_index, superficial_peak_index : int
        Time indices of the two peaks.
    true_ratio : float
        ``|w_deep(superficial peak)| / |w_deep(deep peak)|`` (0.25 for the default pulses).

    Returns
    -------
    echo : float
        The ratio minus ``true_ratio``; NaN if undefined.

    Examples
    --------
    >>> echo(np.array([[2.0, 1.0]]), np.zeros((1, 3)), np.zeros(3), 0, 1, 0.25)
    0.25
    """
    course = region_time_course(amplitude, positions, deep_position)
    deep = check_time_index("deep_peak_index", deep_peak_index, course.size)
    superficial = check_time_index("superficial_peak_index", superficial_peak_index, course.size)
    if course[deep] == 0:
        return float("nan")
    return float(course[superficial] / course[deep] - true_ratio)


def time_course_correlation(
    amplitude: ArrayLike, positions: ArrayLike, true_position: ArrayLike, true_waveform: ArrayLike
) -> float:
    """Pearson correlation of a region's max over time with the true waveform's magnitude.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_times)
        The amplitude of each position at each time.
    positions : ndarray, shape (n_positions, 3)
        Grid positions in metres.
    true_position : ndarray, shape (3,)
        Exact source position in metres.
    true_waveform : ndarray, shape (n_times,)
        The source's moment over time (any unit).

    Returns
    -------
    r : float
        NaN if either time course is constant.

    Examples
    --------
    >>> amp = np.array([[0.0, 2.0, 4.0]])
    >>> r = time_course_correlation(amp, np.zeros((1, 3)), np.zeros(3), [0.0, -1.0, -2.0])
    >>> round(r, 12)
    1.0
    """
    course = region_time_course(amplitude, positions, true_position)
    wave = np.abs(check_array("true_waveform", true_waveform, ("n_times",)))
    if wave.shape != course.shape:
        raise InputError(
            f"true_waveform must have shape (n_times,) = ({course.size},), got {wave.shape}"
        )
    course, wave = course - course.mean(), wave - wave.mean()
    norm = np.linalg.norm(course) * np.linalg.norm(wave)
    return float(course @ wave / norm) if norm > 0 else float("nan")


def separation(
    amplitude: ArrayLike,
    positions: ArrayLike,
    deep_position: ArrayLike,
    superficial_position: ArrayLike,
    deep_peak_index: int,
    superficial_peak_index: int,
    dynamic_range_db: float = DYNAMIC_RANGE_DB,
) -> bool:
    """Deep detected at its peak, superficial at its peak, deep not detected at the latter.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_times)
        The amplitude of each position at each time.
    positions : ndarray, shape (n_positions, 3)
        Grid positions in metres.
    deep_position, superficial_position : ndarray, shape (3,)
        Exact source positions in metres.
    deep_peak_index, superficial_peak_index : int
        Time indices of the two peaks.
    dynamic_range_db : float
        Dynamic range in dB.

    Returns
    -------
    separated : bool
        Whether all three hold.

    Examples
    --------
    >>> positions = np.array([[0.0, 0, 0], [0.1, 0, 0]])
    >>> amp = np.array([[1.0, 0.2], [0.1, 1.0]])
    >>> separation(amp, positions, positions[0], positions[1], 0, 1)
    True
    """
    args = (amplitude, positions)
    return (
        detected(*args, deep_position, deep_peak_index, dynamic_range_db)
        and detected(*args, superficial_position, superficial_peak_index, dynamic_range_db)
        and not detected(*args, deep_position, superficial_peak_index, dynamic_range_db)
    )


def earth_movers_distance(
    amplitude: ArrayLike,
    positions: ArrayLike,
    points: ArrayLike,
    weights: ArrayLike | None = None,
) -> float:
    """Earth mover's distance (mm) between an estimate's spatial distribution and the truth's.

    The exact Wasserstein-1 distance, with Euclidean ground distance, between the estimate
    (mass ``amplitude / sum(amplitude)`` at each grid position) and the truth (mass
    ``weights / sum(weights)`` at each true point): the least mean distance the estimate's
    mass must travel to become the truth. One true point: the amplitude-weighted mean
    distance to it. Two: a closed form (sort and fill). More: the transportation problem,
    solved by :func:`scipy.optimize.linprog` (HiGHS).

    Parameters
    ----------
    amplitude : array_like, shape (n_positions,)
        Non-negative amplitudes of the estimate at one sample (e.g. the norm of each
        position's components); normalized to sum 1 here.
    positions : array_like, shape (n_positions, 3)
        Grid positions in metres.
    points : array_like, shape (n_points, 3)
        The true sources' exact points in metres, at least one.
    weights : array_like, shape (n_points,), optional
        Non-negative masses of the true sources (e.g. their moments' magnitudes at that
        sample), not all zero; normalized to sum 1 here. Points of zero weight are dropped.
        None: equal masses.

    Returns
    -------
    emd_mm : float
        The optimal transport cost in mm; 0 when the estimate's mass sits exactly on the
        true points in the true proportions. NaN when the amplitude is zero everywhere (an
        empty estimate has no distribution).

    Examples
    --------
    >>> positions = np.array([[0.0, 0, 0], [0.01, 0, 0], [0.02, 0, 0]])
    >>> earth_movers_distance([0.0, 1.0, 1.0], positions, [[0.0, 0, 0]])
    15.0
    >>> earth_movers_distance([1.0, 0.0, 1.0], positions, [[0.0, 0, 0], [0.01, 0, 0]])
    5.0
    """
    grid = check_positions(positions)
    amp = check_array("amplitude", amplitude, ("n_positions",))
    if amp.shape != (len(grid),):
        raise InputError(
            f"amplitude must have shape (n_positions,) = ({len(grid)},), got {amp.shape}"
        )
    if (amp < 0).any():
        raise InputError("amplitude must be non-negative (a norm per position)")
    true = check_array("points", points, ("n_points", 3))
    if len(true) == 0:
        raise InputError(f"points must hold at least one point, got shape {true.shape}")
    if weights is None:
        mass = np.full(len(true), 1.0 / len(true))
    else:
        mass = check_array("weights", weights, ("n_points",))
        if mass.shape != (len(true),):
            raise InputError(
                f"weights must have shape (n_points,) = ({len(true)},), got {mass.shape}"
            )
        if (mass < 0).any() or not (mass > 0).any():
            raise InputError("weights must be non-negative and not all zero")
        true, mass = true[mass > 0], _normalized(mass[mass > 0])
    if not (amp > 0).any():
        return float("nan")
    amp = _normalized(amp)
    # distance (mm) from each point (row) to each position: coordinate by coordinate (numpy
    # broadcasts (n, 3) - (3,) slowly), and from differences, not |p|^2 - 2 p.q + |q|^2,
    # whose cancellation loses the digits of nearby pairs
    distance = np.empty((len(true), len(grid)))
    for row, point in zip(distance, true, strict=True):
        np.sqrt(sum((grid[:, k] - point[k]) ** 2 for k in range(3)), out=row)
    distance *= 1e3
    if len(true) == 1:
        return float(amp @ distance[0])
    if len(true) == 2:
        return _two_points(amp, distance, mass[0])
    return _transport(amp, distance, mass)


def _normalized(mass: NDArray[np.float64]) -> NDArray[np.float64]:
    mass = mass / mass.max()  # first, so that a sum of huge amplitudes cannot overflow
    return mass / mass.sum()


def _two_points(amp: NDArray[np.float64], distance: NDArray[np.float64], first: float) -> float:
    """Exact transport of ``amp`` to two points (``distance`` rows), ``first`` to the first."""
    # Sending x_p <= a_p from position p to the first point and the rest to the second costs
    # sum_p a_p d2(p) + sum_p x_p c_p, c = d1 - d2, subject to sum_p x_p = first: a fractional
    # knapsack. Filling in increasing c is optimal: if x_q > 0 while x_p < a_p for some
    # c_p < c_q, moving mass from q to p lowers the cost, so an optimum fills every p before
    # any q of larger c; ties in c cost the same whichever is filled first.
    gain = distance[0] - distance[1]
    order = np.argsort(gain)
    sorted_amp = amp[order]
    before = np.cumsum(sorted_amp) - sorted_amp  # mass filled before each position
    sent = np.minimum(np.maximum(first - before, 0.0), sorted_amp)
    return float(amp @ distance[1] + sent @ gain[order])


def _transport(
    amp: NDArray[np.float64], distance: NDArray[np.float64], mass: NDArray[np.float64]
) -> float:
    """Exact transport of ``amp`` to ``mass`` (``distance`` rows) by linear program."""
    from scipy import sparse
    from scipy.optimize import linprog

    keep = amp > 0  # positions without mass add neither cost nor constraint
    amp, cost = amp[keep], distance[:, keep].T.ravel()
    n_positions, n_points = amp.size, mass.size
    # flow x[p, j] flattened position-major; each position sends its mass, each point
    # receives its own (one of the n_positions + n_points equalities is redundant: HiGHS
    # takes it)
    sends = sparse.kron(sparse.eye(n_positions), np.ones((1, n_points)))
    receives = sparse.kron(np.ones((1, n_positions)), sparse.eye(n_points))
    result = linprog(
        cost,
        A_eq=sparse.vstack([sends, receives]).tocsr(),
        b_eq=np.concatenate([amp, mass]),
        bounds=(0, None),
        method="highs",
    )
    if result.status != 0:  # a transportation problem is always feasible and bounded
        raise RuntimeError(f"earth_movers_distance: linprog failed: {result.message}")
    return float(result.fun)


def summarize(reconstruction: Any, head: Any, truth: Any) -> dict[str, Any]:
    """All metrics for both sources of the P20/N20 scenario.

    Parameters
    ----------
    reconstruction : object with ``amplitude(n_components)``, or ndarray
        See ``as_amplitude``; amplitude shape (n_positions, n_times).
    head : HeadModel
        Anything with ``positions`` (ndarray, shape (n_positions, 3), metres).
    truth : Truth
        Anything with ``positions`` (2, 3) m, ``waveforms`` (2, n_times), ``peak_times``
        (2,) s and ``times`` (n_times,) s; index 0 is the deep source, 1 the superficial.

    Returns
    -------
    summary : dict
        Plain floats and bools, in this order: ``deep_error_mm``, ``superficial_error_mm``
        (peak localization errors), ``deep_detected``, ``superficial_detected``,
        ``deep_region_db``, ``superficial_region_db`` (region max at own peak re. global
        max, dB), ``echo``, ``deep_corr``, ``superficial_corr``, ``separation``,
        ``deep_region_at_superficial_peak_db``.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> positions = np.array([[0.0, 0, 0], [0.1, 0, 0]])
    >>> truth = SimpleNamespace(positions=positions, times=np.array([0.0, 1.0]),
    ...     peak_times=np.array([0.0, 1.0]), waveforms=np.array([[1.0, 0.25], [0.0, 1.0]]))
    >>> summary = summarize(np.array([[1.0, 0.25], [0.0, 1.0]]),
    ...                     SimpleNamespace(positions=positions), truth)
    >>> summary["deep_error_mm"], summary["echo"], summary["separation"]
    (0.0, 0.0, True)
    """
    positions = check_positions(head.positions, "head.positions")
    times = check_array("truth.times", truth.times, ("n_times",))
    true_positions = check_array("truth.positions", truth.positions, ("n_sources", 3))
    waveforms = check_array("truth.waveforms", truth.waveforms, ("n_sources", "n_times"))
    peak_times = check_array("truth.peak_times", truth.peak_times, ("n_sources",))
    if true_positions.shape != (2, 3) or waveforms.shape != (2, times.size):
        raise InputError(
            f"truth must hold 2 sources: positions (2, 3) and waveforms (2, {times.size}), "
            f"got {true_positions.shape} and {waveforms.shape}"
        )
    if peak_times.shape != (2,):
        raise InputError(f"truth.peak_times must have shape (2,), got {peak_times.shape}")
    amplitude = check_amplitude(as_amplitude(reconstruction, len(positions)), len(positions))
    if amplitude.shape[1] != times.size:
        raise InputError(
            f"reconstruction amplitude must have shape (n_positions, n_times) = "
            f"({positions.shape[0]}, {times.size}), got shape {amplitude.shape}"
        )
    (i_deep, i_sup) = (int(np.abs(times - t).argmin()) for t in peak_times)
    (deep, sup), (w_deep, w_sup) = true_positions, waveforms
    if w_deep[i_deep] == 0:
        raise InputError("truth.waveforms: the deep waveform is zero at its peak time")
    args = (amplitude, positions)
    deep_db = region_db(*args, deep, i_deep)
    sup_db = region_db(*args, sup, i_sup)
    return {
        "deep_error_mm": peak_localization_error(*args, deep, i_deep),
        "superficial_error_mm": peak_localization_error(*args, sup, i_sup),
        "deep_detected": bool(deep_db >= -DYNAMIC_RANGE_DB),
        "superficial_detected": bool(sup_db >= -DYNAMIC_RANGE_DB),
        "deep_region_db": deep_db,
        "superficial_region_db": sup_db,
        "echo": echo(*args, deep, i_deep, i_sup, abs(w_deep[i_sup]) / abs(w_deep[i_deep])),
        "deep_corr": time_course_correlation(*args, deep, w_deep),
        "superficial_corr": time_course_correlation(*args, sup, w_sup),
        "separation": separation(*args, deep, sup, i_deep, i_sup),
        "deep_region_at_superficial_peak_db": region_db(*args, deep, i_sup),
    }
