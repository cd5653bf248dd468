"""Priors chosen by the data: two criteria against the ground truth's best cell and the paper's.

For every seed and noise level, :func:`skf_ref.tune` picks EP-SNR and PM-SNR from that
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

from .settings import (
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
    "CRITERION_TEXT",
    "SEPARATION_SHARE",
    "TUNED",
    "Bounds",
    "Entry",
    "TunedComparison",
    "compare_tuned",
    "paper_cells",
    "run_tuned",
    "split_seeds",
]

#: The results file of the tuned runs, in each cell's folder: one row per criterion,
#: noise level, stage and seed.
TUNED = "tuned_priors.csv"
#: The share of the chosen best cell's separation rate the tuned priors must reach.
SEPARATION_SHARE = 0.9
#: How the criteria read in the report.
CRITERION_TEXT = {"likelihood": "marginal likelihood", "discrepancy": "discrepancy principle"}
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
    from skf_ref import tune

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
        joblib workers, one noise level and seed each.

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
    groups = Parallel(n_jobs=n_jobs)(  # by seed: three noise levels keep one of 2 workers idle
        delayed(_tuned_group)(head_kwargs, snr, [seed])
        for snr in NOISE_LEVELS
        for seed in range(seeds)
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
