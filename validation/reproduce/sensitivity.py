"""Post-hoc sensitivity analysis: F5 and F6 on the source grid above the lowest electrode.

Decided after the primary verdicts were seen (the discussion found that with exponents above
0.5 the global maximum mostly lies below the electrode cap, where the volume grid fills the
inner sphere). :func:`crop_head` keeps the grid positions at or above the lowest electrode;
:func:`run_sensitivity` reruns exactly the settings of F5 and F6 on it, with the primary
seeds and noise, and judges them with the unchanged rules. No primary verdict uses it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from itertools import product

import numpy as np
import pandas as pd

from .rules import rule_f5, rule_f6
from .runs import electrode_floor
from .settings import EXPONENTS, NOISE_LEVELS, SMOOTHED, TUNED_PRIOR

__all__ = ["SENSITIVITY", "Sensitivity", "crop_head", "run_sensitivity", "sensitivity_section"]

SENSITIVITY = "sensitivity.csv"


def crop_head(head):
    """The head model restricted to the positions at or above the lowest electrode.

    Parameters
    ----------
    head : skf_ref.study.scenario.HeadModel

    Returns
    -------
    skf_ref.study.scenario.HeadModel
        Same channels, sphere and montage; ``positions`` shape (n_kept, 3) and
        ``leadfield`` shape (n_channels, 3 * n_kept), the three columns (x, y, z) of each
        kept position in the original order. ``src`` and ``fwd`` describe the full grid
        only, so they are set to None.
    """
    keep = np.flatnonzero(head.positions[:, 2] >= electrode_floor(head))
    cols = (3 * keep[:, None] + np.arange(3)).ravel()
    return dataclasses.replace(
        head, leadfield=head.leadfield[:, cols], positions=head.positions[keep], src=None, fwd=None
    )


def _runs(seeds):
    """The F5/F6 runs of one noise level: (exponent, smoother, seed)."""
    return [
        (exponent, smoother, seed)
        for seed in range(seeds)
        for exponent, smoother in product(EXPONENTS, (None, SMOOTHED[1]))
    ]


@dataclass(frozen=True)
class Sensitivity:
    """The cropped-grid analysis.

    Attributes
    ----------
    n_full, n_kept : int
        Grid positions before and after cropping.
    floor_mm : float
        Height of the lowest electrode (mm re. the sphere centre).
    table : pandas.DataFrame
        One row per run, the paper-grid columns, sorted by the sweep key.
    findings : list of Finding
        F5 and F6 by the unchanged rules.
    """

    n_full: int
    n_kept: int
    floor_mm: float
    table: pd.DataFrame
    findings: list


def run_sensitivity(head, seeds, out, n_jobs=1):
    """Run F5 and F6 on the cropped grid, write ``out / sensitivity.csv``, judge them.

    Parameters
    ----------
    head : skf_ref.study.scenario.HeadModel
        The primary head model.
    seeds : int
        Seeds 0 .. seeds - 1, as in the primary analysis.
    out : Path
    n_jobs : int
        joblib workers, one noise level each.

    Returns
    -------
    Sensitivity
    """
    from joblib import Parallel, delayed

    from skf_ref._utils.atomic_files import atomic_path
    from skf_ref.study.sweep import KEY, run_on_head

    cropped = crop_head(head)
    levels = Parallel(n_jobs=n_jobs)(
        delayed(run_on_head)(cropped, snr, *TUNED_PRIOR, _runs(seeds)) for snr in NOISE_LEVELS
    )
    rows = [row for level in levels for row in level]
    table = pd.DataFrame(rows).sort_values(list(KEY), kind="stable", ignore_index=True)
    with atomic_path(out / SENSITIVITY) as tmp:
        table.to_csv(tmp, index=False, lineterminator="\n")
    return Sensitivity(
        n_full=head.n_positions,
        n_kept=cropped.n_positions,
        floor_mm=(electrode_floor(head) - head.origin[2]) * 1e3,
        table=table,
        findings=[rule_f5(table), rule_f6(table)],
    )


def _criterion_label(number, index, text):
    """F5's criteria by letter, F6's by noise level ("separation at 10 dB")."""
    return f"F{number} ({chr(97 + index)})" if number == 5 else f"F{number} {text}"


def _move(finding, was):
    """How a verdict changed from the primary analysis ("F6 moves from partly to ...")."""
    if finding.verdict == was:
        return f"F{finding.number} stays {was}"
    return f"F{finding.number} moves from {was} to {finding.verdict}"


def _interpretation(sens, primary):
    """One or two sentences comparing the cropped findings with the primary ones."""
    flips = [
        f"{_criterion_label(f.number, i, text)} {'now holds' if ok else 'no longer holds'}"
        for f in sens.findings
        for i, ((text, ok), (_, was)) in enumerate(
            zip(f.criteria, primary[f.number].criteria, strict=True)
        )
        if ok != was
    ]
    if not flips:
        return (
            "No criterion of F5 or F6 changes with the crop: these verdicts do not hinge on the "
            "positions below the electrode cap."
        )
    moves = "; ".join(_move(f, primary[f.number].verdict) for f in sens.findings)
    return (
        f"On the cropped grid {', '.join(flips)} ({moves}), so these criteria depend on the "
        "positions below the electrode cap. The crop was chosen after seeing the results and "
        "is no more the paper's source space than the full sphere: this shows how sensitive "
        "the findings are to the source grid, not which verdict is right."
    )


def sensitivity_section(sens, primary_findings):
    """The report section, as lines.

    Parameters
    ----------
    sens : Sensitivity
    primary_findings : list of Finding
        The primary F1 .. F6, for the comparison.

    Returns
    -------
    list of str
    """
    primary = {f.number: f for f in primary_findings}
    rows = [f"| F{f.number} | {f.paper} | {f.measured} | **{f.verdict}** |" for f in sens.findings]
    return [
        "## Sensitivity (post hoc): source grid above the lowest electrode",
        "",
        "Decided after the primary results were seen; it does not change the verdicts above. "
        "The discussion found that with exponents above 0.5 the global maximum often lies "
        "below the lowest electrode, because the volume grid fills the whole inner sphere. "
        f"Here the grid is cropped to the positions at or above the lowest electrode "
        f"({sens.floor_mm:.0f} mm re. the sphere centre): {sens.n_kept} of {sens.n_full} "
        "positions remain. The data are the primary ones (same simulations, seeds and "
        "noise); the priors and the model are recomputed from the cropped lead field. Only "
        "the settings of F5 and F6 are run (EP 20, PM 0; 10, 20, 30 dB; exponents 0.5, 1, "
        f"1.25, 1.5; no smoothing and {SMOOTHED[1]}; {len(sens.table)} runs, "
        f"`{SENSITIVITY}`), judged by the unchanged rules.",
        "",
        "| Finding | Paper | Measured on the cropped grid (mean ± SE over seeds) | Verdict |",
        "|---|---|---|---|",
        *rows,
        "",
        _interpretation(sens, primary),
        "",
    ]
