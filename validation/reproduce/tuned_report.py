"""The report's section "Priors chosen by the data" (:mod:`.tuned`'s comparison, as text)."""

from __future__ import annotations

from .report import _markdown_table
from .settings import CELLS, FINE_RANGE, TUNE_CRITERIA, TUNE_GRID, TUNING
from .stats import iqr_text
from .tuned import CRITERION_TEXT, SEPARATION_SHARE

__all__ = ["tuned_section"]


def _seed_text(seeds):
    seeds = list(seeds)
    if len(seeds) == 1:
        return f"seed {seeds[0]}"
    return f"seeds {seeds[0]}-{seeds[-1]}"


def _iqr_text(quartiles, digits=1):
    """``median [Q1, Q3]`` of :func:`.stats.quartiles`' result, "n/a" without a value."""
    return iqr_text(*quartiles[:3], digits=digits)


def _separation_text(entry):
    k, n = entry.separated
    return f"{k}/{n} ({100 * k / n:.0f} %)" if n else "n/a"


def _stage_label(stage):
    exponent, smoother = stage
    return f"{exponent:g}, {'no smoothing' if smoother == 'none' else smoother}"


def _comparison_rows(cell, comparison):
    head = [cell.title, f"{comparison.snr:g}", _stage_label(comparison.stage)]
    rows = []
    for criterion, entry in comparison.tuned.items():
        target = "met" if comparison.met[criterion] else "**not met**"
        rows.append((f"{CRITERION_TEXT[criterion]}, per seed", entry, target))
    chosen_on = _seed_text(comparison.choose_seeds)
    rows.append((f"best of the map, chosen on {chosen_on}", comparison.best, ""))
    rows += [("paper's cell", entry, "") for entry in comparison.paper]
    return [
        [
            *head,
            label,
            entry.priors,
            _iqr_text(entry.score),
            _separation_text(entry),
            _iqr_text(entry.correlation, 2),
            target,
        ]
        for label, entry, target in rows
    ]


def _bound_rows(cell, comparison):
    rows = []
    for criterion, bounds in comparison.bounds.items():
        rows.append(
            [
                cell.title,
                f"{comparison.snr:g}",
                CRITERION_TEXT[criterion],
                str(bounds.seeds),
                " / ".join(map(str, bounds.pm_snr_db)),
                " / ".join(map(str, bounds.ep_snr_db)),
                str(bounds.warnings),
            ]
        )
    return rows


_HEADER = [
    "cell",
    "SNR (dB)",
    "exponent, smoother",
    "priors",
    "EP, PM (dB)",
    "score (mm)",
    "separation",
    "correlation",
    "target",
]
_BOUND_HEADER = [
    "cell",
    "SNR (dB)",
    "criterion",
    "seeds",
    "PM-SNR on lower / upper bound",
    "EP-SNR on lower / upper bound",
    "warnings caught",
]


def _collect(data):
    """The tables' rows and the counts the text states, over the cells that ran."""
    totals = dict(
        rows=[],
        bound_rows=[],
        met=dict.fromkeys(TUNE_CRITERIA, 0),
        on_bound={c: dict(pm_snr_db=0, ep_snr_db=0) for c in TUNE_CRITERIA},
        choices=dict.fromkeys(TUNE_CRITERIA, 0),
        caught=0,
        settings=0,
        split=None,
    )
    for cell in CELLS:
        result = data.results.get(cell.name)
        for comparison in result.tuned if result is not None else []:
            totals["rows"] += _comparison_rows(cell, comparison)
            totals["settings"] += 1
            totals["split"] = comparison.choose_seeds, comparison.score_seeds
            for criterion in TUNE_CRITERIA:
                totals["met"][criterion] += comparison.met[criterion]
            if comparison.stage != TUNING:  # the same choices serve both stages
                continue
            totals["bound_rows"] += _bound_rows(cell, comparison)
            for criterion, bounds in comparison.bounds.items():
                totals["choices"][criterion] += bounds.seeds
                totals["caught"] += bounds.warnings
                for name in ("pm_snr_db", "ep_snr_db"):
                    totals["on_bound"][criterion][name] += sum(getattr(bounds, name))
    return totals


def _intro(totals):
    choose, score = totals["split"]
    lower, upper = FINE_RANGE
    met = "; ".join(
        f"by the {CRITERION_TEXT[c]}: met in {totals['met'][c]} of {totals['settings']} settings"
        for c in TUNE_CRITERIA
    )
    return (
        "For each seed and noise level, `skf_ref.tune` chose EP-SNR and PM-SNR from that "
        f"seed's data alone ({TUNE_GRID} x {TUNE_GRID} grid over {lower:g} .. {upper:g} dB, "
        "the fine map's span), knowing the noise level as every other run does, and nothing "
        "of the sources, by each of two criteria (docs/model.md §4): the *marginal "
        "likelihood* (the grid, then a bounded refinement), and the *discrepancy principle* "
        "(EP-SNR where the whitened residual of the filtered means equals its expected value "
        "under the noise model, channels x time steps; PM-SNR, about which the principle "
        "says nothing, by the marginal likelihood along that curve). Neither depends on the "
        "exponent or the smoother, so one choice serves the tuning setting and the smoothed "
        "one. Beside them: the *best of the map*, the cell of the fine EP x PM map (and the "
        "paper's corners) with the lowest median score at that setting over "
        f"{_seed_text(choose)} (chosen with the ground truth, a minimum over many cells), and "
        "the paper's recommended cells (tuning: (EP 0, PM 0) at 10 and 20 dB, (EP 20, PM 0) "
        "and (EP 0, PM 20) at 30 dB; smoothed: (EP 20, PM 0)). Every entry is scored on "
        f"{_seed_text(score)} ({len(score)} seed{'s' if len(score) > 1 else ''}, none of "
        "which chose the best cell): score (the mean of the two peak errors) and correlation "
        "(the mean of the two time-course correlations) as median [Q1, Q3] over those seeds, "
        "separation as the seeds separated of those seeds (%); the tuned priors as median "
        "[Q1, Q3] of the per-seed choices. Target (stated before the runs): the tuned priors "
        f"reach at least {100 * SEPARATION_SHARE:.0f} % of the best cell's separation rate, "
        f"and their median score is at most the best cell's Q3. Per criterion, {met}. "
        "Rows: `<cell>/tuned_priors.csv`."
    )


def _bounds_text(totals):
    from skf_ref.method._tuning import BOUND_TOL_DB

    lower, upper = FINE_RANGE
    counts = "; ".join(
        f"by the {CRITERION_TEXT[c]} ({totals['choices'][c]} choices), PM-SNR in "
        f"{totals['on_bound'][c]['pm_snr_db']} and EP-SNR in {totals['on_bound'][c]['ep_snr_db']}"
        for c in TUNE_CRITERIA
    )
    return (
        f"Choices on a bound of the search range ({lower:g} or {upper:g} dB, within "
        f"{BOUND_TOL_DB:g} dB), over every seed of the run (cells x noise levels x seeds): "
        f"{counts}. There the criterion would have gone further than the range the study "
        "searches. `tune` warns for each (a `UserWarning` naming the SNR and the bound): "
        f"{totals['caught']} warnings, caught and counted here, one for each SNR on a bound."
    )


def tuned_section(data):
    """The report's section "Priors chosen by the data", as lines of Markdown.

    Parameters
    ----------
    data : validation.reproduce.overview.Overview
        Its ``results``: cell name -> CellResult with ``tuned`` comparisons.

    Returns
    -------
    list of str
        Empty when no cell ran.
    """
    totals = _collect(data)
    if totals["split"] is None:
        return []
    return [
        "## Priors chosen by the data",
        "",
        _intro(totals),
        "",
        *_markdown_table(_HEADER, totals["rows"]),
        "",
        _bounds_text(totals),
        "",
        *_markdown_table(_BOUND_HEADER, totals["bound_rows"]),
        "",
    ]
