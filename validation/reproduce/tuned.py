"""Priors chosen by the data: two criteria against the ground truth's best cell and the paper's.

For every seed and noise level, :func:`skf_ref.method.tuning` picks EP-SNR and PM-SNR from that
seed's data alone (the search range of the fine map, -20 .. 40 dB, its default), by each of
its criteria: the marginal likelihood, and the discrepancy principle (EP-SNR where the
whitened residual of the filtered means equals its expected value ``n_channels * n_times``,
PM-SNR by the likelihood along that curve; docs/model.md §4). The SKF runs at those priors
in the tuning setting and in the smoothed one (neither criterion depends on the exponent or
the smoother, so one choice serves both). The rows are computed by
:func:`skf_ref.study.sweep.run_on_head`, the code of every other row, so their metrics mean what
the sweep's mean. ``tune`` warns when a searched SNR ends on a bound of its range; here the
warnings are caught, counted and checked against the choices that lie on a bound.

They are compared with two fixed cells of the same setting and noise level: the best cell
of the fixed-prior map (the fine EP x PM map and the paper's corners) *chosen on the first
half of the seeds* (:func:`split_seeds`: the lowest median localization score there, ties
by the lower mean, then by (EP, PM) order), and the paper's recommended cells. Every entry is
*scored on the other half*, so the best cell is not judged on the seeds that chose it. Each
number is a median with its interquartile range over the scoring seeds (peak errors take
few values, a grid's spacing apart), separation a count of those seeds.

The target, stated before any run of this comparison and kept: for each criterion, noise
level and stage, the tuned priors (scored on the scoring seeds) reach

- a separation rate at least 90 % (:data:`SEPARATION_SHARE`) of the chosen best cell's,
  and
- a median score no higher than the chosen best cell's third quartile (its Q3),

both over the scoring seeds.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from skf_ref._utils.atomic_files import atomic_path

from .report import _markdown_table
from .settings import (
    CELLS,
    FINE_RANGE,
    MONTAGE,
    NOISE_LEVELS,
    STAGES,
    TIE_MM,
    TUNE_CRITERIA,
    TUNE_GRID,
    TUNED_PRIOR,
    TUNING,
)
from .stats import _cell, _with_score, quartiles

__all__ = [
    "SEPARATION_SHARE",
    "TUNED",
    "Bounds",
    "Entry",
    "TunedComparison",
    "compare_tuned",
    "paper_cells",
    "run_tuned",
    "split_seeds",
    "tuned_section",
]

#: The results file of the tuned runs, in each cell's folder: one row per criterion,
#: noise level, stage and seed.
TUNED = "tuned_priors.csv"
#: The share of the chosen best cell's separation rate the tuned priors must reach.
SEPARATION_SHARE = 0.9
#: How the criteria read in the report.
_CRITERION_TEXT = {"likelihood": "marginal likelihood", "discrepancy": "discrepancy principle"}
#: The searched SNRs, as ``tune`` names them, and their bound columns in :data:`TUNED`.
_BOUND_COLUMNS = {"pm_snr_db": "pm_bound", "ep_snr_db": "ep_bound"}


def split_seeds(seeds):
    """The seeds that choose the best cell, and the disjoint seeds that score every entry.

    Parameters
    ----------
    seeds : int
        Seeds 0 .. seeds - 1 (at least 2).

    Returns
    -------
    choose, score : range
        The first half (rounded down) and the rest.

    Examples
    --------
    >>> split_seeds(10)
    (range(0, 5), range(5, 10))
    >>> split_seeds(2)
    (range(0, 1), range(1, 2))
    """
    half = seeds // 2
    return range(half), range(half, seeds)


def paper_cells(snr, stage):
    """The paper's recommended (EP, PM) cells at a noise level and stage.

    Tuning stage: (0, 0) at 10 and 20 dB, (20, 0) and (0, 20) at 30 dB (docs/model.md §7,
    F1-F3); smoothed: (20, 0) at every noise level, the priors the paper smoothed with.

    Parameters
    ----------
    snr : float
    stage : tuple
        (exponent, smoother label).

    Returns
    -------
    list of (float, float)
    """
    if stage != TUNING:
        return [TUNED_PRIOR]
    return [(20.0, 0.0), (0.0, 20.0)] if snr == 30.0 else [(0.0, 0.0)]


# --------------------------------------------------------------------------- runs


def _choose(L, sim, criterion):
    """``tune`` by one criterion, its bound warnings caught and counted, not printed."""
    from skf_ref.method.tuning import tune

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)  # count repeats from the same line
        chosen = tune(
            L,
            sim.Y,
            noise_std=sim.sigma,
            pm_snr_db=FINE_RANGE,
            ep_snr_db=FINE_RANGE,
            grid=TUNE_GRID,
            criterion=criterion,
        )
    bound = [
        w for w in caught if issubclass(w.category, UserWarning) and "bound" in str(w.message)
    ]
    for w in caught:  # anything else is not ours to hide
        if not any(w is b for b in bound):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if len(bound) != len(chosen.at_bound):
        raise RuntimeError(
            f"tune warned {len(bound)} times for {len(chosen.at_bound)} SNRs on a bound "
            f"({chosen!r})"
        )
    return chosen, len(bound)


def _tuned_group(head_kwargs, snr, seeds):
    """Tune every seed at one noise level by each criterion and run both stages there."""
    from skf_ref.study import scenario as simulate
    from skf_ref.study.head import make_head
    from skf_ref.study.sweep import run_on_head

    head = make_head(**dict(head_kwargs, montage=MONTAGE))
    scenario = simulate.p20n20_scenario()
    runs = [
        (exponent, None if smoother == "none" else smoother) for _, (exponent, smoother) in STAGES
    ]
    rows = []
    for seed in seeds:
        sim = simulate.simulate(head, scenario, snr, seed)
        for criterion in TUNE_CRITERIA:
            chosen, n_warnings = _choose(head.leadfield, sim, criterion)
            group = run_on_head(
                head,
                snr,
                chosen.ep_snr_db,
                chosen.pm_snr_db,
                [(exponent, smoother, seed) for exponent, smoother in runs],
            )
            for row in group:
                # the run used tune's priors: its likelihood is the one tune found there
                # (for the likelihood criterion, its maximum)
                if not np.isclose(row["log_likelihood"], chosen.log_likelihood, rtol=1e-9, atol=0):
                    raise RuntimeError(
                        f"seed {seed}, {snr:g} dB, {criterion}: the run's log-likelihood "
                        f"{row['log_likelihood']!r} is not tune's {chosen.log_likelihood!r}"
                    )
                row.update(
                    criterion=criterion,
                    bound_warnings=n_warnings,
                    **{
                        column: chosen.at_bound.get(name, "none")
                        for name, column in _BOUND_COLUMNS.items()
                    },
                )
            rows += group
    return rows


def run_tuned(head_kwargs, seeds, path, n_jobs=1):
    """The tuned runs of one cell, computed or read back from ``path``.

    Parameters
    ----------
    head_kwargs : dict
        Keyword arguments of :func:`skf_ref.study.head.make_head` (picklable).
    seeds : int
        Seeds 0 .. seeds - 1 at every noise level.
    path : Path
        The results file (read if present; the caller deletes stale ones).
    n_jobs : int
        joblib workers, one noise level each.

    Returns
    -------
    pandas.DataFrame
        Sweep rows (``smoother`` as a label), ``ep_snr_db`` and ``pm_snr_db`` the priors
        chosen for each seed by ``criterion``; ``pm_bound`` and ``ep_bound`` the end of the
        search range each lies on ("lower", "upper" or "none"), ``bound_warnings`` the
        warnings ``tune`` gave for that choice.
    """
    from joblib import Parallel, delayed

    path = Path(path)
    if path.exists():
        return pd.read_csv(path)
    groups = Parallel(n_jobs=n_jobs)(
        delayed(_tuned_group)(head_kwargs, snr, range(seeds)) for snr in NOISE_LEVELS
    )
    table = pd.DataFrame([row for rows in groups for row in rows])
    table = table.sort_values(
        ["snr_db", "criterion", "exponent", "smoother", "seed"], ignore_index=True
    )
    table["blas"] = table["blas"].map(lambda value: " ".join(sorted(value.split())))
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False, lineterminator="\n")
    return pd.read_csv(path)


# --------------------------------------------------------------------------- comparison


@dataclass(frozen=True)
class Entry:
    """One set of priors at one setting: how it scores over the scoring seeds.

    Attributes
    ----------
    label : str
    priors : str
        The cell, or the median and IQR of the per-seed choices.
    score : tuple
        Median, Q1, Q3 and count of the localization score (mm).
    separated : tuple
        Seeds with separation, and seeds.
    correlation : tuple
        Median, Q1, Q3 and count of the mean of the two time-course correlations.
    """

    label: str
    priors: str
    score: tuple
    separated: tuple
    correlation: tuple

    @property
    def separation(self):
        """float : The fraction of seeds with separation (NaN for none)."""
        k, n = self.separated
        return k / n if n else np.nan


@dataclass(frozen=True)
class Bounds:
    """How often one criterion's choices at one noise level lay on a bound of the range.

    Attributes
    ----------
    seeds : int
        Choices (every seed of the run, not only the scoring ones).
    pm_snr_db, ep_snr_db : tuple
        Choices on the lower and on the upper end of the search range.
    warnings : int
        The warnings (``UserWarning``) ``tune`` gave for them, caught, not printed.
    """

    seeds: int
    pm_snr_db: tuple
    ep_snr_db: tuple
    warnings: int


@dataclass(frozen=True)
class TunedComparison:
    """The tuned priors beside the ground truth's and the paper's, at one setting.

    Attributes
    ----------
    snr : float
    stage : tuple
        (exponent, smoother label).
    choose_seeds, score_seeds : tuple of int
        The seeds that chose the best cell, and the disjoint seeds every entry is scored on.
    tuned : dict
        Criterion -> Entry.
    best : Entry
        The best cell of the map, chosen on ``choose_seeds``.
    paper : list of Entry
    met : dict
        Criterion -> whether the stated target holds: separation rate >= 90 % of the best
        cell's, and median score <= the best cell's Q3.
    bounds : dict
        Criterion -> Bounds.
    """

    snr: float
    stage: tuple
    choose_seeds: tuple
    score_seeds: tuple
    tuned: dict
    best: Entry
    paper: list
    met: dict
    bounds: dict


def _entry(label, priors, rows):
    rows = _with_score(rows)
    correlation = (rows["deep_corr"] + rows["superficial_corr"]) / 2.0
    separated = rows["separation"].astype(bool)
    return Entry(
        label,
        priors,
        quartiles(rows["score"]),
        (int(separated.sum()), len(rows)),
        quartiles(correlation),
    )


def _setting(table, snr, stage, seeds):
    exponent, smoother = stage
    rows = table[
        (table["snr_db"] == snr)
        & (table["exponent"] == exponent)
        & (table["smoother"] == smoother)
        & table["seed"].isin(list(seeds))
    ]
    return _with_score(rows)


def _at(rows, ep, pm):
    return rows[(rows["ep_snr_db"] == ep) & (rows["pm_snr_db"] == pm)]


def _chosen(rows):
    text = []
    for name, column in (("EP", "ep_snr_db"), ("PM", "pm_snr_db")):
        median, q1, q3, _ = quartiles(rows[column])
        text.append(f"{name} {median:.1f} [{q1:.1f}, {q3:.1f}]")
    return ", ".join(text)


def _best_cell(cells):
    """The (EP, PM) of lowest median score; ties by the lower mean, then (EP, PM) order."""
    scores = cells.groupby(["ep_snr_db", "pm_snr_db"])["score"]
    stats = pd.DataFrame(dict(median=scores.median(), mean=scores.mean()))
    low = stats["median"].min()
    tied = stats[stats["median"] <= low + TIE_MM]
    return tied["mean"].idxmin()  # the first in (EP, PM) order among equal means


def _bounds(rows):
    """Bounds of one criterion's choices, from their tuning-stage rows (one per choice)."""
    counts = {
        name: tuple(int((rows[column] == end).sum()) for end in ("lower", "upper"))
        for name, column in _BOUND_COLUMNS.items()
    }
    return Bounds(
        len(rows), counts["pm_snr_db"], counts["ep_snr_db"], int(rows["bound_warnings"].sum())
    )


def _met(entry, best):
    return bool(
        entry.separation >= SEPARATION_SHARE * best.separation and entry.score[0] <= best.score[2]
    )


def compare_tuned(tuned, fixed, seeds):
    """Compare the tuned runs with the best fixed cell and the paper's at every setting.

    Parameters
    ----------
    tuned : pandas.DataFrame
        :func:`run_tuned`'s rows.
    fixed : pandas.DataFrame
        Fixed-prior sweep rows holding both stages' cells (the fine map and the paper
        grid together).
    seeds : int
        The run's seeds, split by :func:`split_seeds`.

    Returns
    -------
    list of TunedComparison
        One per noise level and stage.
    """
    choose, score = split_seeds(seeds)
    out = []
    for snr in NOISE_LEVELS:
        for _, stage in STAGES:
            cells = _setting(fixed, snr, stage, range(seeds)).drop_duplicates(
                ["ep_snr_db", "pm_snr_db", "seed"]
            )
            ep, pm = _best_cell(cells[cells["seed"].isin(list(choose))])
            scored = cells[cells["seed"].isin(list(score))]
            best = _entry("best of the map", _cell((ep, pm)), _at(scored, ep, pm))
            recommended = paper_cells(snr, stage)
            paper = [_entry("paper", _cell((e, p)), _at(scored, e, p)) for e, p in recommended]
            entries, met, bounds = {}, {}, {}
            for criterion in TUNE_CRITERIA:
                mine = tuned[tuned["criterion"] == criterion]
                rows = _setting(mine, snr, stage, score)
                entries[criterion] = _entry(criterion, _chosen(rows), rows)
                met[criterion] = _met(entries[criterion], best)
                bounds[criterion] = _bounds(_setting(mine, snr, TUNING, range(seeds)))
            out.append(
                TunedComparison(
                    snr, stage, tuple(choose), tuple(score), entries, best, paper, met, bounds
                )
            )
    return out


# --------------------------------------------------------------------------- the section


def _seed_text(seeds):
    seeds = list(seeds)
    if len(seeds) == 1:
        return f"seed {seeds[0]}"
    return f"seeds {seeds[0]}-{seeds[-1]}"


def _iqr_text(quartiles, digits=1):
    median, q1, q3, n = quartiles
    if n == 0:
        return "n/a"
    return f"{median:.{digits}f} [{q1:.{digits}f}, {q3:.{digits}f}]"


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
        rows.append((f"{_CRITERION_TEXT[criterion]}, per seed", entry, target))
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
                _CRITERION_TEXT[criterion],
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
        f"by the {_CRITERION_TEXT[c]}: met in {totals['met'][c]} of {totals['settings']} settings"
        for c in TUNE_CRITERIA
    )
    return (
        "For each seed and noise level, `skf_ref.method.tuning` chose EP-SNR and PM-SNR from that "
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
    from skf_ref.method.tuning import BOUND_TOL_DB

    lower, upper = FINE_RANGE
    counts = "; ".join(
        f"by the {_CRITERION_TEXT[c]} ({totals['choices'][c]} choices), PM-SNR in "
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
