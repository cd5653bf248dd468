"""The recordings' geometry and latencies, as :mod:`validation.real_sep.criteria` defines them.

:class:`Recording` holds one recording's MNE objects and everything the criteria need from
the electrodes and the sensor data (never from an estimate): the head's centre, the point
``p*`` under C3/CP3, the source positions, and the N20, P14 and P16 latencies.
:func:`measure` reads one estimate's amplitudes against them.
"""

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import find_peaks

from . import criteria


@dataclass
class Recording:
    """One recording, its forward and noise covariance, and the criteria's geometry.

    Attributes
    ----------
    name : str
    evoked : mne.Evoked
        With its ``nave``.
    forward : mne.Forward
    noise_cov : mne.Covariance
        One trial's, MNE's convention (divided by ``evoked.nave`` by MNE's inverses).
    centre : ndarray, shape (3,)
        The sphere fitted to the electrodes (m).
    radius : float
    central : ndarray, shape (3,)
        ``p*``, the point 25 mm under the scalp below C3/CP3 (m).
    radial : ndarray, shape (3,)
        ``u``, the unit vector from ``centre`` towards C3/CP3.
    positions : ndarray, shape (n_positions, 3)
        The source positions (m), in the forward's order.
    orientations : ndarray, shape (n_positions, 3) or None
        Each position's fixed orientation; None for a free-orientation forward.
    latencies : dict
        ``{"P14": s, "P16": s, "N20": s}``.
    """

    name: str
    evoked: object
    forward: object
    noise_cov: object
    centre: np.ndarray
    radius: float
    central: np.ndarray
    radial: np.ndarray
    positions: np.ndarray
    orientations: np.ndarray | None
    latencies: dict = field(default_factory=dict)

    def sample(self, event):
        """The index of the sample nearest an event's latency."""
        return int(np.argmin(np.abs(self.evoked.times - self.latencies[event])))


def head_sphere(info):
    """Centre (m) and radius (m) of the sphere MNE fits to the EEG electrodes."""
    import warnings

    import mne

    with warnings.catch_warnings():
        # MNE warns when the centre is far from the frame's origin: A0206's frame is the
        # MRI's, whose origin is a corner of the volume, not the head's centre
        warnings.filterwarnings(
            "ignore", message=".*from head frame origin", category=RuntimeWarning
        )
        radius, centre, _ = mne.bem.fit_sphere_to_headshape(
            info, dig_kinds=("eeg",), units="m", verbose=False
        )
    return np.asarray(centre, dtype=float), float(radius)


def central_direction(info, centre):
    """``u`` and ``|m - c|``: from the recording's own C3 and CP3, else the ideal cap's."""
    import mne

    at = {ch["ch_name"]: ch["loc"][:3] for ch in info["chs"]}
    if "C3" in at and "CP3" in at:
        offset = (at["C3"] + at["CP3"]) / 2 - centre
        return offset / np.linalg.norm(offset), float(np.linalg.norm(offset))
    ideal = mne.channels.make_standard_montage(criteria.CENTRAL_MONTAGE).get_positions()
    middle = (ideal["ch_pos"]["C3"] + ideal["ch_pos"]["CP3"]) / 2  # the ideal sphere's centre: 0
    return middle / np.linalg.norm(middle), None


def latencies(evoked, n20_near):
    """N20: the GFP peak nearest ``n20_near``; P14: the largest GFP peak 8 to 4 ms before
    it; P16: halfway between (criteria)."""
    gfp = evoked.data.std(axis=0)
    peaks = find_peaks(gfp)[0]
    times = evoked.times[peaks]
    n20 = times[np.argmin(np.abs(times - n20_near))]
    early, late = criteria.P14_BEFORE_N20
    window = (times >= n20 - early - 1e-9) & (times <= n20 - late + 1e-9)
    if not window.any():
        raise ValueError(f"no GFP peak from {early * 1e3:g} to {late * 1e3:g} ms before the N20")
    p14 = times[window][np.argmax(gfp[peaks][window])]
    return {"P14": float(p14), "P16": float((p14 + n20) / 2), "N20": float(n20)}


def make_recording(name, evoked, forward, noise_cov, n20_near, like=None):
    """A :class:`Recording` with the criteria's geometry and latencies.

    ``like``: a :class:`Recording` of the same average whose geometry (centre, radius,
    ``p*``, ``u``) and latencies are kept (the 256-channel recording without its neck rows
    takes the all-channel one's: criteria.NECK_RULE); ``n20_near`` is then unused.
    """
    import mne

    src = forward["src"][0]
    positions = src["rr"][src["vertno"]]
    fixed = mne.forward.is_fixed_orient(forward)
    if like is None:
        centre, radius = head_sphere(evoked.info)
        radial, distance = central_direction(evoked.info, centre)
        scalp = radius if distance is None else distance
        central = centre + (scalp - criteria.CENTRAL_DEPTH) * radial
        events = latencies(evoked, n20_near)
    else:
        centre, radius, central, radial = like.centre, like.radius, like.central, like.radial
        events = dict(like.latencies)
    return Recording(
        name=name,
        evoked=evoked,
        forward=forward,
        noise_cov=noise_cov,
        centre=centre,
        radius=radius,
        central=central,
        radial=radial,
        positions=positions,
        orientations=np.asarray(forward["source_nn"]) if fixed else None,
        latencies=events,
    )


def _at(recording, amplitude, index):
    """The maximum at one sample: its position and what the criteria ask of it."""
    k = int(np.argmax(amplitude[:, index]))
    position = recording.positions[k]
    depth = float(np.linalg.norm(position - recording.centre))
    to_central = float(np.linalg.norm(position - recording.central))
    deep = depth <= criteria.DEEP_RADIUS
    region = _regions(recording)
    return k, {
        "x_mm": position[0] * 1e3,
        "y_mm": position[1] * 1e3,
        "z_mm": position[2] * 1e3,
        "left": bool(position[0] < recording.centre[0]),
        "depth_mm": depth * 1e3,
        "deep": bool(deep),
        "to_central_mm": max(0.0, to_central - criteria.CENTRAL_RADIUS) * 1e3,
        "to_p_star_mm": to_central * 1e3,
        "central": bool(to_central <= criteria.CENTRAL_RADIUS),
        "deep_share": float(amplitude[region["deep"], index].max() / amplitude[k, index]),
    }


def _regions(recording):
    distance = np.linalg.norm(recording.positions - recording.centre, axis=1)
    central = np.linalg.norm(recording.positions - recording.central, axis=1)
    return {
        "deep": distance <= criteria.DEEP_RADIUS,
        "central": central <= criteria.CENTRAL_RADIUS,
    }


def measure(recording, amplitude):
    """One estimate against the criteria.

    Parameters
    ----------
    recording : Recording
    amplitude : ndarray, shape (n_positions, n_times)
        Non-negative: absolute values (fixed) or norms (free), zero where a sparse
        estimate has no source.

    Returns
    -------
    row : dict
        For each event (N20, P14, P16): the maximum's position (mm), hemisphere, depth, its
        distance to ``p*`` and to the central region, whether it is deep or central, and the
        deep region's largest amplitude as a fraction of the maximum; the five checks and
        their count; for a fixed forward the N20 maximum's axis and its angle to ``u``.
    courses : dict
        Time courses (n_times,): ``"N20 maximum"``, ``"P14 maximum"``, ``"central region"``
        and ``"deep region"`` (the largest amplitude in each region).
    """
    row, courses = {}, {}
    for event in ("N20", "P14", "P16"):
        k, values = _at(recording, amplitude, recording.sample(event))
        row.update({f"{event}_{key}": value for key, value in values.items()})
        if event in ("N20", "P14"):
            courses[f"{event} maximum"] = amplitude[k]
        if event == "N20" and recording.orientations is not None:
            axis = recording.orientations[k]
            row["N20_axis"] = "xyz"[int(np.argmax(np.abs(axis)))]
            angle = np.degrees(np.arccos(min(1.0, abs(float(axis @ recording.radial)))))
            row["N20_angle_to_radial_deg"] = float(angle)
    regions = _regions(recording)
    for name, mask in (("central region", regions["central"]), ("deep region", regions["deep"])):
        courses[name] = amplitude[mask].max(axis=0)
    checks = {
        "check_N20_left": row["N20_left"],
        "check_N20_central": row["N20_central"],
        "check_N20_cortical": not row["N20_deep"],
        "check_P14_deep": row["P14_deep"],
        "check_P16_deep": row["P16_deep"],
    }
    row.update(checks)
    row["checks_met"] = int(sum(checks.values()))
    return row, courses
