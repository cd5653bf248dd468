"""Localization metrics for the P20/N20 scenario (docs/model.md §6).

``amplitude`` below is always a position amplitude ``a_t(p)``, shape (n_positions, n_times):
the Euclidean norm of a position's three standardized components
(:meth:`skf_ref.Reconstruction.amplitude`). ``positions`` are grid positions, shape
(n_positions, 3), and true positions shape (3,), both in metres; distances are reported in
mm. The region of a source is the set of grid positions within 15 mm of its exact position
(:mod:`skf_ref.study.regions`); a region "is detected" at a time when its maximum is within
``dynamic_range_db`` (6 dB, with dB = 20 log10 of an amplitude ratio) of the global maximum
at that time.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._utils.checks import InputError, check_array, check_real, check_vector
from .regions import (
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


def summarize(reconstruction: Any, head: Any, truth: Any) -> dict[str, Any]:
    """All metrics for both sources of the P20/N20 scenario.

    Parameters
    ----------
    reconstruction : object with ``amplitude(n_components)``, or ndarray
        See :func:`as_amplitude`; amplitude shape (n_positions, n_times).
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
