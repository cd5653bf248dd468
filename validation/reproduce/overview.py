"""REPORT.md: the 2 x 2 design, both rule sets, the controls, the deviations, the factors.

Every number comes from the cells' tables (:class:`validation.reproduce.cells.CellResult`);
each cell's own page (``<cell>/CELL.md``) holds its detailed findings, tables and figures.
"""

from __future__ import annotations

from dataclasses import dataclass

from .report import RULES_TEXT, _markdown_table
from .rules_v2 import __doc__ as _V2_DOC
from .rules_v2 import deep_excess
from .settings import (
    CELLS,
    EXPONENTS,
    NOISE_LEVELS,
    SMOOTHED,
    SMOOTHERS,
    TUNED_PRIOR,
    TUNING,
)
from .stats import _best, _cell, _fmt, _mean_se, _pm, _select, corner_stats
from .tuned import tuned_section

__all__ = ["Overview", "overview_text"]

NOT_RUN = "not run"


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


def _v2_rules_text():
    """The v2 rules as the report states them: the module docstring's list, as Markdown."""
    body = _V2_DOC.split("What changes (docs/model.md §7 for the findings):", 1)[1]
    body = body.split("The rules are pure functions", 1)[0].strip()
    return [
        "## Decision rules, v2",
        "",
        "Written and committed before any v2 number was computed (`rule_v2_f1` .. "
        "`rule_v2_f6` in `validation/reproduce/rules_v2.py`); everything not named here is "
        "as in v1.",
        "",
        body,
        "",
    ]


def _verdict(finding):
    return f"**{finding.verdict}**"


def _findings_matrix(data):
    header = ["Finding", "Paper", *(f"{cell.title} (v1 / v2)" for cell in CELLS)]
    rows = []
    for index in range(6):
        paper = None
        cells = []
        for cell in CELLS:
            result = data.results.get(cell.name)
            if result is None:
                cells.append(NOT_RUN)
                continue
            v1, v2 = result.findings[index], result.findings_v2[index]
            paper = v1.paper
            cells.append(f"{_verdict(v1)} / {_verdict(v2)}")
        rows.append([f"F{index + 1}", paper or "", *cells])
    lines = [
        "## Findings: v1 and v2 verdicts in every cell",
        "",
        "Each cell's page (linked below) shows the numbers behind every verdict. "
        + (f"The BEM cells were not run: {data.skipped}." if data.skipped else ""),
        "",
        *_markdown_table(header, rows),
        "",
    ]
    return lines


# --------------------------------------------------------------------------- controls


def _control_rows(result):
    """Per noise level: F4's echo against the control, and F6's residual against it."""
    rows = []
    controls = result.controls
    for snr in NOISE_LEVELS:
        ep, pm = _best(corner_stats(result.paper, snr))[0]
        joined = deep_excess(result.paper, controls["superficial"], snr, ep, pm, *TUNING)
        ratio = joined["deep_max_at_superficial_peak"] / joined["deep_max_at_deep_peak"]
        control_ratio = (joined["deep_max_at_superficial_peak"] * joined["spread_share"]) / joined[
            "deep_max_at_deep_peak"
        ]
        alone = _select(controls["deep"], snr, ep, pm, *TUNING)["echo"]
        exponent, smoother = SMOOTHED
        f6 = _select(result.paper, snr, *TUNED_PRIOR, exponent, smoother)
        f6_control = _select(controls["superficial"], snr, *TUNED_PRIOR, exponent, smoother)
        column = "deep_region_at_superficial_peak_db"
        rows.append(
            [
                f"{snr:g}",
                _cell((ep, pm)),
                _fmt(_mean_se(ratio)[0], 2),
                _fmt(_mean_se(control_ratio)[0], 2),
                f"{100 * _mean_se(joined['spread_share'])[0]:.0f} %",
                _pm(*_mean_se(joined["excess"])[:2], 3),
                _pm(*_mean_se(alone)[:2], 3),
                _fmt(_mean_se(f6[column])[0]),
                _fmt(_mean_se(f6_control[column])[0]),
            ]
        )
    return rows


def _controls_section(data):
    header = [
        "SNR (dB)",
        "best tuning cell",
        "ratio, both sources",
        "ratio, superficial only",
        "spread share",
        "deep excess (v2 echo)",
        "echo, deep only",
        "F6 residual (dB), both",
        "F6 residual (dB), superficial only",
    ]
    lines = [
        "## Controls: how much of the echo and the residual is the other source's spread",
        "",
        "Each run of F4-F6's settings was repeated with one source left out of the data "
        "(same head, priors, seed and noise draws). *Ratio*: the deep region's maximum at "
        "2.5 ms over its maximum at 1.5 ms of the run with both sources (v1's echo is this "
        "minus 0.25); the same numerator taken from the superficial-only control; *spread "
        "share*: the control's deep-region maximum at 2.5 ms as a share of the run's; *deep "
        "excess*: v2's echo, what remains beyond the spread and the true deep activity; "
        "*echo, deep only*: v1's echo in the deep-only control. F6 residual: the deep "
        f"region's level at 2.5 ms (dB re. the maximum) with exponent {SMOOTHED[0]:g}, "
        f"{SMOOTHED[1]}, EP {TUNED_PRIOR[0]:g}, PM {TUNED_PRIOR[1]:g}. Means over seeds.",
        "",
    ]
    for cell in CELLS:
        result = data.results.get(cell.name)
        lines += [f"### {cell.title}", ""]
        if result is None:
            lines += [f"{NOT_RUN}.", ""]
            continue
        lines += [*_markdown_table(header, _control_rows(result)), ""]
    return lines


def lone_source_errors(result, snr=30.0):
    """Mean peak error (mm) of each lone source by exponent and smoother, EP 20, PM 0.

    Returns
    -------
    dict
        (source, exponent, smoother) -> (mean, SE): ``"deep"`` is the deep-only control's
        ``deep_error_mm`` at 1.5 ms, ``"superficial"`` the superficial-only control's
        ``superficial_error_mm`` at 2.5 ms.
    """
    out = {}
    for source, column in (("deep", "deep_error_mm"), ("superficial", "superficial_error_mm")):
        for exponent in EXPONENTS:
            for smoother in SMOOTHERS:
                rows = _select(result.controls[source], snr, *TUNED_PRIOR, exponent, smoother)
                out[source, exponent, smoother] = _mean_se(rows[column])[:2]
    return out


def _lone_section(data):
    header = ["cell", "source", "exponent", *SMOOTHERS]
    rows = []
    shifts = []
    for cell in CELLS:
        result = data.results.get(cell.name)
        if result is None:
            rows.append([cell.title, NOT_RUN, "", "", "", ""])
            continue
        errors = lone_source_errors(result)
        for source in ("deep", "superficial"):
            for exponent in EXPONENTS:
                values = [_pm(*errors[source, exponent, s]) for s in SMOOTHERS]
                rows.append([cell.title, source, f"{exponent:g}", *values])
            filt = [errors[source, e, "none"][0] for e in EXPONENTS]
            std = [errors[source, e, "rts-standardized"][0] for e in EXPONENTS]
            state = [errors[source, e, "rts-state"][0] for e in EXPONENTS]
            shifts.append(
                f"{cell.title}, lone {source} source: filter {min(filt):.0f}-{max(filt):.0f} mm, "
                f"rts-state {min(state):.0f}-{max(state):.0f} mm, rts-standardized "
                f"{min(std):.0f}-{max(std):.0f} mm"
            )
    return [
        "## A lone source under each smoother and exponent",
        "",
        "Peak localization error (mm, mean ± SE over seeds) of a source alone in the data "
        "(the controls) at 30 dB, EP 20, PM 0: the deep source at 1.5 ms in the deep-only "
        "data, the superficial at 2.5 ms in the superficial-only data. A smoother that moves "
        "a lone source's peak carries a bias of its own, whatever the other source does. "
        "Over the four exponents: " + "; ".join(shifts) + ".",
        "",
        *_markdown_table(header, rows),
        "",
    ]


# --------------------------------------------------------------------------- deviations

_DEVIATIONS = (
    (
        "Pulse windows: Hann here, Blackman-Harris in the toolbox",
        "the overlap of the two pulses, so the echo and separation (F4-F6)",
        "blackman-harris",
    ),
    (
        "Orientation: free (three columns per position) here, the paper's divergence-"
        "conforming sources are oriented by the mesh",
        "every peak error; not run: a volume source space has no surface normals, and the "
        "testing subset has no cortical surface to take them from",
        None,
    ),
    (
        "Data from the exact dipoles here; from grid columns at the nearest positions, the "
        "'inverse crime', a common alternative",
        "the localization scores (F1-F3, F5 (b)) most",
        "grid-columns",
    ),
    (
        "Noise: white Gaussian at a peak SNR (as the paper states); the toolbox's own noise "
        "generator is not available here",
        "nothing this study can test: not run",
        None,
    ),
    (
        "Exponent of the tuning stage: 0.5 assumed (the paper does not state it)",
        "F1-F4, which are judged at that exponent",
        "tuning-exponent-1.25",
    ),
)


def _variant_cells(variant, base):
    cells = []
    for index in range(6):
        if index >= len(variant.findings):
            cells.append("n/a")
            continue
        v1, v2 = variant.findings[index], variant.findings_v2[index]
        b1, b2 = base.findings[index], base.findings_v2[index]
        moved = "" if (v1.verdict, v2.verdict) == (b1.verdict, b2.verdict) else " (moved)"
        cells.append(f"{v1.verdict} / {v2.verdict}{moved}")
    return cells


def _deviations_section(data):
    base = data.results[data.best]
    variants = {v.name: v for v in data.variants}
    header = ["deviation", "could move", *(f"F{i}" for i in range(1, 7))]
    rows = [
        [
            "(the best cell as run)",
            "",
            *(
                f"{a.verdict} / {b.verdict}"
                for a, b in zip(base.findings, base.findings_v2, strict=True)
            ),
        ]
    ]
    for text, moves, name in _DEVIATIONS:
        if name is None or name not in variants:
            rows.append([text, moves, *(["not run"] * 6)])
        else:
            rows.append([text, moves, *_variant_cells(variants[name], base)])
    best_title = next(cell.title for cell in CELLS if cell.name == data.best)
    return [
        "## Deviations from the paper's setup, and their variants",
        "",
        f"Each variant that could move a verdict was run on the best cell, **{best_title}** "
        "(the most v2 findings reproduced, a partly counting half; ties to the cell nearest the "
        "paper's setup; rule fixed before the runs), on the settings the rules read, with the "
        "superficial-only control for the v2 rules. Verdicts v1 / v2; '(moved)' where either "
        f"differs from the cell as run. Files: `variants/`. {_variants_note()}",
        "",
        *_markdown_table(header, rows),
        "",
        OPENMEEG_NOTE,
        "",
    ]


def _variants_note():
    return (
        "The tuning-exponent variant judges F1-F4 with exponent 1.25 in place of 0.5 "
        "(F5 and F6 do not use the tuning exponent: n/a)."
    )


#: Checked once by hand, outside this run (OpenMEEG is not a dependency of skf_ref).
OPENMEEG_NOTE = (
    "**BEM solver.** The BEM cells use MNE's linear-collocation solver. Whether OpenMEEG's "
    'symmetric BEM (through MNE, `make_bem_solution(..., solver="openmeeg")`, OpenMEEG '
    "2.6) would matter was checked once, by hand and outside this run, on the BEM cortex + "
    "thalamus cell: its lead field differs from MNE's by 16 % overall (median column 9 %, "
    "95th percentile 28 %; on three nested spheres MNE's solver is 5-7 % off the analytic "
    "solution at this mesh resolution, `tests/test_head.py`), but on the settings the rules "
    "read (10 seeds) every v1 verdict and five of the six v2 verdicts are the same; v2 F1 "
    "moves from reproduced to partly, because F1 (b), a margin of 2.4 ± 1.9 mm here, becomes "
    "a tie. OpenMEEG is therefore not used: it changes no finding beyond that marginal "
    "criterion, and would add a compiled dependency and about 90 s to the forward model."
)


# --------------------------------------------------------------------------- factors


def _flags(result, version):
    findings = result.findings if version == "v1" else result.findings_v2
    return [[ok for _, ok in f.criteria] for f in findings], [f.verdict for f in findings]


def _factor(values):
    """Which factor moves a quantity given its value per cell name (all four cells)."""
    by = {name: values[name] for name in values}
    conductor = [by[f"sphere-{space}"] != by[f"bem-{space}"] for space in ("volume", "anatomical")]
    space = [by[f"{cond}-volume"] != by[f"{cond}-anatomical"] for cond in ("sphere", "bem")]
    if not any(conductor) and not any(space):
        return None
    if all(space) and not any(conductor):
        return "the source space"
    if all(conductor) and not any(space):
        return "the conductor"
    if any(space) and not any(conductor):
        return "the source space (in one conductor)"
    if any(conductor) and not any(space):
        return "the conductor (in one source space)"
    return "both factors (they interact)"


_LEVELS = ("at 10 dB", "at 20 dB", "at 30 dB")
#: Short names of every criterion, by rule set and finding.
_CRITERIA = {
    "v1": {
        1: ("best cell (EP 0, PM 0)", "raising EP costs more than raising PM"),
        2: ("best cell (EP 0, PM 0)", "less sensitive than at 10 dB (absolute spread)"),
        3: ("best cell (EP 20, PM 0) or (EP 0, PM 20)", "one of them within one SE of the best"),
        4: tuple(f"echo {level}" for level in _LEVELS),
        5: (
            "smoothing lowers the deep region",
            "exponent 1.25 best",
            "exponent 1 misses the deep source",
            "exponent 1.5 overemphasizes it",
        ),
        6: tuple(f"separation {level}" for level in _LEVELS),
    },
    "v2": {
        1: ("best cell (EP 0, PM 0)", "raising EP costs more than raising PM by one SE"),
        2: ("best cell (EP 0, PM 0)", "smaller relative spread than at 10 dB by one SE"),
        3: ("best by localization score", "best by correlation", "best by log-likelihood"),
        4: tuple(f"deep excess {level}" for level in _LEVELS),
        5: (
            "smoothing lowers the deep region",
            "exponent 1.25 best",
            "exponent 1 misses the deep source",
            "exponent 1.5: deep excess above zero",
        ),
        6: tuple(f"separation against the control {level}" for level in _LEVELS),
    },
}


def _criterion_name(finding, index, version):
    return f"F{finding.number} ({chr(97 + index)}), {_CRITERIA[version][finding.number][index]}"


def _in_short(data, version):
    """One sentence: which factor moves which finding's verdict."""
    names = [cell.name for cell in CELLS]
    groups = {}
    for index in range(6):
        verdicts = {name: _flags(data.results[name], version)[1][index] for name in names}
        groups.setdefault(_factor(verdicts) or "nothing (the same in every cell)", []).append(
            f"F{index + 1}"
        )
    parts = [f"{', '.join(found)}: {factor}" for factor, found in groups.items()]
    return f"In short, by {version}, what moves each verdict: " + "; ".join(parts) + "."


def _factor_lines(data, version):
    names = [cell.name for cell in CELLS]
    flags = {name: _flags(data.results[name], version) for name in names}
    lines = []
    for index in range(6):
        verdicts = {name: flags[name][1][index] for name in names}
        factor = _factor(verdicts)
        listing = ", ".join(f"{c.title}: {verdicts[c.name]}" for c in CELLS)
        if factor is None:
            lines.append(f"- F{index + 1}: {verdicts[names[0]]} in every cell.")
        else:
            lines.append(f"- F{index + 1} moves with {factor} ({listing}).")
        finding = data.results[names[0]].findings[index]
        if version == "v2":
            finding = data.results[names[0]].findings_v2[index]
        for k in range(len(finding.criteria)):
            holds = {name: flags[name][0][index][k] for name in names}
            moved = _factor(holds)
            if moved is not None:
                where = ", ".join(c.title for c in CELLS if holds[c.name]) or "no cell"
                lines.append(
                    f"  - {_criterion_name(finding, k, version)}: moves with {moved}; holds in "
                    f"{where}."
                )
    return lines


def _range(values, digits=0, unit=""):
    values = [v for v in values if v == v]
    return f"{min(values):.{digits}f} to {max(values):.{digits}f}{unit}"


def _echo_text(data):
    shares, excess, alone = [], [], []
    for result in data.results.values():
        for snr in NOISE_LEVELS:
            ep, pm = _best(corner_stats(result.paper, snr))[0]
            joined = deep_excess(
                result.paper, result.controls["superficial"], snr, ep, pm, *TUNING
            )
            shares.append(100 * joined["spread_share"].mean())
            excess.append(joined["excess"].mean())
            alone.append(_select(result.controls["deep"], snr, ep, pm, *TUNING)["echo"].mean())
    return (
        "**The echo (F4) and the residual (F6).** At every noise level's best tuning cell, in "
        f"every cell that ran, the superficial-only control holds {_range(shares)} % of the "
        "deep region's maximum at 2.5 ms: most of what v1 counts as an echo is the superficial "
        "source's spread into the deep region, and the same holds for F6's residual (the "
        "controls' residuals in the table above are within a few tenths of a dB of the runs'). "
        "The deep source does linger by itself: alone in the data, its region keeps at 2.5 ms "
        "more of its peak than its waveform does (deep-only echo "
        f"{_range(alone, 3)}, 0 for none). But in the data with both sources the deep region's "
        "maximum exceeds the control's by less than the true deep activity (deep excess "
        f"{_range(excess, 3)}), so by the v2 rule the echo is not present. Region maxima do "
        "not add (the deep source's own activity and the spread peak at different positions of "
        "the region), so the excess can understate what the deep source contributes; the "
        "deep-only echo is the other bound."
    )


def _variants_text(data):
    base = data.results[data.best]
    moves = []
    for variant in data.variants:
        for version, findings, ref in (
            ("v1", variant.findings, base.findings),
            ("v2", variant.findings_v2, base.findings_v2),
        ):
            for finding, was in zip(findings, ref, strict=False):
                if finding.verdict != was.verdict:
                    moves.append(
                        f"{variant.what}: {version} F{finding.number} {was.verdict} -> "
                        f"{finding.verdict}"
                    )
    if not moves:
        return "**The deviations.** No variant moved a verdict of the best cell."
    return "**The deviations.** On the best cell the variants moved: " + "; ".join(moves) + "."


def _ties_text(data):
    parts = []
    for index, name in ((0, "F1 (b)"), (1, "F2 (b)")):
        held_v1 = [
            c.title for c in CELLS if c.name in data.results and _holds(data, c, "v1", index, 1)
        ]
        held_v2 = [
            c.title for c in CELLS if c.name in data.results and _holds(data, c, "v2", index, 1)
        ]
        parts.append(
            f"{name} holds by v1 in {len(held_v1)} of {len(data.results)} cells "
            f"({', '.join(held_v1) or 'none'}) and by v2, with the one-SE margin"
            + (" and relative spreads" if index == 1 else "")
            + f", in {len(held_v2)} ({', '.join(held_v2) or 'none'})"
        )
    return "**F1 (b) and F2 (b).** " + "; ".join(parts) + "."


def _holds(data, cell, version, index, criterion):
    result = data.results[cell.name]
    findings = result.findings if version == "v1" else result.findings_v2
    return bool(findings[index].criteria[criterion][1])


def _f3_text(data):
    parts = []
    for cell in CELLS:
        if cell.name not in data.results:
            continue
        flags = [ok for _, ok in data.results[cell.name].findings_v2[2].criteria]
        measures = [n for n, ok in zip(_CRITERIA["v2"][3], flags, strict=True) if ok]
        parts.append(f"{cell.title}: {', '.join(measures) or 'none of the three'}")
    return (
        "**F3 by three measures.** The measures whose best cell at 30 dB is (EP 20, PM 0) or "
        "(EP 0, PM 20): " + "; ".join(parts) + "."
    )


def _lone_text(data):
    parts = []
    for cell in CELLS:
        result = data.results.get(cell.name)
        if result is None:
            continue
        errors = lone_source_errors(result)
        values = [errors["deep", 0.5, s][0] for s in SMOOTHERS]
        parts.append(
            f"{cell.title}: filter {values[0]:.0f} mm, rts-standardized {values[1]:.0f} mm, "
            f"rts-state {values[2]:.0f} mm"
        )
    return (
        "**A lone source under the smoothers.** With the deep source alone in the data (30 "
        "dB, EP 20, PM 0, exponent 0.5) its peak lies, on average over seeds, "
        + "; ".join(parts)
        + ". Where rts-standardized is far off while the filter and rts-state are not, the "
        "paper's smoother moves a lone source's peak by itself; the table above gives every "
        "exponent and the superficial source."
    )


def _summary_lines(data):
    lines = [_echo_text(data), "", _ties_text(data), "", _f3_text(data), "", _lone_text(data), ""]
    if data.variants:
        lines += [_variants_text(data), ""]
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
        _in_short(data, "v1") + " " + _in_short(data, "v2"),
        "",
        "By the v1 rules:",
        "",
        *_factor_lines(data, "v1"),
        "",
        "By the v2 rules:",
        "",
        *_factor_lines(data, "v2"),
        "",
    ]
    return lines


# --------------------------------------------------------------------------- the page


def _header(data):
    from skf_ref.simulate import DEEP_MNI_MM, SUPERFICIAL_MNI_MM

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
    deviations = _deviations_section(data) if data.variants else []
    lines = [
        "# SKF reproduction: Prasikala et al. (2025), P20/N20 study, in a 2 × 2 of head and "
        "source space",
        "",
        *_header(data),
        RULES_TEXT,
        *_v2_rules_text(),
        *_findings_matrix(data),
        *_controls_section(data),
        *_lone_section(data),
        *tuned_section(data),
        *deviations,
        *_discussion_section(data),
    ]
    return "\n".join(lines).rstrip("\n") + "\n"
