"""The report's text and figures of the specificity study (:mod:`.specificity`'s numbers).

The section "Which setting, and against what" (the rule, its inputs and the recommended
setting beside the paper's and the best MNE baseline), the full tables of every condition
and noise level, the run times, the ROC curves and every seed's deep score as points.
"""

from __future__ import annotations

import numpy as np

from skf_ref._utils.atomic_files import atomic_path
from skf_ref.study.regions import DYNAMIC_RANGE_DB

from .baselines import BASELINES, LCMV_REG, MXNE_ALPHA, choice_seeds, conditions
from .recommend import RULE_TEXT
from .settings import NOISE_LEVELS, SMOOTHED
from .specificity import setting_label

__all__ = ["TIMINGS_TITLE", "specificity_text", "summary_table", "timings_text", "write_figures"]

#: The paper's setting, as labelled in the results.
PAPER_LABEL = f"{SMOOTHED[0]:g}/{SMOOTHED[1]}"
#: The methods the figures show (method, setting); the recommended SKF setting is added.
SHOWN = (
    ("SKF", PAPER_LABEL),
    ("sLORETA", "lambda2=1/9"),
    ("eLORETA", "lambda2=1/9"),
    ("dSPM", "lambda2=1/9"),
    ("MNE", "lambda2=1/9"),
    ("LCMV", f"reg={LCMV_REG:g}"),
    ("MxNE", f"alpha={MXNE_ALPHA:g}%"),
)


# --------------------------------------------------------------------------- text


def _label(method, setting):
    if method == "SKF":
        exponent, smoother, *priors = setting.split("/")
        label = f"SKF {exponent}, {'no smoother' if smoother == 'none' else smoother}"
        if priors:  # "EP0-PM0" -> "EP 0 / PM 0"
            ep, pm = priors[0].split("-")
            label += f", EP {ep[2:]} / PM {pm[2:]}"
        return label
    return f"{method} ({setting.replace('lambda2', 'λ²')})"


def _auc_cell(row, source, score=None):
    prefix = source if score is None else f"{source}_{score}"
    area = row[f"{prefix}_auc"]
    low, high = row[f"{prefix}_low"], row[f"{prefix}_high"]
    return f"{area:.2f} [{low:.2f}, {high:.2f}]"


def _err_cell(row, source):
    median, q1, q3 = (row[f"{source}_{k}"] for k in ("err", "q1", "q3"))
    if not np.isfinite(median):
        return "no estimate"
    missing = row[f"{source}_no_estimate"]
    text = f"{median:.0f} [{q1:.0f}, {q3:.0f}]"
    return text + (f" ({missing} empty)" if missing else "")


def _rate_cell(row, source):
    cells = []
    for name in ("tpr", "fpr"):
        rate, low, high = (row[f"{source}_{name}{k}"] for k in ("", "_low", "_high"))
        cells.append(f"{rate:.0%} [{low:.0%}, {high:.0%}]")
    return " / ".join(cells)


_HEADER = (
    "| method | deep AUC, instantaneous ratio | deep AUC, absolute level | deep AUC, epoch "
    "maximum | deep TPR / FPR at -6 dB | superficial AUC | superficial TPR / FPR at -6 dB | "
    "deep error, mm | superficial error, mm |\n"
    "|---|---|---|---|---|---|---|---|---|"
)


def _table(rows, recommended):
    lines = [_HEADER]
    for _, row in rows.iterrows():
        label = _label(row["method"], row["setting"])
        if row["method"] == "SKF" and row["setting"] == PAPER_LABEL:
            label += " (paper)"
        if row["method"] == "SKF" and row["setting"] == recommended:
            label = f"{label} (v1's choice)"
        cells = [
            label,
            _auc_cell(row, "deep"),
            _auc_cell(row, "deep", "level"),
            _auc_cell(row, "deep", "epoch_db"),
            _rate_cell(row, "deep"),
            _auc_cell(row, "superficial"),
            _rate_cell(row, "superficial"),
            _err_cell(row, "deep"),
            _err_cell(row, "superficial"),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _best_baseline(table, condition):
    """The MNE method with the highest mean deep AUC at 20 and 30 dB, then the smaller
    mean error (a description of the scored seeds, not a choice made on them)."""
    rows = table[(table["condition"] == condition) & (table["method"] != "SKF")]
    rows = rows[rows["snr_db"].isin((20.0, 30.0))]
    per = rows.groupby(["method", "setting"]).agg(
        deep=("deep_auc", "mean"), err=("deep_err", "mean"), sup=("superficial_err", "mean")
    )
    per["error"] = per["err"] + per["sup"]
    return per.sort_values(["deep", "error"], ascending=[False, True]).index[0]


def summary_rows(table, condition, recommended):
    """(label, method, setting) of the paper's, the recommended and the best MNE setting."""
    best = _best_baseline(table, condition)
    return [
        ("the paper's setting", "SKF", PAPER_LABEL),
        ("recommended", "SKF", recommended),
        ("best MNE baseline", *best),
    ]


def summary_table(table, condition, recommended):
    """Markdown: deep AUC and deep + superficial median error at each noise level."""
    head = "| setting | " + " | ".join(
        f"deep AUC, {snr:g} dB | errors (deep / superficial), {snr:g} dB" for snr in NOISE_LEVELS
    )
    lines = [head + " |", "|---" * (1 + 2 * len(NOISE_LEVELS)) + "|"]
    for name, method, setting in summary_rows(table, condition, recommended):
        cells = [f"{name}: {_label(method, setting)}"]
        for snr in NOISE_LEVELS:
            row = table[
                (table["condition"] == condition)
                & (table["snr_db"] == snr)
                & (table["method"] == method)
                & (table["setting"] == setting)
            ].iloc[0]
            cells += [
                f"{row['deep_auc']:.2f}",
                f"{row['deep_err']:.0f} / {row['superficial_err']:.0f} mm",
            ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _candidates_table(candidates):
    lines = [
        "| SKF setting | "
        + " | ".join(f"deep / sup. AUC, {s:g} dB" for s in NOISE_LEVELS)
        + " | mean error (deep + sup.), mm |",
        "|---" * (2 + len(NOISE_LEVELS)) + "|",
    ]
    for (exponent, smoother), group in candidates.groupby(["exponent", "smoother"]):
        group = group.set_index("snr_db")
        aucs = [
            f"{group.loc[s, 'deep_auc']:.2f} / {group.loc[s, 'superficial_auc']:.2f}"
            for s in NOISE_LEVELS
        ]
        label = _label("SKF", f"{exponent:g}/{smoother}")
        lines.append(f"| {label} | " + " | ".join(aucs) + f" | {group['error_mm'].mean():.1f} |")
    return "\n".join(lines)


def specificity_text(table, choice, settings, figures):
    """The report's section "Which setting, and against what" and the full tables.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`scores` of the scored seeds.
    choice : tuple
        :func:`recommendation`'s result.
    settings : Settings
    figures : dict
        Figure name -> path relative to the report folder.

    Returns
    -------
    headline, details : str
        Markdown: the section "Which setting, and against what", and the full tables.
    """
    setting, admissible, candidates = choice
    recommended = setting_label(setting)
    main = next(c for c in conditions(settings) if c.wide and c.noise == "white")
    n_main = int(table.loc[table["condition"] == main.name, "n_seeds"].max())
    verdict = (
        "It meets the bar (deep and superficial AUC at least 0.9 at 20 and 30 dB)."
        if admissible
        else "**No setting met the bar** (clause 4 chose it)."
    )
    parts = [
        "## The first study of the SKF's worth (v1): one configuration",
        "",
        "The previous report's study, kept for continuity: one pair of sources (the paper's), "
        "seeds differing only in noise, every SKF setting at EP 20 / PM 0 dB. Its rule's "
        "choice is superseded by the rule above, which reads many configurations; its tables "
        "(the last section) gain the absolute and epoch-normalized scores.",
        "",
        RULE_TEXT,
        "",
        f"**Its choice: {_label('SKF', recommended)}** (EP 20 / PM 0 dB). {verdict}",
        "",
        f"The rule's inputs ({len(choice_seeds(settings))} choice seeds, {main.title}):",
        "",
        _candidates_table(candidates),
        "",
        f"Scored on the other seeds ({n_main} seeds, {main.title}): the paper's setting, the "
        "recommended one and the best of MNE's methods (by mean deep AUC at 20-30 dB, then "
        "error: a description, not a choice).",
        "",
        summary_table(table, main.name, recommended),
        "",
    ]
    for name, path in figures.items():
        parts += [f"![{name}]({path})", ""]
    headline, parts = (
        "\n".join(parts),
        [
            "## Baselines and specificity, every condition",
            "",
            "The first study's tables (one configuration, the paper's; section \"The first "
            "study of the SKF's worth\"), kept for continuity. Every method on identical "
            "simulations (same head, pulses, noise draws and seeds). Deep AUC: deep source "
            "present (both sources) vs absent (superficial source only), three scores: the deep "
            "region's maximum at 1.5 ms re. the map's maximum then (the *instantaneous ratio*, "
            "the first study's score), that maximum's *absolute level*, and that level re. the "
            "*epoch maximum* (every position and sample); superficial AUC: both vs deep only, "
            "instantaneous ratio. AUC intervals: Newcombe's method 5 (95 %), which stays "
            "informative at 1.00; rates: Clopper-Pearson 95 % intervals. TPR / FPR: 'within "
            "6 dB of the maximum' with the source present / absent, which is not a calibrated "
            "detection (section 2 above is). MxNE's deep AUC of 0.50 means it put nothing in "
            "the deep region in any run, present or absent: every score tied. Errors: median "
            "[Q1, Q3] over seeds, both sources present (empty: MxNE put no source at the peak "
            "time). Run times: the last section. "
            "MNE's methods: free orientation, no "
            "depth weighting, the average reference, the data's own noise covariance; "
            f"λ²=SNR is 10^(-SNR/10), λ²=matched is the SKF's PM-SNR of 0 dB (63/64); LCMV "
            f"reg {LCMV_REG:g}, unit-noise-gain; MxNE alpha "
            f"{MXNE_ALPHA:g} % of alpha_max, depth 0.9 (fixed before the runs).",
            "",
        ],
    )
    for condition in conditions(settings):
        rows = table[table["condition"] == condition.name]
        for snr in NOISE_LEVELS:
            level = rows[rows["snr_db"] == snr]
            parts += [
                f"### {condition.title}, {snr:g} dB ({int(level['n_seeds'].min())} seeds)",
                "",
                _table(level, recommended),
                "",
            ]
    return headline, "\n".join(parts) + "\n" + timings_text(table, settings)


#: The title of the report's last section, the only one that changes between identical runs.
TIMINGS_TITLE = "## Run times in this run"


def timings_text(table, settings):
    """Markdown: median ms per run and per preparation, per method and condition."""
    names = [c.name for c in conditions(settings)]
    lines = [
        TIMINGS_TITLE,
        "",
        "Median milliseconds per run / per preparation over the noise levels, measured in this "
        "report run on a shared 2-core machine, with the run's --jobs workers: the "
        "SKF prepares one spectral model per noise level; MNE's minimum-norm methods one "
        "inverse operator and its preparation per noise level, method and λ²; LCMV its "
        "filters per run; MxNE has no preparation. Wall times vary from run to run: compare "
        "ratios within a column.",
        "",
        "| method | " + " | ".join(names) + " |",
        "|---" * (1 + len(names)) + "|",
    ]
    per = table.groupby(["method", "setting", "condition"], sort=False)[["run_ms", "prep_ms"]]
    per = per.median()
    for method, setting in dict.fromkeys(zip(table["method"], table["setting"], strict=True)):
        cells = []
        for name in names:
            run, prep = per.loc[(method, setting, name)]
            cells.append(f"{run:.1f} / {prep:.0f}")
        lines.append(f"| {_label(method, setting)} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- figures


def _roc(present, absent):
    thresholds = np.unique(np.concatenate([present, absent]))[::-1]
    tpr = [0.0] + [float(np.mean(present >= t)) for t in thresholds]
    fpr = [0.0] + [float(np.mean(absent >= t)) for t in thresholds]
    return np.array(fpr), np.array(tpr)


def _shown(recommended):
    return [("SKF", recommended), *SHOWN]


def write_figures(raw, settings, out, recommended):
    """ROC curves and the seeds' deep scores; return name -> path relative to ``out``.

    Parameters
    ----------
    raw : pandas.DataFrame
        The scored seeds' baseline rows.
    settings : Settings
    out : Path
        The report folder.
    recommended : str
        The recommended setting's label (``"0.5/none"``).

    Returns
    -------
    dict
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shown = _shown(recommended)
    wide = [c for c in conditions(settings) if c.wide] or conditions(settings)[:1]
    folder = out / BASELINES
    paths = {}
    fig, axes = plt.subplots(len(wide), len(NOISE_LEVELS), figsize=(12, 3.8 * len(wide)))
    axes = np.atleast_2d(axes)
    for row, condition in zip(axes, wide, strict=True):
        data = raw[raw["condition"] == condition.name]
        for ax, snr in zip(row, NOISE_LEVELS, strict=True):
            level = data[data["snr_db"] == snr]
            for method, setting in shown:
                runs = level[(level["method"] == method) & (level["setting"] == setting)]
                present = runs.loc[runs["data"] == "both", "deep_region_db"].to_numpy()
                absent = runs.loc[runs["data"] == "superficial", "deep_region_db"].to_numpy()
                fpr, tpr = _roc(present, absent)
                label = _label(method, setting) + (
                    " (paper)" if setting == PAPER_LABEL and method == "SKF" else ""
                )
                ax.step(fpr, tpr, where="post", label=label)
            ax.plot([0, 1], [0, 1], color="0.7", lw=0.8, ls=":")
            ax.set(title=f"{condition.title}\n{snr:g} dB", xlabel="false-detection rate")
            ax.title.set_fontsize(8)
        row[0].set_ylabel("deep source: true-detection rate")
    axes[0, -1].legend(fontsize=6, loc="lower right")
    fig.tight_layout()
    paths["ROC curves of the deep source, present vs absent"] = _save(fig, folder / "roc.png")
    paths["The deep score of every seed, present vs absent"] = _strip(
        raw, wide[0], shown, folder / "deep_scores.png"
    )
    return {name: path.relative_to(out).as_posix() for name, path in paths.items()}


def _strip(raw, condition, shown, path):
    import matplotlib.pyplot as plt

    data = raw[raw["condition"] == condition.name]
    fig, axes = plt.subplots(1, len(NOISE_LEVELS), figsize=(13, 4.2), sharey=True)
    rng = np.random.default_rng(0)
    for ax, snr in zip(axes, NOISE_LEVELS, strict=True):
        level = data[data["snr_db"] == snr]
        for k, (method, setting) in enumerate(shown):
            runs = level[(level["method"] == method) & (level["setting"] == setting)]
            for shift, kind, color in ((-0.17, "both", "C0"), (0.17, "superficial", "C3")):
                values = runs.loc[runs["data"] == kind, "deep_region_db"].to_numpy()
                values = np.maximum(values, -40.0)  # MxNE's empty regions (-inf) at the floor
                x = k + shift + rng.uniform(-0.08, 0.08, values.size)
                ax.plot(x, values, "o", ms=2.5, color=color, alpha=0.7)
        ax.axhline(-DYNAMIC_RANGE_DB, color="k", lw=0.8, ls="--")
        ax.set_xticks(range(len(shown)))
        ax.set_xticklabels([_label(*m) for m in shown], rotation=60, ha="right", fontsize=6)
        ax.set_title(f"{condition.title}, {snr:g} dB", fontsize=8)
    axes[0].set_ylabel("deep region re. global maximum, dB (floor -40)")
    axes[0].plot([], [], "o", color="C0", label="deep present (both sources)")
    axes[0].plot([], [], "o", color="C3", label="deep absent (superficial only)")
    axes[0].legend(fontsize=6, loc="lower left")
    fig.tight_layout()
    return _save(fig, path)


def _save(fig, path):
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png", metadata={"Software": None})
    plt.close(fig)
    return path
