"""REPORT.md: the decision rules in words, the findings, the tables and the figure links.

:func:`report_text` assembles the report from a :class:`ReportData`; every number in it
comes from the sweep tables, the findings and the diagnostics, so the same results give the
same text byte for byte.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np
import pandas as pd

from skf_ref.study.regions import DYNAMIC_RANGE_DB as DETECTION_DB

from .discussion import _discussion
from .runs import electrode_floor
from .sensitivity import sensitivity_section
from .settings import (
    CORNERS,
    EXPONENTS,
    MONTAGE,
    NOISE_LEVELS,
    RESULTS,
    SMOOTHED,
    SMOOTHERS,
    TIE_MM,
    TUNED_PRIOR,
    TUNING,
    Settings,
)
from .stats import (
    _best,
    _cell,
    _fine_means,
    _mean_se,
    _pm,
    _select,
    _setting_label,
    corner_stats,
    iqr_text,
    mean_and_iqr,
    median_iqr,
)

__all__ = ["RULES_TEXT", "ReportData", "report_text"]

RULES_TEXT = f"""\
## Decision rules

Fixed before any number below was computed: they are code (`rule_f1` .. `rule_f6` in
`validation/reproduce/rules.py`), identical in every run, and the verdicts follow from the sweep
table by these rules alone. Nothing was tuned until a finding agreed.

**Quality score** of a run: the mean of the two peak localization errors,
(`deep_error_mm` + `superficial_error_mm`) / 2, in mm (error = distance from the true
dipole to the position of maximum amplitude at its peak time, 1.5 ms deep, 2.5 ms
superficial); lower is better. A setting's score is the mean over its seeds, with the
standard error SE = sample standard deviation (ddof 1) / √(number of seeds). Means within
{TIE_MM:g} mm are tied (peak errors are grid distances, so exact ties happen); **the best
cell** is the unique lowest mean, and a tie for the lowest is no unique best. Where one cell
must be picked (F4, the average maps) ties go to the first of (EP, PM) = (0, 0), (0, 20),
(20, 0), (20, 20). "Majority" means more than half of the seeds. Detection and the region
levels use the paper's {DETECTION_DB:g} dB dynamic range and 15 mm regions
(`skf_ref.study.metrics`).

**Tuning setting** (F1-F4), the paper's parameter-tuning stage (left columns of its
figures): the SKF without smoothing, standardization exponent {TUNING[0]:g}, on the 2 × 2 grid
EP-SNR, PM-SNR ∈ {{0, 20}} dB. **Smoothed setting**: exponent {SMOOTHED[0]:g}, `{SMOOTHED[1]}`.

- **F1** (10 dB, tuning setting): (a) the best cell is (EP 0, PM 0); (b) score(EP 20, PM 0)
  − score(0, 0) > score(EP 0, PM 20) − score(0, 0). Reproduced if both hold, partly if
  exactly one holds, not reproduced if neither.
- **F2** (20 dB, tuning setting): (a) the best cell is (EP 0, PM 0); (b) the spread of the
  four cell means (max − min) is smaller at 20 dB than at 10 dB. Same verdict logic as F1.
- **F3** (30 dB, tuning setting): reproduced if every cell tied for the lowest mean is
  (EP 20, PM 0) or (EP 0, PM 20); partly if not, but one of these two has a mean within one
  SE (the best cell's) of the lowest mean; otherwise not reproduced.
- **F4** (tuning setting, each noise level at its best cell): the echo (`echo`: the deep
  region's maximum at 2.5 ms over its maximum at 1.5 ms, minus the true ratio 0.25) is
  present if its mean − 2 SE > 0 (seeds with an undefined echo are left out). Reproduced if
  present at all three noise levels, partly at one or two, not reproduced at none.
- **F5** (30 dB, EP 20, PM 0; smoothed = `{SMOOTHED[1]}`): (a) for the majority of the four
  exponents {{0.5, 1, 1.25, 1.5}} (at least 3), the mean over seeds of `deep_region_db`
  (the deep region's maximum at 1.5 ms, dB re. the global maximum then) is lower smoothed
  than not smoothed at the same exponent; (b) among the smoothed exponents 1, 1.25, 1.5 the
  best (unique lowest mean score) is 1.25; (c) exponent 1, smoothed: the deep source is not
  detected (`deep_detected` false) in the majority of seeds; (d) exponent 1.5, smoothed: the
  deep region is within 6 dB of the global maximum at 2.5 ms
  (`deep_region_at_superficial_peak_db` > −6) in the majority of seeds. Reproduced if all
  four hold, partly if one to three hold, not reproduced if none.
- **F6** (EP 20, PM 0, exponent 1.25): at a noise level, separation (`separation`: deep
  detected at 1.5 ms, superficial detected at 2.5 ms and the deep region *not* within 6 dB of
  the maximum at 2.5 ms) holds with `{SMOOTHED[1]}` in at least half of the seeds, and in a
  larger fraction of seeds than without smoothing (same exponent and priors). Reproduced if
  so at all three noise levels, partly at one or two, not reproduced at none.

Verdicts are one of: reproduced, partly, not reproduced.
"""


def _markdown_table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(row) + " |" for row in rows]


def _corner_rows(paper):
    rows = []
    for snr in NOISE_LEVELS:
        for exponent, smoother in (TUNING, SMOOTHED):
            best = _best(corner_stats(paper, snr, exponent, smoother))
            cells = []
            for key in CORNERS:
                scores = _select(paper, snr, *key, exponent, smoother)["score"]
                mean = _pm(*_mean_se(scores)[:2])
                cells.append(f"{f'**{mean}**' if key in best else mean}<br>{median_iqr(scores)}")
            rows.append([f"{snr:g}", _setting_label(exponent, smoother), *cells])
    return rows


def _tuned_row(paper, snr, exponent, smoother, diag):
    """One row of the EP 20, PM 0 table: a setting's distributions and its diagnostic."""
    rows = _select(paper, snr, *TUNED_PRIOR, exponent, smoother)
    n = len(rows)
    return [
        f"{snr:g}",
        f"{exponent:g}",
        smoother,
        mean_and_iqr(rows["score"]),
        median_iqr(rows["deep_error_mm"]),
        median_iqr(rows["superficial_error_mm"]),
        median_iqr(rows["deep_region_db"]),
        median_iqr(rows["deep_region_at_superficial_peak_db"]),
        median_iqr(rows["echo"], 3),
        f"{int(rows['deep_detected'].astype(bool).sum())}/{n}",
        f"{int(rows['separation'].astype(bool).sum())}/{n}",
        "{0}/{2}, {1}/{2}".format(*diag.low, n),
        iqr_text(*diag.balance_quartiles),
    ]


def _tuned_rows(paper, diag):
    settings = product(NOISE_LEVELS, EXPONENTS, SMOOTHERS)
    return [_tuned_row(paper, *key, diag[key]) for key in settings]


def _fine_best_text(fine, settings):
    lines = []
    for exponent, smoother in (TUNING, SMOOTHED):
        means = _fine_means(fine, settings.fine_values(), exponent, smoother)
        parts = []
        for snr, grid in means.items():
            row, col = np.unravel_index(np.nanargmin(grid), grid.shape)
            ep, pm = settings.fine_values()[col], settings.fine_values()[row]
            parts.append(f"{snr:g} dB: {_cell((ep, pm))}, {grid[row, col]:.1f} mm")
        lines.append(f"- {_setting_label(exponent, smoother)}: " + "; ".join(parts))
    return lines


def head_text(head):
    """The conductor and the source space of a head, as two list items (Markdown)."""
    from skf_ref.study.head import LABELS, SHELL_DEPTH_MM, THALAMUS_RADIUS_MM

    if head.conductor_kind == "sphere":
        layers = ", ".join(
            f"{layer['rad'] * 1e3:.1f} mm / {layer['sigma']:g} S/m"
            for layer in head.conductor["layers"]
        )
        conductor = (
            f'- Head model: MNE spherical model (`make_sphere_model("auto", "auto")`) fitted '
            f"to the `{MONTAGE}` montage ({head.n_channels} EEG channels, average reference), "
            f"{len(head.conductor['layers'])} shells (outer radius / conductivity, inside out: "
            f"{layers})."
        )
    else:
        sigmas = " / ".join(f"{surf['sigma']:g}" for surf in head.conductor["surfs"])
        conductor = (
            "- Head model: MNE's linear-collocation BEM (`make_bem_solution`) of MNE's "
            '"sample" subject (testing dataset, `sample-1280-1280-1280-bem.fif`: inner skull, '
            f"outer skull, scalp, 1280 triangles each; {sigmas} S/m), the `{MONTAGE}` "
            f"channels at their MNI 10-05 positions mapped into the subject and moved onto its "
            f"scalp ({head.n_channels} EEG channels, average reference)."
        )
    spacing = f"{head.spacing * 1e3:.1f} mm"
    columns = f"free orientation ({head.leadfield.shape[1]} lead-field columns)"
    if head.source_space == "volume":
        where = "the innermost shell" if head.conductor_kind == "sphere" else "the inner skull"
        space = (
            f"- Source space: regular volume grid of {head.n_positions} positions (spacing "
            f"{spacing}) filling {where} (5 mm margin), {columns}."
        )
    elif head.conductor_kind == "sphere":
        space = (
            f"- Source space: the sphere's equivalent of cortex + thalamus, {head.n_positions} "
            f"positions of a {spacing} lattice: a cortex 5-{SHELL_DEPTH_MM[1]:g} mm below the "
            "brain sphere at or above the fiducial plane, and two balls of the sample "
            f"subject's thalamus volume (radius {THALAMUS_RADIUS_MM:g} mm) at the MNI "
            f"centroids of its thalami; {columns}."
        )
    else:
        labels = ", ".join(f"{name} ({label})" for name, label in LABELS.items())
        space = (
            f"- Source space: MNE's volume source space on the aseg labels {labels}, "
            f"{spacing} grid in MRI coordinates, 5 mm inside the inner skull: "
            f"{head.n_positions} positions, {columns}."
        )
    return [conductor, space]


def sources_text(head, truth):
    """Where the two sources are, in MNI and in this head (one list item)."""
    from skf_ref.study.scenario import DEEP_MNI_MM, SUPERFICIAL_MNI_MM

    def mm(values):
        return "(" + ", ".join(f"{v:.1f}" for v in values) + ")"

    parts = []
    for name, mni, pos, moved in zip(
        ("deep", "superficial"),
        (DEEP_MNI_MM, SUPERFICIAL_MNI_MM),
        truth.positions,
        truth.moved_mm,
        strict=True,
    ):
        text = f"{name} at MNI {mm(mni)} mm -> head {mm(pos * 1e3)} mm"
        if moved > 0:
            text += f" (moved {moved:.1f} mm into its aseg label)"
        parts.append(text)
    return (
        "- Sources: "
        + "; ".join(parts)
        + "; the superficial one tangential to "
        + ("the sphere" if head.conductor_kind == "sphere" else "the nearest inner-skull normal")
        + ". Hann pulses of 3 ms, 10 nAm, peaks at 1.5 and 2.5 ms; 10 kHz, 0-4 ms (41 "
        "samples). Data from the exact dipoles' own forward field, not grid columns (no "
        "inverse crime); white noise at peak SNR 10, 20, 30 dB; the inverse uses the true "
        'noise level. Priors from EP/PM-SNR with the "gain" amplitude convention '
        "(docs/model.md §4)."
    )


def _header(settings, head, wanted, paper, fine, truth):
    versions = ", ".join(f"{k} {v}" for k, v in wanted["versions"].items())
    fine_values = ", ".join(f"{v:g}" for v in settings.fine_values())
    return [
        "## What was run",
        "",
        f"- Command: `{settings.command()}` (`--out DIR` and `--jobs N` do not change the "
        "results).",
        *head_text(head),
        sources_text(head, truth),
        f"- Paper grid (`{RESULTS[0]}`, {len(paper)} runs): 10/20/30 dB; EP, PM ∈ {{0, 20}} dB; "
        "exponents 0.5, 1, 1.25, 1.5; smoothers none, rts-standardized, rts-state; seeds "
        f"0..{settings.seeds - 1}.",
        f"- Fine map (`{RESULTS[1]}`, {len(fine)} runs): EP, PM ∈ {{{fine_values}}} dB at "
        f"10/20/30 dB for ({_setting_label(*TUNING)}) and ({_setting_label(*SMOOTHED)}), "
        f"seeds 0..{settings.seeds - 1}.",
        "- Controls (`control_deep.csv`, `control_superficial.csv`): the same runs of F4-F6's "
        "settings and of every exponent and smoother at EP 20, PM 0 with one source left out "
        "of the data (same seeds, same noise).",
        "- Per-setting aggregates: `summary.csv`; run settings: `../settings.json`.",
        f"- Packages: {versions}; skf_ref sources sha256 "
        f"`{wanted['skf_ref_sources_sha256'][:16]}`.",
        "",
    ]


def _findings_section(findings, title="## Findings"):
    rows = [[f"F{f.number}", f.paper, f.measured, f"**{f.verdict}**"] for f in findings]
    return [
        title,
        "",
        *_markdown_table(["Finding", "Paper", "Measured (mean ± SE over seeds)", "Verdict"], rows),
        "",
    ]


def _findings_v3_section(findings):
    """The v3 verdicts: F4 and F6 with their numbers, the others as by v2 (same rule)."""
    from .rules_v3 import CHANGED

    rows = [
        [
            f"F{f.number}",
            f.paper,
            f.measured if f.number in CHANGED else "as by the v2 rule (above)",
            f"**{f.verdict}**",
        ]
        for f in findings
    ]
    header = ["Finding", "Paper", "Measured (mean ± SE, median [Q1, Q3] over seeds)", "Verdict"]
    return ["## Findings by the v3 rules", "", *_markdown_table(header, rows), ""]


def _tables_section(data):
    paper, fine, settings = data.paper, data.fine, data.settings
    corner_header = ["SNR (dB)", "setting", *(_cell(k) for k in CORNERS)]
    tuned_header = [
        "SNR (dB)",
        "exponent",
        "smoother",
        "score (mm)",
        "deep err (mm)",
        "sup. err (mm)",
        "deep @1.5 ms (dB)",
        "deep @2.5 ms (dB)",
        "echo",
        "deep detected",
        "separated",
        "max below electrodes (1.5, 2.5 ms)",
        "deep/sup. balance (dB)",
    ]
    return [
        "## Tables",
        "",
        "### 2 × 2 prior grids: score (mm) over seeds",
        "",
        f"Each cell: mean ± SE over the {settings.seeds} seeds, what the rules read (bold: the "
        "lowest mean), above the median [first quartile, third quartile].",
        "",
        *_markdown_table(corner_header, _corner_rows(paper)),
        "",
        f"### Every exponent and smoother at EP {TUNED_PRIOR[0]:g}, PM {TUNED_PRIOR[1]:g}",
        "",
        f"Median [first quartile, third quartile] over the {settings.seeds} seeds (the score "
        "also as mean ± SE, what F5 (b) reads, above its median); region levels in dB re. the "
        "global maximum at that time; counts are seeds. The last two columns are post-hoc "
        "diagnostics, added after the verdicts were seen and used by no rule: the seeds "
        "whose global maximum at the deep (1.5 ms) "
        "and at the superficial (2.5 ms) peak lies below the lowest electrode "
        f"({(electrode_floor(data.head) - data.head.origin[2]) * 1e3:.0f} mm re. the centre of "
        "the brain compartment's sphere, fitted to the inner skull for a BEM; the grid reaches "
        f"{(data.head.positions[:, 2].min() - data.head.origin[2]) * 1e3:.0f} mm), and the "
        "deep-to-superficial balance, 20 log10 of the deep region's maximum at 1.5 ms over "
        "the superficial region's maximum at 2.5 ms (0 dB: equal peaks, as in the truth).",
        "",
        *_markdown_table(tuned_header, _tuned_rows(paper, data.diagnostics)),
        "",
        "### Fine EP × PM map: lowest mean score",
        "",
        *_fine_best_text(fine, settings),
        "",
    ]


def _figures_section(figures, settings):
    if not figures:
        return ["## Figures", "", "Not drawn: a --quick run draws the first cell's only.", ""]
    lines = [
        "## Figures",
        "",
        "Time courses: the maximum amplitude over each source's 15 mm region (solid; deep "
        "green, superficial red) against the true waveforms (dashed).",
        "",
    ]
    for snr in NOISE_LEVELS:
        left, right = (
            figures["prior_grid"][snr, "nonsmoothed"],
            figures["prior_grid"][snr, "smoothed"],
        )
        lines += [
            f"### {snr:g} dB: EP × PM grid, {_setting_label(*TUNING)} (left) and "
            f"{_setting_label(*SMOOTHED)} (right), seed 0",
            "",
            "| | |",
            "|---|---|",
            f"| ![{left}]({left}) | ![{right}]({right}) |",
            "",
        ]
    name, seeds, bounds = figures["exponents"], figures["exponent_seeds"], figures["bounds"]
    lines += [
        f"### Standardization exponent, 30 dB, EP {TUNED_PRIOR[0]:g}, PM {TUNED_PRIOR[1]:g}, "
        f"{SMOOTHED[1]}, seed 0",
        "",
        f"![{name}]({name})",
        "",
        f"### Standardization exponent over seeds, 30 dB, EP {TUNED_PRIOR[0]:g}, PM "
        f"{TUNED_PRIOR[1]:g}",
        "",
        f"Each of the {settings.seeds} seeds is a point (jittered sideways), the bar its "
        f"median; without smoothing (grey) and with {SMOOTHED[1]} (blue). F5's numbers.",
        "",
        f"![{seeds}]({seeds})",
        "",
        "### The echo and its two bounds over seeds (F4, F6)",
        "",
        f"Left: F4's readings at each noise level's best tuning cell, v1's echo and v3's two "
        f"bounds (the deep excess over the superficial-only control, the deep-only control's "
        f"echo). Right: how {SMOOTHED[1]} (exponent {SMOOTHED[0]:g}, EP {TUNED_PRIOR[0]:g}, PM "
        f"{TUNED_PRIOR[1]:g}) changes each reading, seed by seed (F6 (a): below zero is "
        "suppression). Points are seeds, bars medians.",
        "",
        f"![{bounds}]({bounds})",
        "",
        f"### Average reconstructions (amplitude averaged over {settings.seeds} seeds)",
        "",
        "Maximum-intensity projections at 1.5 ms (deep peak) and 2.5 ms (superficial peak), "
        "6 dB range. Not smoothed: exponent 0.5 at the noise level's best tuning cell; "
        "smoothed: exponent 1.25, rts-standardized, EP 20, PM 0.",
        "",
    ]
    for (snr, tag), (name, prior) in figures["average"].items():
        lines += [
            f"{snr:g} dB, {tag.replace('non', 'not ')} {_cell(prior)}:",
            "",
            f"![{name}]({name})",
            "",
        ]
    lines += ["### Fine EP × PM maps (mean score over seeds, per noise level)", ""]
    for name in figures["fine_map"].values():
        lines += [f"![{name}]({name})", ""]
    return lines


@dataclass(frozen=True)
class ReportData:
    """Everything REPORT.md is written from.

    Attributes
    ----------
    settings : Settings
    head : skf_ref.study.scenario.HeadModel
    manifest : dict
        From :func:`manifest`.
    paper, fine : pandas.DataFrame
        The sweep tables.
    findings : list of Finding
    figures : dict
        From :func:`make_figures`; empty where a --quick run drew none.
    diagnostics : dict
        From :func:`diagnostics`.
    sensitivity : Sensitivity or None
        From :func:`run_sensitivity` (post hoc; its section follows the discussion).
    findings_v2 : list of Finding
        The v2 verdicts (:mod:`validation.reproduce.rules_v2`).
    findings_v3 : list of Finding
        The v3 verdicts (:mod:`validation.reproduce.rules_v3`).
    truth : skf_ref.study.scenario.Truth
        The sources placed in this head.
    title : str
        The cell.
    """

    settings: Settings
    head: object
    manifest: dict
    paper: pd.DataFrame
    fine: pd.DataFrame
    findings: list
    figures: dict
    diagnostics: dict
    sensitivity: object = None
    findings_v2: list = None
    findings_v3: list = None
    truth: object = None
    title: str = "sphere, volume grid"


def _sensitivity_lines(data):
    if data.sensitivity is None:
        return []
    return sensitivity_section(data.sensitivity, data.findings)


def report_text(data):
    """REPORT.md without its ``Generated:`` line (that line is inserted by :func:`main`).

    Parameters
    ----------
    data : ReportData

    Returns
    -------
    str
    """
    v2 = []
    if data.findings_v2:
        v2 = _findings_section(data.findings_v2, "## Findings by the v2 rules")
    if data.findings_v3:
        v2 += _findings_v3_section(data.findings_v3)
    lines = [
        f"# SKF reproduction, {data.title}: Prasikala et al. (2025), P20/N20 study",
        "",
        *_header(data.settings, data.head, data.manifest, data.paper, data.fine, data.truth),
        "The decision rules (v1, v2 and v3) are stated in `../REPORT.md`.",
        "",
        *_findings_section(data.findings, "## Findings by the v1 rules"),
        *v2,
        *_discussion(data),
        *_sensitivity_lines(data),
        *_tables_section(data),
        *_figures_section(data.figures, data.settings),
    ]
    return "\n".join(lines).rstrip("\n") + "\n"
