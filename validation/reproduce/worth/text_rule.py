"""The report's verdict on the default (item 8) and its headline table (item 7).

The rule and the success criteria are printed verbatim from the pre-registration
(``validation/report/PREREGISTRATION.md``, between its markers).
"""

from __future__ import annotations

import inspect
from pathlib import Path

from skf_ref import make_skf_operator

from .design import SNRS, Static
from .rule import MARGIN_MM, criteria, inputs
from .tables import cell, lookup, markdown_table, percent, snr_name

__all__ = ["PACKAGE_PRIORS", "PREREGISTRATION", "criteria_text", "headline_rows", "headline_table",
           "preregistered", "rule_text"]  # fmt: skip

#: The pre-registration (committed before the numbers).
PREREGISTRATION = Path(__file__).resolve().parents[2] / "report" / "PREREGISTRATION.md"


def preregistered(name):
    """The pre-registration's text between ``<!-- name: begin -->`` and its end marker."""
    text = PREREGISTRATION.read_text()
    begin, end = f"<!-- {name}: begin -->", f"<!-- {name}: end -->"
    block = text.split(begin, 1)[1].split(end, 1)[0].strip().splitlines()
    return "\n".join(line for line in block if not line.startswith("#")).strip()


def _scored_inputs(worth, key):
    s = worth.summaries
    part = s[(s["method"] == key) & (s["design"] == "D1") & (s["set"] == "scored")]
    return inputs(part)


def headline_rows(worth):
    """(label, key) of the headline's methods, in order, without repeats."""
    named = worth.named
    rows = [
        ("the default (N1)", named["N1"]),
        ("the paper's setting (N2)", named["N2"]),
        ("the paper's unsmoothed priors (N4)", named["N4"]),
        ("eLORETA (λ² 1/9)", Static("eLORETA", "1/9").key),
        ("sLORETA (λ² 1/9)", Static("sLORETA", "1/9").key),
        ("the best minimum-norm method", worth.best["minimum norm"]),
        ("LCMV", "LCMV"),
        ("irMxNE", "irMxNE"),
    ]
    seen, out = set(), []
    for label, key in rows:
        if key not in seen:
            seen.add(key)
            out.append((label, key))
    return out


def headline_table(worth, snr):
    """The headline at one SNR (D1, scored set)."""
    header = [
        "method",
        "lone thalamic error, mm",
        "lone thalamic maxima in the thalamus",
        "true / false detection",
        "deep error, mm",
        "superficial error, mm",
        "deep time-course r",
    ]
    rows = []
    for label, key in headline_rows(worth):
        name = label
        if key in worth.settings and worth.label(key) != label:
            name = f"{label}: {worth.label(key)}"
        true = cell(worth, key, "true_1", snr, "rate-only")
        false = cell(worth, key, "false_cortical", snr, "rate-only")
        rows.append(
            [
                name,
                cell(worth, key, "lone_thalamic_error", snr, "median"),
                cell(worth, key, "lone_thalamic_own", snr, "rate-only"),
                f"{true} / {false}",
                cell(worth, key, "deep_error", snr, "median"),
                cell(worth, key, "superficial_error", snr, "median"),
                cell(worth, key, "deep_r", snr, "r"),
            ]
        )
    return markdown_table(header, rows)


def _package_priors() -> tuple[float, float]:
    """The default priors (EP-SNR, PM-SNR) in dB of ``make_skf_operator`` (``apply_skf`` and
    the command line take the same), read from the package itself: an EP-SNR not given
    (None) is the random walk's ``DEFAULT_EP_SNR_DB``."""
    from skf_ref.method._priors import DEFAULT_EP_SNR_DB

    defaults = inspect.signature(make_skf_operator).parameters
    ep = defaults["ep_snr_db"].default
    return float(DEFAULT_EP_SNR_DB if ep is None else ep), float(defaults["pm_snr_db"].default)


#: The package's default priors (EP-SNR, PM-SNR) in dB, of ``apply_skf`` and the commands.
PACKAGE_PRIORS = _package_priors()


def rule_text(worth):
    """The rule (verbatim), its choice, and the candidates nearest it."""
    setting, met_all, table = worth.rule
    verdict = (
        "It meets R1, R2 and R3 on the choice set."
        if met_all
        else "**No candidate met R1, R2 and R3 on the choice set**: the fallback clause chose "
        f"it (it meets {int(table.loc[table['setting'] == setting, 'met'].iloc[0])} of the three)."
    )
    if setting.priors != PACKAGE_PRIORS:
        verdict += (
            f" Its priors (EP {setting.ep_snr_db:g} / PM {setting.pm_snr_db:g} dB) are not the "
            f"package's default priors (EP {PACKAGE_PRIORS[0]:g} / PM {PACKAGE_PRIORS[1]:g} dB): "
            "the defaults of `apply_skf`, `make_skf_operator` and the command line must follow "
            "(section 10)."
        )
    ranked = table.sort_values(["met", "mean_error_mm"], ascending=[False, True]).head(8)
    rows = [
        [
            row.setting.label, f"{row.mean_error_mm:.1f}", f"{row.mean_true:.2f}",
            *("met" if flag else "not met" for flag in (row.r1, row.r2, row.r3)),
        ]
        for row in ranked.itertuples()
    ]  # fmt: skip
    return "\n".join(
        [
            preregistered("rule"),
            "",
            f"**The rule chose: {setting.label}.** {verdict} Of the {len(table)} candidates "
            f"({int((table['met'] == 3).sum())} meet all three), the eight with the most criteria "
            "met and the lowest mean localization error (all: `worth/rule.csv`):",
            "",
            markdown_table(
                [
                    "candidate",
                    "mean localization error, mm",
                    "mean true detection (1x)",
                    "R1",
                    "R2",
                    "R3",
                ],
                rows,
            ),  # fmt: skip
        ]
    )


def criteria_text(worth):
    """The success criteria (verbatim) and the default judged by them on the scored set."""
    default = worth.named["N1"]
    judged = criteria(
        _scored_inputs(worth, default), _scored_inputs(worth, Static("eLORETA", "1/9").key)
    )
    false = lookup(worth, default, "false_cortical", 20.0)[0]
    lines = [
        preregistered("criteria"),
        "",
        f"**S1 {'met' if judged.r1 else 'NOT MET'}**: median lone thalamic error at 30 dB "
        f"{judged.thalamic_error:.1f} mm (at most 10), maxima in the thalamus "
        f"{percent(judged.in_thalamus)} (at least 80 %).",
        f"**S2 {'met' if judged.r2 else 'NOT MET'}**: true detection at 1x, 20 dB, "
        f"{percent(judged.true_detection)} (at least 80 %), with false detections of cortical "
        f"nulls {percent(false)} at that threshold.",
    ]
    if judged.r3:
        lines.append(
            f"**S3 met**: no error median exceeds eLORETA's by more than {MARGIN_MM:g} mm."
        )
    else:
        worse = "; ".join(
            f"{name.replace('_', ' ')} at {snr_name(snr)}: {mine:.1f} mm against {theirs:.1f}"
            for (name, snr), mine, theirs in judged.worse
        )
        lines.append(f"**S3 NOT MET**: worse than eLORETA's by more than 5 mm: {worse}.")
    lines += ["", _withdrawn(judged)]
    return "\n".join(lines)


def _withdrawn(judged):
    """The plain statement of what is withdrawn where a criterion fails."""
    if all(judged.met):
        return (
            "The default meets every success criterion; its deep-source numbers stand as "
            "reported, each with its interval."
        )
    parts = []
    if not judged.r1:
        parts.append(
            "it does not localize a lone thalamic source to within 10 mm at 30 dB, so no "
            "claim is made that it localizes thalamic sources at 30 dB or below"
        )
    if not judged.r2:
        parts.append(
            "it does not detect a thalamic source beside a cortical one at the calibrated "
            "threshold at 20 dB, so no claim is made that it detects thalamic sources at "
            "20 dB or below"
        )
    if not judged.r3:
        levels = sorted({snr for (_, snr), _, _ in judged.worse})
        parts.append(
            "it localizes worse than eLORETA by more than 5 mm ("
            + ", ".join(snr_name(s) for s in levels)
            + "), so no claim is made that it localizes as well as eLORETA there"
        )
    return "**The default fails its success criteria**: " + "; ".join(parts) + "."


def headline_section(worth):
    """The headline tables at 10, 20 and 30 dB."""
    parts = [
        "Scored set, design D1 (the paper's timing). *Lone thalamic*: each thalamic source "
        "alone at its own peak SNR, median [Q1, Q3] of the peak error and the share of maxima "
        "in the thalamus. *True / false detection*: a thalamic source of the cortical one's "
        "moment beside it, and the cortical source alone, at the threshold calibrated to 5 % "
        "on the choice set's nulls (irMxNE: any thalamic activity). *Deep / superficial "
        "error* and *deep time-course r*: both sources present. Intervals: section 2 and "
        "`worth/summary.csv`.",
        "",
    ]
    for snr in SNRS:
        parts += [f"**{snr:g} dB**", "", headline_table(worth, snr), ""]
    return "\n".join(parts)


def default_is_named(worth):
    """Which named settings the default equals (for the text)."""
    return [name for name, key in worth.named.items() if key == worth.named["N1"] and name != "N1"]
