"""Positions, amplitudes and source regions: the building blocks of :mod:`skf_ref.metrics`.

``amplitude`` is a position amplitude ``a_t(p)``, shape (n_positions, n_times): the
Euclidean norm of a position's standardized components. ``positions`` are grid positions,
shape (n_positions, 3), and true positions shape (3,), both in metres. The region of a
source is the set of grid positions within ``radius_mm`` (15 mm) of its exact position.
"""

from __future__ import annotations

import numbers

import numpy as np

from ._validation import check_array

__all__ = [
    "DYNAMIC_RANGE_DB",
    "REGION_RADIUS_MM",
    "amplitude_from_components",
    "as_amplitude",
    "region_db",
    "region_mask",
    "region_time_course",
]

#: Radius (mm) of a source's region.
REGION_RADIUS_MM = 15.0
#: Dynamic range (dB) within which a region counts as detected (the paper's figures).
DYNAMIC_RANGE_DB = 6.0


def _positions(positions):
    pos = check_array("positions", positions, ("n_positions", 3))
    if pos.shape[1] != 3 or pos.shape[0] == 0:
        raise ValueError(f"positions must have shape (n_positions, 3), got shape {pos.shape}")
    return pos


def _point(value, name):
    point = check_array(name, value, (3,))
    if point.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got shape {point.shape}")
    return point


def _amplitude(amplitude, positions):
    amp = check_array("amplitude", amplitude, ("n_positions", "n_times"))
    if amp.shape[0] != positions.shape[0] or amp.shape[1] == 0:
        raise ValueError(
            f"amplitude must have shape (n_positions, n_times) = ({positions.shape[0]}, "
            f"n_times), got shape {amp.shape}"
        )
    if (amp < 0).any():
        raise ValueError("amplitude must be non-negative (a norm per position)")
    return amp


def _index(index, name, n_times):
    if isinstance(index, bool) or not isinstance(index, numbers.Integral):
        raise ValueError(f"{name} must be an int, got {index!r}")
    if not 0 <= index < n_times:
        raise ValueError(f"{name} must be in [0, {n_times}), got {index}")
    return int(index)


def _region(positions, true_position, radius_mm, name="true_position"):
    mask = region_mask(positions, true_position, radius_mm)
    if not mask.any():
        raise ValueError(
            f"positions: no grid position within {radius_mm:g} mm of {name}; the grid is "
            f"too coarse"
        )
    return mask


def amplitude_from_components(z, n_components=3):
    """Position amplitude: the norm of each position's consecutive components.

    Parameters
    ----------
    z : ndarray, shape (n_components * n_positions, n_times)
        Standardized source estimate, MNE column order (x, y, z of position 0, then 1, ...).
    n_components : int
        Components per position (3 for free orientation).

    Returns
    -------
    amplitude : ndarray, shape (n_positions, n_times)

    Examples
    --------
    >>> amplitude_from_components(np.array([[3.0], [4.0], [0.0], [0.0], [0.0], [1.0]]))
    array([[5.],
           [1.]])
    """
    z = check_array("z", z, ("n_components * n_positions", "n_times"))
    if z.shape[0] % n_components:
        raise ValueError(
            f"z must have shape (n_components * n_positions, n_times) with n_components="
            f"{n_components}, got shape {z.shape}"
        )
    return np.linalg.norm(z.reshape(-1, n_components, z.shape[1]), axis=1)


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
        raise ValueError(
            f"reconstruction amplitude must have shape (n_positions, n_times) with "
            f"n_positions={n_positions}, got shape {amp.shape} (pass an amplitude, not the "
            f"standardized components; see amplitude_from_components)"
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
    positions = _positions(positions)
    true_position = _point(true_position, "true_position")
    if not (isinstance(radius_mm, numbers.Real) and radius_mm > 0):
        raise ValueError(f"radius_mm must be a positive number, got {radius_mm!r}")
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
    positions = _positions(positions)
    amplitude = _amplitude(amplitude, positions)
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
    positions = _positions(positions)
    amplitude = _amplitude(amplitude, positions)
    index = _index(index, "index", amplitude.shape[1])
    region = amplitude[_region(positions, true_position, radius_mm), index].max()
    if region == 0:
        return float("-inf")
    return float(20.0 * np.log10(region / amplitude[:, index].max()))
