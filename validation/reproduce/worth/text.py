"""The report's part on the SKF's worth (v2): its sections, figures and headline files.

:func:`worth_text` returns the Markdown inserted at the top of REPORT.md;
:func:`write_headline` writes ``headline.json`` (every number the README and the
documentation may quote) and ``headline.md`` (the table they print).
"""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

from skf_ref._utils.atomic_files import atomic_path

from .design import SNRS, Static
from .figures import cross_talk_figure, windows_figure
from .text_items import (
    contrasts_section,
    designs_section,
    detection_section,
    named_list,
    resolution_section,
    sparse_section,
    temporal_section,
    tuning_section,
)
from .text_rule import PREREGISTRATION, criteria_text, headline_section, headline_table, rule_text

__all__ = ["HEADLINE_SNRS", "preregistration_commit", "worth_text", "write_headline"]

#: The SNRs of the README's and the documentation's headline tables.
HEADLINE_SNRS = (20.0, 30.0)


def preregistration_commit():
    """The commit that added the pre-registration (its first), or None outside git."""
    try:
        out = subprocess.run(
            ["git", "log", "--diff-filter=A", "--format=%h %cs", "--",
             PREREGISTRATION.name],
            cwd=PREREGISTRATION.parent, capture_output=True, text=True, check=True,
        )  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return None
    lines = out.stdout.strip().splitlines()
    return lines[-1] if lines else None


def _intro(worth):
    study, sizes = worth.study, worth.sizes
    sets = study.sets
    commit = preregistration_commit()
    when = f" (commit {commit})" if commit else ""
    return "\n".join(
        [
            f"Everything in this part follows [the pre-registration](PREREGISTRATION.md), "
            f"committed before any of its numbers{when}. The realistic head, cortex + "
            f"thalamus, white noise. Choice set: {len(sets['choice'].thalamic)} thalamic "
            f"sources ({len(sets['choice'].thalamic) // 3} positions x 3 random orthonormal "
            f"orientations) and {len(sets['choice'].cortical)} cortical; scored set: "
            f"{len(sets['scored'].thalamic)} thalamic and {len(sets['scored'].cortical)} "
            f"cortical, at other positions. Every source lies off the grid (no inverse crime). "
            f"Noise pools of {sizes.pool} draws per set and design. The configurations' noise "
            f"level is the median cortical source's peak at the SNR "
            f"(A_ref = {study.a_ref * 1e6:.3g} µV). Files: `worth/`.",
            "",
            "The settings named throughout:",
            "",
            named_list(worth),
        ]
    )


def worth_text(worth, out):
    """The Markdown of the worth study's sections (figures written into ``out/worth``)."""
    folder = Path(out) / "worth"
    keys = [worth.named["N1"], Static("eLORETA", "1/9").key, worth.named["N2"]]
    keys = list(dict.fromkeys(keys))
    cross_talk_figure(worth, keys, folder / "cross_talk.png")
    windows_figure(worth, folder / "windows.png")
    alphas = ", ".join(f"{a:g} % at {s:g} dB" for s, a in worth.irmxne_alpha.items())
    sections = [
        ("## Which setting, and against what", "What the SKF is worth, v2. " + _intro(worth)),
        ("### The default, by a rule committed first (item 8)", rule_text(worth)),
        ("### Did the default meet its success criteria? (item 8)", criteria_text(worth)),
        ("### Headline (item 7)", headline_section(worth)),
        ("### 1. Resolution over the whole source space", resolution_section(worth)
         + "\n\n![cross-talk map](worth/cross_talk.png)"),
        ("### 2. Calibrated detection", detection_section(worth)),
        ("### 3. Configurations: four timing designs (scored set)", "Each cell: true "
         "detection at 1x; deep / superficial error (median); deep time-course r.\n\n"
         + designs_section(worth)),
        ("### 4. Equal tuning: regularization chosen from each data set", "Scored "
         "configurations, design D1; medians [Q1, Q3] over the runs. The matched comparison "
         "(SKF at PM 0 dB against MNE's methods at the matched λ²) is in every other table "
         "(rows 'λ² matched').\n\n" + tuning_section(worth)),
        ("### 5. Sparse baselines", f"irMxNE's alpha by the discrepancy principle on the "
         f"choice set: {alphas}. gamma-MAP did not run (about a minute per run on this "
         "head). The previous report's MxNE row (alpha 50 %) had a deep AUC of 0.50 because "
         "it put nothing in the thalamus in any run, with or without a thalamic source: "
         "every score tied, which is not chance but silence.\n\n" + sparse_section(worth)),
        ("### 6. The temporal model isolated", "Each SKF setting beside sLORETA and eLORETA "
         "on the data filtered by that setting's own effective window (thresholds calibrated "
         "on filtered nulls). The windows at the thalamic peak:\n\n"
         "![windows](worth/windows.png)\n\n" + temporal_section(worth)),
        ("### 7. The named contrasts (paired, Holm-corrected)", "* Holm-adjusted p < 0.05. "
         "First and second: medians (rates for detection) over the runs.\n\n"
         + contrasts_section(worth)),
    ]  # fmt: skip
    return "\n\n".join(f"{title}\n\n{body}" for title, body in sections) + "\n"


def _numbers(text):
    return set(re.findall(r"\d+(?:\.\d+)?", text))


def _paragraph(report, heading):
    """The first paragraph after a heading of the report ('' when it is missing)."""
    if f"\n{heading}\n" not in report:
        return ""
    rest = report.split(f"\n{heading}\n", 1)[1].strip()
    return rest.split("\n\n", 1)[0]


def write_headline(worth, out, report, elapsed):
    """``headline.md`` (the tables at 20 and 30 dB) and ``headline.json`` (quotable numbers).

    Quotable: the headline tables, the default's rule and verdict, the paragraph of the
    report's section on the priors chosen by the data, and the run's wall time in minutes.
    """
    tables = {f"{snr:g} dB": headline_table(worth, snr) for snr in HEADLINE_SNRS}
    markdown = "\n\n".join(f"**{name}**\n\n{table}" for name, table in tables.items()) + "\n"
    minutes = f"{elapsed / 60:.0f}"
    texts = (markdown, criteria_text(worth), rule_text(worth),
             _paragraph(report, "## Priors chosen by the data"))  # fmt: skip
    quotable = set().union(*map(_numbers, texts)) | {minutes}
    record = dict(
        default=worth.label(worth.named["N1"]),
        met_all_on_choice=worth.rule[1],
        tables=tables,
        snrs=list(SNRS),
        minutes=minutes,
        quotable=sorted(quotable, key=lambda x: (float(x), x)),
    )
    with atomic_path(Path(out) / "headline.md") as tmp:
        tmp.write_text(markdown)
    with atomic_path(Path(out) / "headline.json") as tmp:
        tmp.write_text(json.dumps(record, indent=1, sort_keys=True, ensure_ascii=False) + "\n")
