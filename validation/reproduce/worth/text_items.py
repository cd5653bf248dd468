"""The report's sections for items 1-7 of the study of the SKF's worth (v2)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from .design import DESIGNS, SNRS, STATIC_METHODS, Static
from .tables import NOISE_FREE, cell, lookup, markdown_table, snr_name

__all__ = [
    "contrasts_section",
    "designs_section",
    "detection_section",
    "resolution_section",
    "sparse_section",
    "temporal_section",
    "tuning_section",
]


def _methods(worth):
    """The named SKF settings, then MNE's minimum-norm methods, then LCMV."""
    named = [(name, key) for name, key in worth.named.items()]
    named.sort(key=lambda item: item[0])
    keys = list(dict.fromkeys(key for _, key in named))
    keys += [Static(m, rule).key for m in STATIC_METHODS for rule in ("1/9", "matched")]
    return [*keys, "LCMV"]


def _name(worth, key):
    names = [name for name, k in worth.named.items() if k == key]
    setting = worth.settings.get(key)
    if getattr(setting, "window", None) is not None:
        return f"{setting.method} (λ² {setting.lambda2}) in {_window_name(worth, setting.window)}"
    label = worth.label(key)
    return f"{', '.join(sorted(names))}: {label}" if names else label


def _window_name(worth, window):
    """E.g. "the window of N1, N4 (EP 0 / PM 0, filter)"."""
    names = sorted(
        name for name, key in worth.named.items()
        if worth.settings[key].priors == window.priors
        and worth.settings[key].smooths == window.smooths
    )  # fmt: skip
    kind = "RTS smoother" if window.smooths else "filter"
    return (
        f"the window of {', '.join(names)} (EP {window.ep_snr_db:g} / PM "
        f"{window.pm_snr_db:g}, {kind})"
    )


def resolution_section(worth):
    """Item 1: lone sources over the source space, and the cross-talk into the thalamus."""
    parts = []
    for kind in ("thalamic", "cortical"):
        header = ["method", *(snr_name(s) for s in (NOISE_FREE, *SNRS))]
        rows = []
        for key in _methods(worth):
            cells = []
            for snr in (NOISE_FREE, *SNRS):
                error = cell(worth, key, f"lone_{kind}_error", snr, "median")
                own = cell(worth, key, f"lone_{kind}_own", snr, "rate-only")
                spread = cell(worth, key, f"lone_{kind}_dispersion", snr, "median-only")
                cells.append("n/a" if error == "n/a" else f"{error}; {own}; SD {spread}")
            rows.append([_name(worth, key), *cells])
        parts += [
            f"**Lone {kind} sources**: peak error, mm, median [Q1, Q3]; share of maxima in the "
            f"source's own structure; spatial dispersion SD, mm, median.",
            "",
            markdown_table(header, rows),
            "",
        ]
    rows = [
        [
            _name(worth, key),
            cell(worth, key, "cross_talk_db", NOISE_FREE, "median"),
            cell(worth, key, "cross_talk_within_6db", NOISE_FREE, "rate"),
        ]
        for key in _methods(worth)
        if lookup(worth, key, "cross_talk_db", NOISE_FREE)[3]
    ]
    parts += [
        "**Cortex-to-thalamus cross-talk** (each scored cortical source alone, noise-free): the "
        "thalamus' maximum re. the map's maximum, dB, median [Q1, Q3]; and the share of "
        "cortical sources that put the thalamus within 6 dB of the map's maximum, [95 % CI]. "
        "The map: `worth/cross_talk.png`.",
        "",
        markdown_table(["method", "cross-talk, dB", "thalamus within 6 dB"], rows),
    ]
    return "\n".join(parts)


def detection_section(worth):
    """Item 2: calibrated thresholds, false and true detections, ROC areas."""
    parts = []
    for snr in SNRS:
        rows = []
        for key in [*_methods(worth), "irMxNE"]:
            if not lookup(worth, key, "true_1", snr)[3]:
                continue
            rows.append(
                [
                    _name(worth, key),
                    cell(worth, key, "false_noise", snr, "rate"),
                    cell(worth, key, "false_cortical", snr, "rate"),
                    *(cell(worth, key, f"true_{m}", snr, "rate") for m in ("1", "0.5", "0.25")),
                    cell(worth, key, "auc_level", snr, "auc"),
                    cell(worth, key, "auc_ratio_db", snr, "auc"),
                ]
            )
        header = ["method", "false, noise only", "false, cortical", "true, 1x", "true, 0.5x",
                  "true, 0.25x", "AUC, absolute level", "AUC, instantaneous ratio"]  # fmt: skip
        parts += [f"**{snr:g} dB**", "", markdown_table(header, rows), ""]
    return "\n".join(parts)


def designs_section(worth):
    """Item 3: the named settings and MNE's methods in the four timing designs (scored)."""
    keys = [k for k in _methods(worth) if k != "LCMV"]
    parts = []
    for snr in SNRS:
        header = ["method", *(d.title for d in DESIGNS if d.name in worth.sizes.designs)]
        rows = []
        for key in keys:
            cells = []
            for design in DESIGNS:
                if design.name not in worth.sizes.designs:
                    continue
                true = cell(worth, key, "true_1", snr, "rate-only", design.name)
                deep = cell(worth, key, "deep_error", snr, "median-only", design.name)
                sup = cell(worth, key, "superficial_error", snr, "median-only", design.name)
                r = cell(worth, key, "deep_r", snr, "r", design.name)
                cells.append(f"{true}; {deep} / {sup} mm; r {r}")
            rows.append([_name(worth, key), *cells])
        parts += [f"**{snr:g} dB**", "", markdown_table(header, rows), ""]
    return "\n".join(parts)


def tuning_section(worth):
    """Item 4: priors and lambda2 chosen from each data set."""
    tuned = worth.tuned
    rows = []
    for (method, criterion, snr), group in tuned.groupby(["method", "criterion", "snr_db"]):
        key = worth.named.get(method.split(", ")[0])
        name = f"{method}: {worth.label(key)}" if key else method
        if np.isnan(group["lambda2"]).all():
            chosen = (
                f"EP {group['ep_snr_db'].median():.1f}, PM {group['pm_snr_db'].median():.1f} dB"
            )
        else:
            chosen = f"λ² {group['lambda2'].median():.3g}"
        bounds = int((group["bound"].fillna("") != "").sum())
        rows.append(
            [name, criterion, f"{snr:g}", chosen, f"{bounds} / {len(group)}",
             _median(group["deep_error_mm"]), _median(group["superficial_error_mm"]),
             f"{group['deep_r'].median():.2f}"]
        )  # fmt: skip
    header = ["method", "criterion", "SNR, dB", "chosen (median)", "on a bound",
              "deep error, mm", "superficial error, mm", "deep r"]  # fmt: skip
    return markdown_table(header, rows)


def _median(values):
    values = pd.Series(values, dtype=float).dropna()
    if values.empty:
        return "n/a"
    q1, median, q3 = np.percentile(values, [25, 50, 75])
    return f"{median:.0f} [{q1:.0f}, {q3:.0f}]"


def sparse_section(worth):
    """Item 5: irMxNE's alpha by the discrepancy principle, and its numbers."""
    rows = []
    for snr in SNRS:
        rows.append(
            [
                f"{snr:g}",
                f"{worth.irmxne_alpha[snr]:g} %",
                cell(worth, "irMxNE", "true_1", snr, "rate"),
                cell(worth, "irMxNE", "false_cortical", snr, "rate"),
                cell(worth, "irMxNE", "deep_error", snr, "median"),
                cell(worth, "irMxNE", "superficial_error", snr, "median"),
            ]
        )
    header = ["SNR, dB", "alpha (% of alpha_max)", "thalamic activity, thalamic source present",
              "thalamic activity, cortical source alone", "deep error, mm",
              "superficial error, mm"]  # fmt: skip
    return markdown_table(header, rows)


def temporal_section(worth):
    """Item 6: each SKF setting beside the static methods on data in its window."""
    rows = []
    for name in ("N1", "N2", "N4"):
        key = worth.named[name]
        window = next(
            s for s in worth.window_settings if s.priors == worth.settings[key].priors
            and s.smooths == worth.settings[key].smooths
        )  # fmt: skip
        controls = [Static(m, rule, window).key for m in ("sLORETA", "eLORETA")
                    for rule in ("1/9", "matched")]  # fmt: skip
        for k in [key, *controls]:
            rows.append(
                [
                    f"{name}: {worth.label(k)}" if k == key else _name(worth, k),
                    *(
                        f"{cell(worth, k, 'true_1', snr, 'rate-only')}; "
                        f"{cell(worth, k, 'deep_error', snr, 'median-only')} / "
                        f"{cell(worth, k, 'superficial_error', snr, 'median-only')} mm; "
                        f"r {cell(worth, k, 'deep_r', snr, 'r')}"
                        for snr in SNRS
                    ),
                ]
            )
    header = ["method", *(f"{s:g} dB: true detection; deep / superficial error; r"
                          for s in SNRS)]  # fmt: skip
    return markdown_table(header, rows)


def contrasts_section(worth):
    """Item 7: the named contrasts, paired by position, Holm-adjusted."""
    rows = []
    formats = {"detection at 1x": lambda v: f"{100 * v:.0f} %",
               "deep time-course r": lambda v: f"{v:.2f}"}  # fmt: skip
    for row in worth.contrasts.itertuples():
        fmt = formats.get(row.metric, lambda v: f"{v:.1f}")
        names = f"{_name(worth, row.a)} vs {_name(worth, row.b)}"
        rows.append(
            [
                row.contrast + (f" (also {row.also})" if row.also else "") + f": {names}",
                row.metric,
                f"{row.snr_db:g}",
                fmt(row.first),
                fmt(row.second),
                f"{fmt(row.difference)} [{fmt(row.low)}, {fmt(row.high)}]",
                f"{row.units}",
                f"{row.p:.2g}",
                f"{row.p_holm:.2g}" + (" *" if row.p_holm < 0.05 else ""),
            ]
        )
    header = ["contrast", "metric", "SNR, dB", "first", "second",
              "paired difference, median over positions [95 % CI]", "positions", "p",
              "p, Holm"]  # fmt: skip
    return markdown_table(header, rows)


def named_list(worth):
    """The named settings as a Markdown list."""
    lines = []
    for name in sorted(worth.named):
        lines.append(f"- **{name}**: {worth.label(worth.named[name])}")
    return "\n".join(lines)
