"""Which SKF setting to recommend: a rule committed before the numbers it reads.

This module was committed before any baseline or specificity run existed (see the git
history: the rule's commit precedes the commit of the results it judges). It reads only the
*choice* seeds of the baselines study (:data:`CHOICE_SEEDS`), which are disjoint from the
seeds every table of the report scores, so the recommended setting is not tuned to the
seeds it is judged on.

The rule (:data:`RULE_TEXT`, :func:`recommend`)
-----------------------------------------------
Candidates
    The twelve SKF settings of the study: exponent 0.5, 1, 1.25 or 1.5, each with no
    smoother, the RTS smoother of the standardized estimate (``rts-standardized``) or of
    the state (``rts-state``), all at the paper's tuned priors (EP-SNR 20 dB, PM-SNR 0 dB).
Data
    The realistic head with cortex + thalamus (the sample subject's BEM, 64 BioSemi
    electrodes, white noise), the three noise levels, the choice seeds.
Scores
    Deep AUC: the ROC area of the deep region's score (its maximum at the deep peak time re.
    the global maximum, dB), the deep source present (both sources) vs absent (superficial
    source only, same noise draws). Superficial AUC likewise (both sources vs deep only).
    Error: the median over seeds of the deep plus the superficial peak localization error
    (mm) on the data with both sources.
1. A candidate is admissible when its deep AUC and its superficial AUC are both at least
   :data:`MIN_AUC` (0.9) at 20 and at 30 dB (at 10 dB the sources are near the noise floor
   for every method, so 10 dB enters through the error only).
2. Among admissible candidates, recommend the one with the smallest error averaged over the
   three noise levels.
3. Candidates within :data:`TIE_MM` (1 mm) of that smallest error tie; ties go to the
   higher deep AUC averaged over the three levels, then to the simpler setting: no smoother
   before a smoother, then the lower exponent.
4. If no candidate is admissible, recommend the one with the highest deep AUC at its worse
   of 20 and 30 dB (ties as in 3), and the report says that no setting met the bar.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CHOICE_SEEDS", "MIN_AUC", "RULE_TEXT", "TIE_MM", "auc", "recommend"]

#: The seeds the rule reads (the scored seeds are 0 .. n - 1).
CHOICE_SEEDS = range(1000, 1020)
#: Admissible: deep and superficial AUC at least this at 20 and 30 dB.
MIN_AUC = 0.9
#: Errors closer than this (mm) tie.
TIE_MM = 1.0
#: The noise levels (dB) the AUC bar applies to.
AUC_LEVELS = (20.0, 30.0)

#: The rule as the report prints it: one Markdown paragraph on one line. Wrapped, a line
#: could start with a block marker (">= 0.9" made a quote of the rest of the paragraph).
RULE_TEXT = " ".join(
    """\
**Rule (committed before the numbers).** Candidates: the 12 SKF settings (exponent 0.5, 1,
1.25, 1.5; no smoother, `rts-standardized`, `rts-state`) at EP 20 / PM 0 dB. Data: the
realistic head, cortex + thalamus, white noise, the *choice* seeds 1000-1019 (disjoint from
the scored seeds 0-19 of every table). Deep AUC: deep present (both sources) vs absent
(superficial only); superficial AUC: both vs deep only. Error: median over seeds of deep +
superficial peak error (mm), both sources present. (1) Admissible: deep and superficial AUC
>= 0.9 at 20 and 30 dB. (2) Recommend the admissible setting with the smallest error
averaged over 10, 20 and 30 dB; (3) errors within 1 mm tie, ties go to the higher mean deep
AUC, then no smoother before a smoother, then the lower exponent. (4) If none is
admissible, the highest deep AUC at the worse of 20 and 30 dB, and the report says so.""".split()
)


def auc(present, absent):
    """ROC area of a score: P(present > absent) + P(tie) / 2 (Mann-Whitney).

    Parameters
    ----------
    present, absent : array_like, shape (n,) and (m,)
        Scores of the runs with and without the source (``-inf`` allowed).

    Returns
    -------
    float
        0.5 is chance, 1 a perfect separation.

    Examples
    --------
    >>> auc([3.0, 2.0], [1.0, 2.0])
    0.875
    """
    present = np.asarray(present, dtype=float)[:, None]
    absent = np.asarray(absent, dtype=float)[None, :]
    return float(np.mean((present > absent) + 0.5 * (present == absent)))


def _smoother_rank(smoother):
    return 0 if smoother == "none" else 1


def recommend(scores):
    """Apply the rule to the candidates' scores on the choice seeds.

    Parameters
    ----------
    scores : pandas.DataFrame
        One row per candidate and noise level, columns ``exponent``, ``smoother``
        (``"none"`` for no smoother), ``snr_db``, ``deep_auc``, ``superficial_auc`` and
        ``error_mm`` (median over the choice seeds of the deep plus superficial error).

    Returns
    -------
    setting : dict
        ``{"exponent": float, "smoother": str or None}`` (None: no smoother).
    admissible : bool
        Whether the setting met the AUC bar (False: clause 4 chose it).

    Examples
    --------
    >>> import pandas as pd
    >>> rows = [(e, "none", s, a, 0.95, err) for e, a, err in ((0.5, 0.95, 20.0),
    ...         (1.25, 0.4, 10.0)) for s in (10.0, 20.0, 30.0)]
    >>> table = pd.DataFrame(rows, columns=["exponent", "smoother", "snr_db", "deep_auc",
    ...                                     "superficial_auc", "error_mm"])
    >>> recommend(table)
    ({'exponent': 0.5, 'smoother': None}, True)
    """
    at_bar = scores[scores["snr_db"].isin(AUC_LEVELS)]
    per = scores.groupby(["exponent", "smoother"], sort=True).agg(
        error=("error_mm", "mean"), mean_deep=("deep_auc", "mean")
    )
    worst = at_bar.groupby(["exponent", "smoother"], sort=True).agg(
        deep=("deep_auc", "min"), superficial=("superficial_auc", "min")
    )
    per = per.join(worst)
    ok = (per["deep"] >= MIN_AUC) & (per["superficial"] >= MIN_AUC)
    if ok.any():
        pool = per[ok]
        pool = pool[pool["error"] <= pool["error"].min() + TIE_MM]
    else:
        pool = per[per["deep"] == per["deep"].max()]
    pool = pool.reset_index()
    pool["simple"] = pool["smoother"].map(_smoother_rank)
    pool = pool.sort_values(
        ["mean_deep", "simple", "exponent"], ascending=[False, True, True], kind="stable"
    )
    best = pool.iloc[0]
    smoother = None if best["smoother"] == "none" else str(best["smoother"])
    return {"exponent": float(best["exponent"]), "smoother": smoother}, bool(ok.any())
