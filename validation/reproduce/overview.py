"""REPORT.md: the 2 x 2 design, both rule sets, the controls, the deviations, the factors.

Every number comes from the cells' tables (:class:`validation.reproduce.cells.CellResult`);
each cell's own page (``<cell>/CELL.md``) holds its detailed findings, tables and figures.
"""

from __future__ import annotations

from dataclasses import dataclass

from .controls import controls_section, echo_text, lone_section, lone_text
from .deviations import deviations_section, variants_text
from .findings import (
    NOT_RUN,
    VERSIONS,
    f3_text,
    f6_text,
    factor_lines,
    findings_matrix,
    in_short,
    rules_text_v2,
    rules_text_v3,
    ties_text,
)
from .report import RULES_TEXT, _markdown_table
from .settings import CELLS
from .tuned_report import tuned_section

__all__ = ["Overview", "overview_text"]


@dataclass(frozen=True)
class Overview:
    """Everything REPORT.md is written from.

    Attributes
    ----------
    settings : Settings
    manifest : dict
    results : dict
        Cell name -> CellResult, for the cells that ran.
    skipped : str or None
        Why the BEM cells did not run (None if they did).
    variants : list of Variant
    best : str
        The best cell's name (the variants ran on it).
    figures : dict
        ``"placement"`` -> file name.
    """

    settings: object
    manifest: dict
    results: dict
    skipped: str | None
    variants: list
    best: str
    figures: dict


def _summary_lines(data):
    lines = [echo_text(data), "", f6_text(data), "", ties_text(data), "", f3_text(data), ""]
    lines += [lone_text(data), ""]
    if data.variants:
        lines += [variants_text(data), ""]
    return lines


def _discussion_section(data):
    lines = ["## Discussion: which factor moves which finding", "", *_summary_lines(data)]
    if len(data.results) < len(CELLS):
        return lines + [
            "Only the sphere cells ran, so the conductor's effect is not measured here; "
            f"{data.skipped}.",
            "",
        ]
    lines += [
        "From the verdicts and the criteria of the four cells (a factor *moves* a verdict or "
        "a criterion when changing it, the other factor fixed, changes the outcome):",
        "",
        " ".join(in_short(data, version) for version in VERSIONS),
        "",
    ]
    for version in VERSIONS:
        rest = " (F4 and F6; the others are v2's)" if version == "v3" else ""
        lines += [f"By the {version} rules{rest}:", "", *factor_lines(data, version), ""]
    return lines


# --------------------------------------------------------------------------- the page


def _header(data):
    from skf_ref.study.scenario import DEEP_MNI_MM, SUPERFICIAL_MNI_MM

    settings, wanted = data.settings, data.manifest
    versions = ", ".join(f"{k} {v}" for k, v in wanted["versions"].items())
    rows = []
    for cell in CELLS:
        result = data.results.get(cell.name)
        if result is None:
            rows.append([cell.title, NOT_RUN, "", "", ""])
            continue
        head, truth = result.head, result.truth
        moved = ", ".join(f"{m:.1f}" for m in truth.moved_mm)
        rows.append(
            [
                f"[{cell.title}]({cell.name}/CELL.md)",
                str(head.n_positions),
                f"{head.spacing * 1e3:.1f}",
                "; ".join(
                    "(" + ", ".join(f"{v:.1f}" for v in p * 1e3) + ")" for p in truth.positions
                ),
                moved,
            ]
        )
    skipped = [f"- {data.skipped}."] if data.skipped else []
    return [
        "## What was run",
        "",
        f"- Command: `{settings.command()}` (`--out DIR`, `--jobs N` and the dataset's "
        "location do not change the results; DIR is MNE's testing dataset folder).",
        "- A 2 × 2 design: conductor {MNE's 4-shell sphere fitted to the `biosemi64` "
        'montage, a three-layer BEM of MNE\'s "sample" subject} × source space {a regular '
        "grid filling the brain compartment, cortex + thalamus}; each cell's page says how "
        "its head and source space are built. In every cell the same pulses, noise levels, "
        "priors (from EP/PM-SNR), seeds and rules.",
        *skipped,
        f"- Sources by MNI coordinates: deep {DEEP_MNI_MM} mm, the left thalamus' ventral "
        "posterolateral nucleus (a round-number estimate of the nucleus' centre in "
        "stereotactic atlases: 16 mm left, 22 mm behind and 4 mm above the anterior "
        f"commissure); superficial {SUPERFICIAL_MNI_MM} mm, the hand area of the posterior "
        "wall of the left central sulcus (area 3b, the N20 generator). Both were chosen "
        "before any run. In the sphere they are placed through MNE's fsaverage fiducials "
        "(fsaverage's MRI coordinates are MNI coordinates); in the sample subject through "
        "its `talairach.xfm` and head <-> MRI transform (the inverse of `mne.head_to_mni`), "
        "then moved to the nearest voxel of their aseg label (Left-Thalamus, "
        "Left-Cerebral-Cortex) if they fall outside it. The superficial orientation is made "
        "tangential to the sphere, or to the inner skull's normal nearest the source (BEM).",
        "- Paper grid, fine EP × PM map and figures as in v1, per cell; controls (one source "
        "left out of the data, the noise of both) at F4's tuning corners and at every "
        "exponent and smoother at EP 20, PM 0, all noise levels; the deviations' variants on "
        "the best cell.",
        f"- Packages: {versions}; skf_ref sources sha256 "
        f"`{wanted['skf_ref_sources_sha256'][:16]}`.",
        "",
        *_markdown_table(
            ["cell", "positions", "spacing (mm)", "deep; superficial (head mm)", "moved (mm)"],
            rows,
        ),
        "",
        f"![source placement]({data.figures['placement']})",
        "",
    ]


def overview_text(data):
    """REPORT.md without its ``Generated:`` line.

    Parameters
    ----------
    data : Overview

    Returns
    -------
    str
    """
    deviations = deviations_section(data) if data.variants else []
    lines = [
        "# SKF reproduction: Prasikala et al. (2025), P20/N20 study, in a 2 × 2 of head and "
        "source space",
        "",
        *_header(data),
        RULES_TEXT,
        *rules_text_v2(),
        *rules_text_v3(),
        *findings_matrix(data),
        *controls_section(data),
        *lone_section(data),
        *tuned_section(data),
        *deviations,
        *_discussion_section(data),
    ]
    return "\n".join(lines).rstrip("\n") + "\n"
