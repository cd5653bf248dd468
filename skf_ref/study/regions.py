"""Source regions of the P20/N20 study, and the checks of positions and amplitudes.

``amplitude`` is a position amplitude ``a_t(p)``, shape (n_positions, n_times): the
Euclidean norm of a position's standardized components
(:func:`skf_ref.method.amplitude_from_components`). ``positions`` are grid positions, shape
(n_positions, 3), and true positions shape (3,), both in metres. The region of a source is the
set of grid positions within ``radius_mm`` (15 mm) of its exact position (docs/model.md §6).
"""

from __future__ import annotations

import numpy as np

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


def check_positions(positions, name="positions"):
    """Grid positions: a finite (n_positions, 3) array with at least one row."""
    pos = check_array(name, positions, ("n_positions", 3))
    if pos.shape[0] == 0:
        raise InputError(f"{name} must hold at least one position, got shape {pos.shape}")
    return pos


def check_amplitude(amplitude, n_positions, name="amplitude"):
    """A non-negative (n_positions, n_times) amplitude with at least one time."""
    amp = check_array(name, amplitude, (n_positions, "n_times"))
    if amp.shape[1] == 0:
        raise InputError(f"{name} must hold at least one time, got shape {amp.shape}")
    if (amp < 0).any():
        raise InputError(f"{name} must be non-negative (a norm per position)")
    return amp


def check_time_index(name, index, n_times):
    """A time index in ``[0, n_times)``."""
    return check_int(name, index, minimum=0, maximum=n_times - 1)


def _region(positions, true_position, radius_mm, name="true_position"):
    mask = region_mask(positions, true_position, radius_mm)
    if not mask.any():
        raise InputError(
            f"positions: no grid position within {radius_mm:g} mm of {name}; the grid is "
            f"too coarse"
        )
    return mask


def as_amplitude(reconstruction, n_positions):
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


def region_mask(positions, true_position, radius_mm=REGION_RADIUS_MM):
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

    Examples
    --------
    >>> region_mask(np.array([[0, 0, 0], [0.01, 0, 0], [0.02, 0, 0]]), np.zeros(3))
    array([ True,  True, False])
    """
    positions = check_positions(positions)
    true_position = check_vector("true_position", true_position, 3)
    radius_mm = check_real("radius_mm", radius_mm, positive=True)
    return np.linalg.norm(positions - true_position, axis=1) * 1e3 <= radius_mm


def region_time_course(amplitude, positions, true_position, radius_mm=REGION_RADIUS_MM):
    """Maximum amplitude over a source's region at each time.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_times)
    positions : ndarray, shape (n_positions, 3)
        Grid positions in metres.
    true_position : ndarray, shape (3,)
        Exact source position in metres.
    radius_mm : float
        Region radius in mm.

    Returns
    -------
    course : ndarray, shape (n_times,)

    Examples
    --------
    >>> region_time_course(np.array([[1.0, 2.0], [5.0, 0.0]]),
    ...                    np.array([[0.0, 0, 0], [0.1, 0, 0]]), np.zeros(3))
    array([1., 2.])
    """
    positions = check_positions(positions)
    amplitude = check_amplitude(amplitude, len(positions))
    return amplitude[_region(positions, true_position, radius_mm)].max(axis=0)


def region_db(amplitude, positions, true_position, index, radius_mm=REGION_RADIUS_MM):
    """A region's maximum at one time relative to the global maximum then, in dB.

    Returns ``20 log10(max_region a / max_all a)`` at time `index` (0 dB: the region holds
    the global maximum); ``-inf`` if the region's maximum is zero.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_times)
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
