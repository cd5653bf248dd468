"""Source regions of the P20/N20 study, and the checks of positions and amplitudes.

``amplitude`` is a position amplitude ``a_t(p)``, shape (n_positions, n_times): the
Euclidean norm of a position's standardized components
(:func:`skf_ref.method.amplitude_from_components`). ``positions`` are grid positions, shape
(n_positions, 3), and true positions shape (3,), both in metres. The region of a source is the
set of grid positions within ``radius_mm`` (15 mm) of its exact position (docs/model.md §6).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils.checks import InputError, check_array, check_int, check_real, check_vector

__all__ = [
    "DYNAMIC_RANGE_DB",
    "REGION_RADIUS_MM",
    "as_amplitude",
    "check_amplitude",
    "check_positions",
    "check_time_index",
    "region_db",
    "region_mask",
    "region_time_course",
]

#: Radius (mm) of a source's region.
REGION_RADIUS_MM = 15.0
#: Dynamic range (dB) within which a region counts as detected (the paper's figures).
DYNAMIC_RANGE_DB = 6.0


def check_positions(positions: ArrayLike, name: str = "positions") -> NDArray[np.float64]:
    """Check grid positions: a finite (n_positions, 3) array with at least one row.

    Parameters
    ----------
    positions : array_like, shape (n_positions, 3)
        Grid positions in metres.
    name : str
        The parameter's name in the error message.

    Returns
    -------
    positions : ndarray, shape (n_positions, 3)
        The positions as a float array.
    """
    pos = check_array(name, positions, ("n_positions", 3))
    if pos.shape[0] == 0:
        raise InputError(f"{name} must hold at least one position, got shape {pos.shape}")
    return pos


def check_amplitude(
    amplitude: ArrayLike, n_positions: int | str, name: str = "amplitude"
) -> NDArray[np.float64]:
    """Check a non-negative (n_positions, n_times) amplitude with at least one time.

    Parameters
    ----------
    amplitude : array_like, shape (n_positions, n_times)
        A position amplitude (a norm per position, so non-negative).
    n_positions : int or str
        The expected number of rows, or a name for any number.
    name : str
        The parameter's name in the error message.

    Returns
    -------
    amplitude : ndarray, shape (n_positions, n_times)
        The amplitude as a float array.
    """
    amp = check_array(name, amplitude, (n_positions, "n_times"))
    if amp.shape[1] == 0:
        raise InputError(f"{name} must hold at least one time, got shape {amp.shape}")
    if (amp < 0).any():
        raise InputError(f"{name} must be non-negative (a norm per position)")
    return amp


def check_time_index(name: str, index: int, n_times: int) -> int:
    """Check a time index: an integer in ``[0, n_times)``.

    Parameters
    ----------
    name : str
        The parameter's name in the error message.
    index : int
        The time index.
    n_times : int
        The number of times it indexes.

    Returns
    -------
    int
        ``index``.
    """
    return check_int(name, index, minimum=0, maximum=n_times - 1)


def _region(
    positions: NDArray[np.float64],
    true_position: ArrayLike,
    radius_mm: float,
    name: str = "true_position",
) -> NDArray[np.bool_]:
    mask = region_mask(positions, true_position, radius_mm)
    if not mask.any():
        raise InputError(
            f"positions: no grid position within {radius_mm:g} mm of {name}; the grid is "
            f"too coarse"
        )
    return mask


def as_amplitude(reconstruction: Any, n_positions: int) -> NDArray[np.float64]:
    """Position amplitude of a reconstruction object or an amplitude array.

    Parameters
    ----------
    reconstruction : object with ``amplitude(n_components)``, or ndarray
        E.g. ``skf_ref.Reconstruction`` (``reconstruction.amplitude(3)`` is used), or an
        amplitude of shape (n_positions, n_times).
    n_positions : int
        Expected number of positions.

    Returns
    -------
    amplitude : ndarray, shape (n_positions, n_times)
        The amplitude of each position at each time.

    Examples
    --------
    >>> as_amplitude(np.ones((2, 5)), 2).shape
    (2, 5)
    """
    if hasattr(reconstruction, "amplitude") and callable(reconstruction.amplitude):
        reconstruction = reconstruction.amplitude(3)
    amp = check_array("reconstruction amplitude", reconstruction, ("n_positions", "n_times"))
    if amp.shape[0] != n_positions:
        raise InputError(
            f"reconstruction amplitude must have shape (n_positions, n_times) with "
            f"n_positions={n_positions}, got shape {amp.shape} (pass an amplitude, not the "
            f"standardized components; see skf_ref.method.amplitude_from_components)"
        )
    return amp


def region_mask(
    positions: ArrayLike, true_position: ArrayLike, radius_mm: float = REGION_RADIUS_MM
) -> NDArray[np.bool_]:
    """Grid positions within `radius_mm` of a true position.

    Parameters
    ----------
    positions : ndarray, shape (n_positions, 3)
        Grid positions in metres.
    true_position : ndarray, shape (3,)
        Exact source position in metres.
    radius_mm : float
        Region radius in mm.

    Returns
    -------
    mask : ndarray of bool, shape (n_positions,)
        True at the positions within the region.

    Examples
    --------
    >>> region_mask(np.array([[0, 0, 0], [0.01, 0, 0], [0.02, 0, 0]]), np.zeros(3))
    array([ True,  True, False])
    """
    grid = check_positions(positions)
    true = check_vector("true_position", true_position, 3)
    radius = check_real("radius_mm", radius_mm, positive=True)
    return np.linalg.norm(grid - true, axis=1) * 1e3 <= radius


def region_time_course(
    amplitude: ArrayLike,
    positions: ArrayLike,
    true_position: ArrayLike,
    radius_mm: float = REGION_RADIUS_MM,
) -> NDArray[np.float64]:
    """Maximum amplitude over a source's region at each time.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_times)
        The amplitude of each position at each time.
    positions : ndarray, shape (n_positions, 3)
        Grid positions in metres.
    true_position : ndarray, shape (3,)
        Exact source position in metres.
    radius_mm : float
        Region radius in mm.

    Returns
    -------
    course : ndarray, shape (n_times,)
        The region's largest amplitude at each time.

    Examples
    --------
    >>> region_time_course(np.array([[1.0, 2.0], [5.0, 0.0]]),
    ...                    np.array([[0.0, 0, 0], [0.1, 0, 0]]), np.zeros(3))
    array([1., 2.])
    """
    positions = check_positions(positions)
    amplitude = check_amplitude(amplitude, len(positions))
    return amplitude[_region(positions, true_position, radius_mm)].max(axis=0)


def region_db(
    amplitude: ArrayLike,
    positions: ArrayLike,
    true_position: ArrayLike,
    index: int,
    radius_mm: float = REGION_RADIUS_MM,
) -> float:
    """A region's maximum at one time relative to the global maximum then, in dB.

    Returns ``20 log10(max_region a / max_all a)`` at time `index` (0 dB: the region holds
    the global maximum); ``-inf`` if the region's maximum is zero.

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
    radius_mm : float
        Region radius in mm.

    Returns
    -------
    db : float
        At most 0 dB.

    Examples
    --------
    >>> region_db(np.array([[1.0], [2.0]]), np.array([[0.0, 0, 0], [0.1, 0, 0]]),
    ...           np.zeros(3), 0)
    -6.020599913279624
    """
    positions = check_positions(positions)
    amplitude = check_amplitude(amplitude, len(positions))
    index = check_time_index("index", index, amplitude.shape[1])
    region = amplitude[_region(positions, true_position, radius_mm), index].max()
    if region == 0:
        return float("-inf")
    return float(20.0 * np.log10(region / amplitude[:, index].max()))
