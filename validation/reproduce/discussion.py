"""The report's discussion: how this setup differs from the paper's, and what the numbers show.

Its paragraphs are written from the sweep tables and the post-hoc diagnostics of
:func:`validation.reproduce.runs.diagnostics`; no decision rule uses them.
"""

from __future__ import annotations

import math

from .settings import (
    EXPONENTS,
    NOISE_LEVELS,
    RANKED_EXPONENTS,
    SMOOTHED,
    SMOOTHERS,
    TUNED_PRIOR,
    TUNING,
    VERDICTS,
)
from .stats import _pm, _rate, _separated, _setting_label, _setting_rows

__all__ = []


def _low_share(diag, exponents):
    """Share (%) of EP 20, PM 0 runs with the maximum at 1.5 ms below the electrodes."""
    hits = [d for (_, e, _), d in diag.items() if e in exponents]
    return 100.0 * sum(d.low[0] for d in hits) / sum(d.n for d in hits)


def _sum_r2(fine, exponent, smoother):
    """Per noise level, R² of the fine map's cell means grouped by EP + PM (NaN if flat)."""
    out = {}
    for snr, level in _setting_rows(fine, exponent, smoother).groupby("snr_db", sort=True):
        means = level.groupby(["ep_snr_db", "pm_snr_db"])["score"].mean().reset_index()
        by_sum = means.groupby(means["ep_snr_db"] + means["pm_snr_db"])["score"]
        residual = ((means["score"] - by_sum.transform("mean")) ** 2).sum()
        total = ((means["score"] - means["score"].mean()) ** 2).sum()
        out[snr] = 1.0 - residual / total if total > 0 else math.nan
    return out


def _r2_text(fine, exponent, smoother):
    return ", ".join(f"{r2:.2f}" for r2 in _sum_r2(fine, exponent, smoother).values())


def _low_text(diag):
    share_05, share_hi = _low_share(diag, (0.5,)), _low_share(diag, RANKED_EXPONENTS)
    text = (
        "the grid also fills the sphere below the electrode cap, where the lead field is "
        "weak; the standardization divides by a power of the weights, and an exponent above "
        "0.5 amplifies these positions most. At EP 20, PM 0 the global maximum at the deep "
        f"peak lies below the lowest electrode in {share_05:.0f} % of the runs with exponent "
        f"0.5 and in {share_hi:.0f} % with exponents 1-1.5 (table below, last column)."
    )
    if share_hi >= 50.0:
        return text + (
            " For those exponents the peak errors, and so the exponent ranking of F5 (b), mostly "
            "reflect maxima below the electrode cap, a region the sphere's volume grid fills "
            "completely while the paper's source space holds only the brain's active "
            "compartments."
        )
    return text + " The effect is minor in this run."


def _balance_text(diag):
    """The post-hoc paragraph on the deep-to-superficial balance at 30 dB, EP 20, PM 0."""
    smoothed = {e: diag[30.0, e, SMOOTHED[1]].balance for e in RANKED_EXPONENTS}
    b1, b125, b15 = (smoothed[e][0] for e in RANKED_EXPONENTS)
    ordered = b1 < b125 < b15 and abs(b125) <= min(abs(b1), abs(b15))
    match = (
        ": the pattern the paper describes (1 lowers the deep peak, 1.5 raises it, 1.25 "
        "balances the two)"
        if ordered
        else ", not the pattern the paper describes"
    )
    lowered = sum(
        diag[30.0, e, SMOOTHED[1]].balance[0] < diag[30.0, e, "none"].balance[0] for e in EXPONENTS
    )
    values = ", ".join(f"{_pm(*smoothed[e])} dB for exponent {e:g}" for e in smoothed)
    return (
        "Post hoc (added after the verdicts were seen; no rule uses it): the paper's time "
        "courses show the two region maxima normalized together, not their level against the "
        "global maximum that the rules use. Measured that way, at 30 dB, EP 20, PM 0 with "
        f"{SMOOTHED[1]}, the deep-to-superficial balance is {values}{match}; smoothing lowers "
        f"it for {lowered} of the {len(EXPONENTS)} exponents at that setting. The verdicts "
        "stay as the rules give them."
    )


def _most_separated(paper):
    """Per noise level, the EP 20, PM 0 setting separating the sources in most seeds."""
    parts = []
    for snr in NOISE_LEVELS:
        counts = {
            (exponent, smoother): _rate(paper, snr, *TUNED_PRIOR, exponent, smoother, _separated)
            for exponent in EXPONENTS
            for smoother in SMOOTHERS
        }
        (exponent, smoother), (k, n) = max(counts.items(), key=lambda item: item[1][0])
        parts.append(f"{snr:g} dB: {_setting_label(exponent, smoother)}, {k}/{n} seeds")
    return "; ".join(parts)


def _verdict_counts(findings):
    """The sentence counting the verdicts and listing the findings under each."""
    counts = {v: sum(f.verdict == v for f in findings) for v in VERDICTS}
    listed = "; ".join(
        f"{v}: {', '.join(f'F{f.number}' for f in findings if f.verdict == v) or 'none'}"
        for v in VERDICTS
    )
    return (
        f"Of the six findings, {counts[VERDICTS[0]]} reproduced, {counts[VERDICTS[1]]} "
        f"partly and {counts[VERDICTS[2]]} not ({listed})."
    )


def _setup_text(head):
    """How this cell's head and source space differ from the paper's, (1) and (2)."""
    if head.conductor_kind == "sphere":
        conductor = (
            f"(1) the head model is a {len(head.conductor['layers'])}-shell sphere fitted to "
            "the electrodes, not a boundary-fitted FEM model of the ICBM152 template; the "
            "sphere has no anatomy, so the thalamic and cortical sources differ only in depth "
            "and orientation, and the lead field's depth attenuation is the sphere's"
        )
    else:
        conductor = (
            "(1) the head model is a three-layer BEM of MNE's sample subject (1280 triangles "
            "a surface, linear collocation), not the paper's boundary-fitted FEM of the "
            "ICBM152 template: another subject, another numerical method, no CSF layer"
        )
    if head.source_space == "volume":
        space = (
            f"(2) the sources sit on a regular volume grid of {head.n_positions} positions "
            "filling the brain compartment, not 3000 divergence-conforming sources restricted "
            "to the active compartments, so deep activity can spread to neighbours the "
            "paper's source space does not have"
        )
    else:
        space = (
            f"(2) the {head.n_positions} sources lie in cortex and thalamus only, like the "
            "paper's, but as free-orientation volume positions, not divergence-conforming "
            "sources"
        )
    return f"{conductor}; {space}"


def _discussion(data):
    """The Discussion section of REPORT.md, as lines."""
    settings, head = data.settings, data.head
    return [
        "## Discussion",
        "",
        "By the v1 rules: "
        + _verdict_counts(data.findings)
        + " A finding that does not hold here "
        "is a result about this setup, not a failure to be tuned away. The setup differs from "
        f"the paper's in ways that can move every finding: {_setup_text(head)}; (3) EP- and "
        'PM-SNR use the "gain" amplitude convention, under which PM-SNR is the '
        "prior-predicted data SNR; the toolbox normalizes differently (data scaled by their "
        "maximum, amplitude from mean column norms), so 0 and 20 dB here need not be the "
        "paper's 0 and 20 dB, which is why the fine EP × PM map is shown; (4) the paper judged "
        "time-series figures by eye and does not state how many noise realizations it used; "
        f"here each setting is scored over {settings.seeds} seeds by peak localization error "
        "and region levels, which can rank settings differently from visual impression.",
        "",
        "Two effects show in the numbers. First, " + _low_text(data.diagnostics),
        "",
        "Second, on the fine map the mean score depends almost only on EP + PM: grouping the "
        "cells by EP + PM explains R² = "
        f"{_r2_text(data.fine, *TUNING)} of the variance of the cell means at 10, 20, 30 dB "
        f"without smoothing ({_r2_text(data.fine, *SMOOTHED)} with {SMOOTHED[1]}, exponent "
        f"{SMOOTHED[0]:g}). This is what the parametrization predicts if the evolution "
        "variance q, rather than the initial variance θ0, governs the filter after its first "
        "steps: q = 10^((EP + PM)/10) σ² A² / (N K) depends on the sum only. So raising EP or "
        "raising PM by 20 dB changes the model almost alike, and F1 (b) can hold only by a "
        "small margin here. The toolbox "
        "convention (docs/model.md §4) clamps PM to at most the data SNR − 1 dB: at "
        "10 dB a PM of 20 dB acts as 9 dB, which makes raising PM cheaper than raising EP, a "
        "possible origin of the paper's F1 (b); it could be tested with the toolbox "
        "convention (not run here: the sweep has no convention axis).",
        "",
        _balance_text(data.diagnostics),
        "",
        "For reference, the EP 20, PM 0 setting that separated the sources in most seeds: "
        f"{_most_separated(data.paper)}.",
        "",
    ]
