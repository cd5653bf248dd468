"""What the study of the SKF's worth (v2) runs: the settings compared, the designs, the sets.

Every constant here is the pre-registration's (``validation/report/PREREGISTRATION.md``):
the seeds, the split between the choice and the scored set, the timing designs, the SKF
candidates and named settings, MNE's methods and their regularization, the sizes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from itertools import product

__all__ = [
    "CANDIDATE_PRIORS",
    "DESIGNS",
    "DRAW_SEEDS",
    "EXPONENTS",
    "FULL",
    "IRMXNE_ALPHAS",
    "LAMBDA2",
    "MOMENTS",
    "NAMED",
    "POOL_SEEDS",
    "QUICK",
    "SETS",
    "SMOOTHERS",
    "SNRS",
    "SPLIT_SEEDS",
    "STANDARDIZATIONS",
    "STATIC_METHODS",
    "Design",
    "SKFSetting",
    "Sizes",
    "Static",
    "candidates",
]

#: The two sets: the choice set (every choice is made on it) and the scored set.
SETS = ("choice", "scored")
#: Seeds of the split (thalamic positions, cortical positions).
SPLIT_SEEDS = (34000, 34001)
#: Seeds of the points and orientations drawn near each set's positions.
DRAW_SEEDS = {"choice": 34010, "scored": 34020}
#: Seeds of each set's noise pools (draw k of design d: ``default_rng([seed, d, k])``).
POOL_SEEDS = {"choice": 34030, "scored": 34040}
#: Peak SNRs (dB) with noise; lone sources are also read without noise.
SNRS = (10.0, 20.0, 30.0)
#: The thalamic moment in configurations, as a fraction of the cortical one.
MOMENTS = (1.0, 0.5, 0.25)
EXPONENTS = (0.5, 1.0, 1.25, 1.5)
SMOOTHERS = ("none", "rts-standardized", "rts-state", "rts-smoothed-weights")
STANDARDIZATIONS = ("column", "position")
#: The candidates' priors: (EP-SNR, PM-SNR) in dB.
CANDIDATE_PRIORS = ((20.0, 0.0), (0.0, 0.0))
#: MNE's minimum-norm methods (``apply_inverse``'s names).
STATIC_METHODS = ("MNE", "dSPM", "sLORETA", "eLORETA")
#: Their lambda2: MNE's usual value, and the one matched to the SKF's PM-SNR (0 dB).
LAMBDA2 = ("1/9", "matched")
#: irMxNE's alpha (% of alpha_max), chosen per SNR by the discrepancy principle.
IRMXNE_ALPHAS = (10.0, 25.0, 50.0)


@dataclass(frozen=True)
class Design:
    """A timing design: the interval between the peaks and the sampling rate."""

    name: str
    interval_ms: float
    sfreq: float

    @property
    def title(self):
        """E.g. ``"D1: 1 ms apart, 10 kHz"``."""
        return f"{self.name}: {self.interval_ms:g} ms apart, {self.sfreq / 1000:g} kHz"

    def scenario(self):
        """The scenario's pulses in this design (positions irrelevant: its waveforms)."""
        from skf_ref.study.scenario import p20n20_scenario

        onset = self.interval_ms
        return p20n20_scenario(
            superficial_onset_ms=onset, sfreq=self.sfreq, duration_ms=onset + 3.0
        )


DESIGNS = (
    Design("D1", 1.0, 10000.0),
    Design("D2", 1.0, 2000.0),
    Design("D3", 5.0, 10000.0),
    Design("D4", 5.0, 2000.0),
)


@dataclass(frozen=True, order=True)
class SKFSetting:
    """An SKF setting: exponent, smoother, standardization and priors (EP, PM dB)."""

    exponent: float
    smoother: str
    standardize: str
    ep_snr_db: float
    pm_snr_db: float

    @property
    def key(self):
        """File-name key, e.g. ``"skf-0.5-none-column-ep20-pm0"``."""
        return (
            f"skf-{self.exponent:g}-{self.smoother}-{self.standardize}-"
            f"ep{self.ep_snr_db:g}-pm{self.pm_snr_db:g}"
        )

    @property
    def label(self):
        """E.g. ``"SKF 0.5, no smoother, column, EP 20 / PM 0"``."""
        smoother = "no smoother" if self.smoother == "none" else self.smoother
        return (
            f"SKF {self.exponent:g}, {smoother}, {self.standardize}, "
            f"EP {self.ep_snr_db:g} / PM {self.pm_snr_db:g}"
        )

    @property
    def smooths(self):
        """Whether the setting smooths (its window is the RTS smoother's)."""
        return self.smoother != "none"

    @property
    def priors(self):
        """(EP-SNR, PM-SNR) in dB."""
        return (self.ep_snr_db, self.pm_snr_db)


@dataclass(frozen=True)
class Static:
    """One of MNE's minimum-norm methods, optionally on data filtered with an SKF's window."""

    method: str
    lambda2: str
    window: SKFSetting | None = None

    @property
    def key(self):
        """E.g. ``"sLORETA-matched"`` or ``"sLORETA-matched-window-skf-..."``."""
        rule = "1_9" if self.lambda2 == "1/9" else self.lambda2
        tail = "" if self.window is None else f"-window-{self.window.key}"
        return f"{self.method}-{rule}{tail}"

    @property
    def label(self):
        """E.g. ``"sLORETA (λ² 1/9)"``, ``"eLORETA (λ² matched), N1's window"``."""
        text = f"{self.method} (λ² {self.lambda2})"
        return text if self.window is None else f"{text} on data in {self.window.label}'s window"


#: The named settings N2-N6 (N1 is the rule's choice).
NAMED = {
    "N2": SKFSetting(1.25, "rts-standardized", "column", 20.0, 0.0),
    "N3": SKFSetting(0.5, "none", "column", 20.0, 0.0),
    "N4": SKFSetting(0.5, "none", "column", 0.0, 0.0),
    "N5": SKFSetting(0.5, "none", "position", 20.0, 0.0),
    "N6": SKFSetting(0.5, "rts-smoothed-weights", "position", 20.0, 0.0),
}


def candidates():
    """The 64 SKF candidates: exponent x smoother x standardization x priors."""
    return [
        SKFSetting(exponent, smoother, standardize, ep, pm)
        for exponent, smoother, standardize, (ep, pm) in product(
            EXPONENTS, SMOOTHERS, STANDARDIZATIONS, CANDIDATE_PRIORS
        )
    ]


@dataclass(frozen=True)
class Sizes:
    """The sizes of a run (the full run's are the pre-registration's)."""

    choice_cortical: int = 210
    scored_cortical: int = 300
    thalamic: int | None = None  # per set; None: every thalamic position of the split
    pool: int = 100
    lcmv_noise: int = 50
    lcmv_step: int = 3
    irmxne_choice: int = 8
    irmxne_scored: int = 24
    tuned: int = 40
    tuned_snrs: tuple = SNRS
    designs: tuple = tuple(d.name for d in DESIGNS)
    all_candidates: bool = True  # False: the named settings only (a smoke run)

    def quick(self):
        """A smoke run's sizes: every step, tiny sets."""
        return replace(
            self,
            choice_cortical=8,
            scored_cortical=8,
            thalamic=2,
            pool=6,
            lcmv_noise=3,
            irmxne_choice=1,
            irmxne_scored=1,
            tuned=1,
            tuned_snrs=(20.0,),
            designs=("D1", "D2"),
            all_candidates=False,
        )


FULL = Sizes()
QUICK = FULL.quick()
