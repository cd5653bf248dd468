"""Resolution metrics of many single-source estimates at once.

Where the maximum lies, how far the estimate spreads, and how much of it reaches the
thalamus. Every function takes ``amplitude``, shape (n_positions, n_runs): the position
amplitudes of many estimates at one time each (one column per run: the norm of a position's
components, ``position_amplitudes``), the grid ``positions`` (n_positions, 3) and the
runs' exact source points (n_runs, 3), in metres; distances come out in mm. They are the
vectorized counterparts, at one time, of :mod:`skf_ref.study._metrics` (same definitions):

- :func:`peak_errors`: distance from the source to the position of the maximum;
- :func:`spatial_dispersion`: ``sqrt(sum_p a_p^2 d_p^2 / sum_p a_p^2)`` (Molins et al. 2008,
  NeuroImage 42: 1069-1077; Hauk et al. 2019, NeuroImage 191: 631-649), with ``d_p`` the
  distance from the source to position p;
- :func:`level_db`: a set of positions' maximum re. the map's maximum (dB); with the
  thalamus as the set and cortical sources as the runs, the cortex-to-thalamus cross-talk.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils.checks import InputError

__all__ = ["level_db", "peak_errors", "position_amplitudes", "spatial_dispersion"]


def position_amplitudes(z: ArrayLike, n_orient: int = 3) -> NDArray[np.float64]:
    """Norm of each position's components: (n_positions * n_orient, ...) -> (n_positions, ...).

    Parameters
    ----------
    z : array_like, shape (n_positions * n_orient, ...)
        Components, position-major (a position's ``n_orient`` rows together).
    n_orient : int
        Components per position.

    Returns
    -------
    ndarray, shape (n_positions, ...)
        The Euclidean norm over each position's components.

    Examples
    --------
    >>> position_amplitudes(np.array([[3.0], [4.0], [0.0], [0.0], [0.0], [1.0]]))
    array([[5.],
           [1.]])
    """
    z = np.asarray(z, dtype=float)
    if z.shape[0] % n_orient:
        raise InputError(f"z must have a multiple of {n_orient} rows, got shape {z.shape}")
    blocks = z.reshape(z.shape[0] // n_orient, n_orient, *z.shape[1:])
    return np.sqrt(np.square(blocks).sum(axis=1))


def _check(
    amplitude_: ArrayLike, positions_: ArrayLike, points_: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    amplitude = np.asarray(amplitude_, dtype=float)
    positions = np.asarray(positions_, dtype=float)
    points = np.asarray(points_, dtype=float)
    if amplitude.ndim != 2 or amplitude.shape[0] != len(positions):
        raise InputError(
            f"amplitude must have shape (n_positions, n_runs) = ({len(positions)}, n_runs), "
            f"got {amplitude.shape}"
        )
    if points.shape != (amplitude.shape[1], 3):
        raise InputError(
            f"points must have shape (n_runs, 3) = ({amplitude.shape[1]}, 3), got {points.shape}"
        )
    return amplitude, positions, points


def peak_errors(
    amplitude: ArrayLike, positions: ArrayLike, points: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Distance (mm) from each run's source to the position of its maximum.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_runs)
        Position amplitudes, one column per run (``position_amplitudes``).
    positions : ndarray, shape (n_positions, 3)
        The grid, m.
    points : ndarray, shape (n_runs, 3)
        Each run's exact source point, m.

    Returns
    -------
    errors : ndarray, shape (n_runs,)
        NaN where a run's amplitude is zero everywhere (no estimate).
    peak : ndarray of int, shape (n_runs,)
        The position of the maximum (the first on a tie).

    Examples
    --------
    >>> positions = np.array([[0.0, 0, 0], [0.02, 0, 0]])
    >>> peak_errors(np.array([[1.0, 3.0], [3.0, 1.0]]), positions, np.zeros((2, 3)))
    (array([20.,  0.]), array([1, 0]))
    """
    a, grid, x = _check(amplitude, positions, points)
    peak = a.argmax(axis=0)
    errors = np.linalg.norm(grid[peak] - x, axis=1) * 1e3
    return np.where(a.max(axis=0) > 0, errors, np.nan), peak


def spatial_dispersion(
    amplitude: ArrayLike, positions: ArrayLike, points: ArrayLike
) -> NDArray[np.float64]:
    """Spatial dispersion (mm): the amplitude-weighted RMS distance from the source.

    ``SD = sqrt(sum_p a_p^2 d_p^2 / sum_p a_p^2)``; NaN for an all-zero run.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_runs)
        Position amplitudes, one column per run (``position_amplitudes``).
    positions : ndarray, shape (n_positions, 3)
        The grid, m.
    points : ndarray, shape (n_runs, 3)
        Each run's exact source point, m.

    Returns
    -------
    ndarray, shape (n_runs,)
        The dispersion of each run, mm.

    Examples
    --------
    >>> positions = np.array([[0.0, 0, 0], [0.01, 0, 0]])
    >>> spatial_dispersion(np.array([[1.0], [1.0]]), positions, np.zeros((1, 3)))
    array([7.07106781])
    """
    a, grid, x = _check(amplitude, positions, points)
    power = a**2
    total = power.sum(axis=0)
    squared = ((grid**2).sum(axis=1)[:, None] - 2 * grid @ x.T) + (x**2).sum(axis=1)[None]
    spread = np.einsum("pr,pr->r", power, np.maximum(squared, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, np.sqrt(spread / total) * 1e3, np.nan)


def level_db(amplitude: ArrayLike, mask: ArrayLike) -> NDArray[np.float64]:
    """The maximum over the positions of ``mask`` re. the maximum over all, in dB, per run.

    0 dB: the set holds the map's maximum; ``-inf``: the set is empty of activity.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_runs)
        Position amplitudes, one column per run.
    mask : ndarray of bool, shape (n_positions,)
        The set of positions (e.g. the thalamus'), at least one.

    Returns
    -------
    ndarray, shape (n_runs,)
        The level of each run, dB.

    Examples
    --------
    >>> level_db(np.array([[1.0, 2.0], [2.0, 2.0]]), np.array([True, False]))
    array([-6.02059991,  0.        ])
    """
    amplitude = np.asarray(amplitude, dtype=float)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != amplitude.shape[:1] or not mask.any():
        raise InputError(
            f"mask must be a boolean array of shape ({amplitude.shape[0]},) with a True entry"
        )
    inside, overall = amplitude[mask].max(axis=0), amplitude.max(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(overall > 0, 20 * np.log10(inside / overall), -np.inf)
