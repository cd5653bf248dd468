"""The metrics of section 5 for one run: an amplitude map and the truth it estimates."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .design import REGION_MM


@dataclass(eq=False)
class Geometry:
    """Positions (m), the thalamus and each hemisphere's cortex, as boolean masks."""

    positions: np.ndarray = field(repr=False)
    thalamus: np.ndarray = field(repr=False)
    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)

    @classmethod
    def of(cls, head):
        """From a cortex + thalamus head."""
        from skf_ref.study._sources import position_labels

        labels = np.asarray(position_labels(head)).astype(str)
        return cls(
            np.asarray(head.positions),
            np.char.endswith(labels, "Thalamus"),
            labels == "Left-Cerebral-Cortex",
            labels == "Right-Cerebral-Cortex",
        )

    def distance_mm(self, point):
        """Distance of every position to ``point`` (m), in mm."""
        return 1e3 * np.linalg.norm(self.positions - point, axis=1)


def _error(a, distance, mask=None):
    if mask is not None:
        a = np.where(mask, a, -np.inf)
    if not np.any(a > 0):
        return np.nan
    return float(distance[int(np.argmax(a))])


def _emd(a, geometry, points, weights):
    from skf_ref.study._metrics import earth_movers_distance

    if not np.any(a > 0):
        return np.nan
    return float(earth_movers_distance(a, geometry.positions, points, weights))


def _course(A, distance, wave, dt_ms, peak):
    region = distance <= REGION_MM
    course = A[region].max(axis=0)
    if np.ptp(course) == 0 or np.ptp(np.abs(wave)) == 0:
        r = np.nan
    else:
        r = float(np.corrcoef(course, np.abs(wave))[0, 1])
    latency = abs(int(np.argmax(course)) - peak) * dt_ms
    return r, float(latency)


def pair(A, geometry, design, deep, cortical, moments):
    """A configuration: deep and superficial errors, EMD, ``S``, time-course r, latency."""
    waves = design.waveforms()
    t_deep, t_cort = design.peak(waves["deep"]), design.peak(waves["cortical"])
    d_deep, d_cort = geometry.distance_mm(deep), geometry.distance_mm(cortical)
    weights = np.abs([moments[0] * waves["deep"][t_deep], moments[1] * waves["cortical"][t_deep]])
    r, latency = _course(A, d_deep, waves["deep"], 1e3 / design.sfreq, t_deep)
    return {
        "deep error": _error(A[:, t_deep], d_deep),
        "superficial error": _error(A[:, t_cort], d_cort),
        "EMD": _emd(A[:, t_deep], geometry, np.array([deep, cortical]), weights),
        "S": float(A[geometry.thalamus, t_deep].max()),
        "r": r,
        "latency": latency,
    }


def null(A, geometry, design):
    """A null run: only the detection statistic ``S``."""
    t_deep = design.peak(design.waveforms()["deep"])
    return {"S": float(A[geometry.thalamus, t_deep].max())}


def two(A, geometry, design, left, right):
    """Two cortical sources: each one's error within its hemisphere, and the EMD."""
    t = design.peak(design.waveforms()["left"])
    return {
        "left error": _error(A[:, t], geometry.distance_mm(left), geometry.left),
        "right error": _error(A[:, t], geometry.distance_mm(right), geometry.right),
        "EMD": _emd(A[:, t], geometry, np.array([left, right]), None),
    }


def lone(A, geometry, design, point, structure):
    """A lone source: its error at its peak sample and the EMD."""
    wave = design.waveforms()["deep" if structure == "thalamic" else "cortical"]
    t = design.peak(wave)
    return {
        f"lone {structure} error": _error(A[:, t], geometry.distance_mm(point)),
        f"lone {structure} EMD": _emd(A[:, t], geometry, point[None], None),
    }
