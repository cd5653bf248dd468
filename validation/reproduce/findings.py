"""REPORT.md's verdicts: the rule sets in words, the findings matrix, what moves each finding.

Reads the verdicts of every cell (:class:`validation.reproduce.cells.CellResult`); a factor
of the 2 x 2 design *moves* a verdict or a criterion when changing it, the other factor
fixed, changes the outcome.
"""

from __future__ import annotations

from .report import _markdown_table
from .rules_v2 import __doc__ as _V2_DOC
from .rules_v3 import CHANGED
from .rules_v3 import __doc__ as _V3_DOC
from .settings import CELLS, NOISE_LEVELS

__all__ = [
    "NOT_RUN",
    "VERSIONS",
    "f3_text",
    "f6_text",
    "factor_lines",
    "findings_matrix",
    "findings_of",
    "in_short",
    "rules_text_v2",
    "rules_text_v3",
    "ties_text",
]

NOT_RUN = "not run"
#: The rule sets, in the order the report shows their verdicts.
VERSIONS = ("v1", "v2", "v3")


def findings_of(result, version):
    """A cell's (or a variant's) findings by one rule set of :data:`VERSIONS`."""
    attribute = {"v1": "findings", "v2": "findings_v2", "v3": "findings_v3"}[version]
    return getattr(result, attribute)


def _rules_body(doc):
    """The list of a rule module's docstring that says what changes, as Markdown."""
    body = doc.split("What changes (docs/model.md §7 for the findings):", 1)[1]
    return body.split("The rules are pure functions", 1)[0].strip()


def rules_text_v2():
    """The v2 rules as the report states them: the module docstring's list, as Markdown."""
    return [
        "## Decision rules, v2",
        "",
        "Written and committed before any v2 number was computed (`rule_v2_f1` .. "
        "`rule_v2_f6` in `validation/reproduce/rules_v2.py`); everything not named here is "
        "as in v1.",
        "",
        _rules_body(_V2_DOC),
        "",
    ]


def rules_text_v3():
    """The v3 rules as the report states them, and when they were written."""
    return [
        "## Decision rules, v3",
        "",
        "Written after the v2 numbers of the committed full run were known (v2's rules were "
        "committed before any v2 number), and fixed in code (`rule_v3_f4`, `rule_v3_f6` in "
        "`validation/reproduce/rules_v3.py`) before the run that generated this report; "
        "everything not named here is as in v2. v2 stays as it was, beside v3.",
        "",
        _rules_body(_V3_DOC),
        "",
    ]


def _verdict(finding):
    return f"**{finding.verdict}**"


def findings_matrix(data):
    """The verdicts of every rule set in every cell, as REPORT.md lines."""
    header = ["Finding", "Paper", *(f"{cell.title} (v1 / v2 / v3)" for cell in CELLS)]
    rows = []
    for index in range(6):
        paper = None
        cells = []
        for cell in CELLS:
            result = data.results.get(cell.name)
            if result is None:
                cells.append(NOT_RUN)
                continue
            found = [findings_of(result, version)[index] for version in VERSIONS]
            paper = found[0].paper
            cells.append(" / ".join(_verdict(finding) for finding in found))
        rows.append([f"F{index + 1}", paper or "", *cells])
    lines = [
        "## Findings: v1, v2 and v3 verdicts in every cell",
        "",
        "Each cell's page (linked below) shows the numbers behind every verdict. "
        + (f"The BEM cells were not run: {data.skipped}." if data.skipped else ""),
        "",
        *_markdown_table(header, rows),
        "",
    ]
    return lines


def _flags(result, version):
    findings = findings_of(result, version)
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
_CRITERIA["v3"] = {
    **_CRITERIA["v2"],
    4: tuple(
        f"{bound} bound present {level}" for level in _LEVELS for bound in ("lower", "upper")
    ),
    6: tuple(
        name
        for level in _LEVELS
        for name in (
            f"(a) smoothing lowers the lower bound {level}",
            f"(a) smoothing lowers the upper bound {level}",
            f"(b) clear separation {level}",
        )
    ),
}


def _criterion_name(finding, index, version):
    name = _CRITERIA[version][finding.number][index]
    if version == "v3" and finding.number in CHANGED:  # named by clause and bound
        return f"F{finding.number}, {name}"
    return f"F{finding.number} ({chr(97 + index)}), {name}"


def _numbers(version):
    """The findings a rule set's factor lines cover: v3 only where it differs from v2."""
    return CHANGED if version == "v3" else range(1, 7)


def in_short(data, version):
    """One sentence: which factor moves which finding's verdict."""
    names = [cell.name for cell in CELLS]
    groups = {}
    for index in (number - 1 for number in _numbers(version)):
        verdicts = {name: _flags(data.results[name], version)[1][index] for name in names}
        groups.setdefault(_factor(verdicts) or "nothing (the same in every cell)", []).append(
            f"F{index + 1}"
        )
    parts = [f"{', '.join(found)}: {factor}" for factor, found in groups.items()]
    rest = " (F1-F3 and F5 as by v2)" if version == "v3" else ""
    return f"In short, by {version}{rest}, what moves each verdict: " + "; ".join(parts) + "."


def factor_lines(data, version):
    """Per finding (and criterion) of one rule set, which factor moves it (list items)."""
    names = [cell.name for cell in CELLS]
    flags = {name: _flags(data.results[name], version) for name in names}
    lines = []
    for index in (number - 1 for number in _numbers(version)):
        verdicts = {name: flags[name][1][index] for name in names}
        factor = _factor(verdicts)
        listing = ", ".join(f"{c.title}: {verdicts[c.name]}" for c in CELLS)
        if factor is None:
            lines.append(f"- F{index + 1}: {verdicts[names[0]]} in every cell.")
        else:
            lines.append(f"- F{index + 1} moves with {factor} ({listing}).")
        finding = findings_of(data.results[names[0]], version)[index]
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


def ties_text(data):
    """The discussion's paragraph on F1 (b) and F2 (b) by v1 and by v2's margins."""
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
    findings = findings_of(data.results[cell.name], version)
    return bool(findings[index].criteria[criterion][1])


def f3_text(data):
    """The discussion's paragraph on the measures whose best cell at 30 dB fits F3."""
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


def _f6_level(flags):
    """What decided one noise level of v3's F6, from its three criteria."""
    lower, upper, clear = flags
    if not clear:
        return "fails: separated in fewer than half of the seeds"
    if lower and upper:
        return "holds"
    if not (lower or upper):
        return "fails: neither bound lowered by smoothing"
    which = "lower (deep excess)" if lower else "upper (deep-only echo)"
    return f"undetermined: only the {which} bound lowered by smoothing"


def f6_text(data):
    """What decided each noise level of v3's F6 in each cell."""
    parts = []
    for cell in CELLS:
        if cell.name not in data.results:
            continue
        finding = data.results[cell.name].findings_v3[5]
        flags = [ok for _, ok in finding.criteria]
        levels = ", ".join(
            f"{snr:g} dB {_f6_level(flags[3 * i : 3 * i + 3])}"
            for i, snr in enumerate(NOISE_LEVELS)
        )
        parts.append(f"{cell.title} ({finding.verdict}): {levels}")
    return (
        "**F6 by v3.** What decided each noise level (smoothing's suppression read on both "
        "bounds, separation on the deep source's own level): " + "; ".join(parts) + "."
    )
