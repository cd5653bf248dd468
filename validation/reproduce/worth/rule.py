"""The default's rule and its success criteria (the pre-registration's sections 10 and 11).

Both read the same inputs (:func:`inputs`): on the choice set they choose the default, on the
scored set they judge it. :func:`criteria` is R1-R3 (and S1-S3): met or not, with the numbers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .design import CANDIDATE_PRIORS, SNRS, STANDARDIZATIONS

__all__ = ["Criteria", "best_of", "choose_default", "criteria", "inputs", "mean_error"]

#: R1: the lone thalamic error at 30 dB (mm) and the share of maxima in the thalamus.
MAX_THALAMIC_ERROR_MM = 10.0
MIN_IN_THALAMUS = 0.80
#: R2: the true-detection rate at 1x, 20 dB.
MIN_TRUE_DETECTION = 0.80
#: R3: no error median above eLORETA's by more than this (mm).
MARGIN_MM = 5.0
#: Mean localization errors closer than this (mm) tie.
TIE_MM = 1.0
#: The smoothers in the order ties go to.
TIE_SMOOTHERS = ("none", "rts-state", "rts-smoothed-weights", "rts-standardized")
_NOISE_FREE = np.inf
_ERRORS = (
    [("lone_thalamic_error", s) for s in (_NOISE_FREE, *SNRS)]
    + [("lone_cortical_error", s) for s in (_NOISE_FREE, *SNRS)]
    + [("deep_error", s) for s in SNRS]
    + [("superficial_error", s) for s in SNRS]
)


def inputs(summary):
    """The rule's inputs from a method's summary (:func:`.summary.summarize`) of set D1.

    Returns
    -------
    dict
        ``(quantity, snr_db) -> value`` for the lone errors, deep and superficial errors,
        the share of lone thalamic maxima in the thalamus and the true-detection rate at 1x.
    """
    values = {(row.quantity, float(row.snr_db)): float(row.value) for row in summary.itertuples()}
    wanted = [*_ERRORS, ("lone_thalamic_own", 30.0), *[("true_1", s) for s in SNRS]]
    return {key: values.get(key, np.nan) for key in wanted}


def mean_error(values):
    """Mean over 10, 20, 30 dB of (E_th + E_cx + E_deep + E_sup) / 4 (mm)."""
    names = ("lone_thalamic_error", "lone_cortical_error", "deep_error", "superficial_error")
    return float(np.mean([values[name, snr] for snr in SNRS for name in names]))


@dataclass(frozen=True)
class Criteria:
    """R1-R3 (or S1-S3) of one method against eLORETA's numbers."""

    thalamic_error: float
    in_thalamus: float
    true_detection: float
    worse: tuple  # ((quantity, snr_db), method's, eLORETA's) beyond the margin

    @property
    def r1(self):
        """bool : Lone thalamic error at 30 dB <= 10 mm and >= 80 % of maxima in the thalamus."""
        return self.thalamic_error <= MAX_THALAMIC_ERROR_MM and self.in_thalamus >= MIN_IN_THALAMUS

    @property
    def r2(self):
        """bool : True detection at 1x, 20 dB, >= 0.8."""
        return self.true_detection >= MIN_TRUE_DETECTION

    @property
    def r3(self):
        """bool : No error median worse than eLORETA's by more than 5 mm."""
        return not self.worse

    @property
    def met(self):
        """tuple of bool : (R1, R2, R3)."""
        return (self.r1, self.r2, self.r3)


def criteria(values, reference):
    """R1-R3 of ``values`` with ``reference`` (eLORETA's inputs)."""
    worse = tuple(
        (key, values[key], reference[key])
        for key in _ERRORS
        if not values[key] <= reference[key] + MARGIN_MM
    )
    return Criteria(
        thalamic_error=values["lone_thalamic_error", 30.0],
        in_thalamus=values["lone_thalamic_own", 30.0],
        true_detection=values["true_1", 20.0],
        worse=worse,
    )


def _order(setting):
    """The rule's preference among tied candidates (after the mean true-detection rate)."""
    return (
        TIE_SMOOTHERS.index(setting.smoother),
        STANDARDIZATIONS.index(setting.standardize),
        CANDIDATE_PRIORS.index(setting.priors),
        setting.exponent,
    )


def choose_default(candidates, reference):
    """The default by the rule.

    Parameters
    ----------
    candidates : dict
        SKFSetting -> its inputs on the choice set.
    reference : dict
        eLORETA's (lambda2 1/9) inputs on the choice set.

    Returns
    -------
    setting : SKFSetting
    met_all : bool
        Whether it met R1, R2 and R3 (False: the fallback clause chose it).
    table : pandas.DataFrame
        One row per candidate: its mean error, mean true detection, R1-R3.
    """
    rows = []
    for setting, values in candidates.items():
        judged = criteria(values, reference)
        rows.append(
            dict(
                setting=setting,
                mean_error_mm=mean_error(values),
                mean_true=float(np.mean([values["true_1", s] for s in SNRS])),
                r1=judged.r1,
                r2=judged.r2,
                r3=judged.r3,
                met=sum(judged.met),
            )
        )
    table = pd.DataFrame(rows)
    best_met = table["met"].max()
    pool = table[table["met"] == best_met]
    pool = pool[pool["mean_error_mm"] <= pool["mean_error_mm"].min() + TIE_MM]
    ranked = sorted(pool.itertuples(), key=lambda row: (-row.mean_true, _order(row.setting)))
    return ranked[0].setting, bool(best_met == 3), table


def best_of(pool):
    """The label of the lowest mean localization error (first given on a tie)."""
    errors = {label: mean_error(values) for label, values in pool.items()}
    lowest = min(errors.values())
    return next(label for label, error in errors.items() if error <= lowest)
