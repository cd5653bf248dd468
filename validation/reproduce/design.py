"""What the evidence study v3 runs: every constant of its pre-registration, in one place.

``validation/reproduce/PREREGISTRATION.md`` (with its amendment 1) fixes the seeds, the sizes,
the designs, the conditions, the SKF candidates and named settings, and the baselines; this
module states them as code and nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np

#: Seeds: the split, the sources' points and orientations, the noise draws.
SEEDS = {
    "thalamic split": 43000,
    "cortical split": 43001,
    "choice": 43010,
    "scored": 43020,
    "noise choice": 43030,
    "noise scored": 43040,
}
SETS = ("choice", "scored")
#: Runs per kind (configurations, cortical nulls, noise-only nulls; lone sources per structure).
SIZES = {"choice": 6, "scored": 16}
QUICK_SIZES = {"choice": 2, "scored": 2}
#: Cortical positions per hemisphere in each set.
CORTICAL_PER_HEMISPHERE = {"choice": 60, "scored": 120}
#: Peak SNR (dB) of a typical cortical source, whitened units.
SNR_DB = 20.0
#: PM-SNR of every candidate (dB), and the exponent.
PM_SNR_DB = 0.0
EXPONENT = 0.5
#: Radius (mm) of the region whose largest amplitude is the deep time course.
REGION_MM = 15.0
#: The white floor added to the mapped background of ``b64-real``: its share of the variance.
FLOOR_SHARE = 0.10


def _hann(t, start, width):
    phase = (t - start) / width
    return np.where((phase >= 0) & (phase <= 1), np.sin(np.pi * phase) ** 2, 0.0)


def _tukey_sine(t, start, length=0.3, edge=0.05, freq=10.0):
    u = t - start
    taper = np.clip(np.minimum(u, length - u) / edge, 0.0, 1.0)
    envelope = np.where((u >= 0) & (u <= length), 0.5 - 0.5 * np.cos(np.pi * taper), 0.0)
    return envelope * np.sin(2 * np.pi * freq * u)


@dataclass(frozen=True)
class Design:
    """A timing design: rate, epoch, the waveforms and which runs it has.

    ``kind`` is ``"pair"`` (a thalamic and a cortical source, with nulls), ``"two"`` (two
    cortical sources) or ``"lone"`` (one source at a time).
    """

    name: str
    sfreq: float
    tmin: float
    n_times: int
    kind: str
    support_s: float

    @property
    def times(self):
        """ndarray, shape (n_times,) : Seconds."""
        return self.tmin + np.arange(self.n_times) / self.sfreq

    def waveforms(self):
        """The deep and the cortical waveform (unit peak), each shape (n_times,)."""
        t = self.times
        if self.name == "D1":
            return {"deep": _hann(t, 0.0, 3e-3), "cortical": _hann(t, 1e-3, 3e-3)}
        if self.name == "10Hz":
            return {"deep": _tukey_sine(t, 0.0), "cortical": _tukey_sine(t, 0.025)}
        erp = {"deep": _hann(t, 0.060, 0.080), "cortical": _hann(t, 0.090, 0.080)}
        if self.name == "2cortical":
            return {"left": erp["cortical"], "right": erp["cortical"]}
        return erp

    def peak(self, wave):
        """The first sample where ``|wave|`` is largest (to rounding: 10 Hz has many peaks)."""
        a = np.abs(wave)
        return int(np.flatnonzero(a >= a.max() * (1 - 1e-9))[0])


DESIGNS = {
    "D1": Design("D1", 10000.0, 0.0, 41, "pair", 3e-3),
    "ERP": Design("ERP", 500.0, -0.05, 201, "pair", 0.080),
    "10Hz": Design("10Hz", 500.0, -0.05, 201, "pair", 0.300),
    "2cortical": Design("2cortical", 500.0, -0.05, 201, "two", 0.080),
    "MEG": Design("MEG", 500.0, -0.05, 201, "lone", 0.080),
}
#: Conditions: sensors and noise.
CONDITIONS = {
    "b64-white": ("biosemi64", "white"),
    "b64-real": ("biosemi64", "real"),
    "s60-white": ("sample", "white"),
    "s60-real": ("sample", "real"),
    "meg": ("meg", "gaussian"),
}
EEG_CONDITIONS = ("b64-white", "b64-real", "s60-white", "s60-real")
#: The conditions each design runs in.
DESIGN_CONDITIONS = {name: EEG_CONDITIONS for name in ("D1", "ERP", "10Hz", "2cortical")}
DESIGN_CONDITIONS["MEG"] = ("meg",)
#: Where LCMV and irMxNE run (scored set), their cost.
COSTLY_CELLS = (("b64-white", "D1"), ("b64-white", "ERP"), ("s60-real", "D1"), ("s60-real", "ERP"))
IRMXNE_RUNS = 8
IRMXNE_ALPHA = 25.0
LCMV_REG = 0.05

DYNAMICS = ("walk EP 0", "walk EP 20", "AR 10 ms", "AR 30 ms", "AR 100 ms", "AR auto")
STANDARDIZATIONS = ("column", "position")
SMOOTHERS = ("none", "rts-standardized", "rts-state", "rts-smoothed-weights")
MINIMUM_NORM = ("MNE", "dSPM", "sLORETA", "eLORETA")
LAMBDA2 = ("1/9", "matched")


@dataclass(frozen=True)
class Setting:
    """An SKF setting: dynamics, standardization, smoother, exponent."""

    dynamics: str
    standardize: str
    smoother: str
    exponent: float = EXPONENT

    @property
    def label(self):
        """E.g. ``"SKF 0.5, AR 30 ms, position, none"``."""
        return f"SKF {self.exponent:g}, {self.dynamics}, {self.standardize}, {self.smoother}"

    @property
    def by_data(self):
        """bool : The time constant is chosen by each data set."""
        return self.dynamics == "AR auto"

    @property
    def simplicity(self):
        """The rule's last tie-break: smaller is simpler."""
        return (
            SMOOTHERS.index(self.smoother) > 0,
            self.by_data,
            not self.dynamics.startswith("walk"),
            DYNAMICS.index(self.dynamics),
            STANDARDIZATIONS.index(self.standardize),
        )

    def prior(self):
        """``("walk", ep_db)`` or ``("ar", tau_ms)`` or ``("ar", "auto")``."""
        kind, value = self.dynamics.split(" ", 1)
        if kind == "walk":
            return "walk", float(value.split()[1])
        return "ar", "auto" if value == "auto" else float(value.split()[0])


CANDIDATES = tuple(Setting(d, s, m) for d, s, m in product(DYNAMICS, STANDARDIZATIONS, SMOOTHERS))
PAPER = Setting("walk EP 20", "column", "rts-standardized", 1.25)
PREVIOUS = Setting("walk EP 0", "position", "none")
QUICK_CANDIDATES = (
    PREVIOUS,
    Setting("AR 30 ms", "position", "none"),
    Setting("AR auto", "column", "none"),
)


def by_data_twin(setting):
    """N4: the default with its time constant chosen by the data (AR 30 ms if it already is)."""
    dynamics = "AR 30 ms" if setting.by_data else "AR auto"
    return Setting(dynamics, setting.standardize, setting.smoother, setting.exponent)


def named(default):
    """N1-N4, in order: ``{"N1": Setting, ...}``."""
    return {"N1": default, "N2": PAPER, "N3": PREVIOUS, "N4": by_data_twin(default)}
