"""Priors chosen by the data: two criteria against the ground truth's best cell and the paper's.

For every seed and noise level, :func:`skf_ref.tune` picks EP-SNR and PM-SNR from that
seed's data alone (the search range of the fine map, -20 .. 40 dB, its default), by each of
its criteria: the marginal likelihood, and the discrepancy principle (EP-SNR where the
whitened residual of the filtered means equals its expected value ``n_channels * n_times``,
PM-SNR by the likelihood along that curve; docs/model.md §4). The SKF runs at those priors
in the tuning setting and in the smoothed one (neither criterion depends on the exponent or
the smoother, so one choice serves both). The rows are computed by
:func:`skf_ref.sweep.run_on_head`, the code of every other row, so their metrics mean what
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

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from skf_ref.files import atomic_path

from .settings import FINE_RANGE, MONTAGE, NOISE_LEVELS, STAGES, TUNE_GRID, TUNED_PRIOR, TUNING
from .stats import _cell, _mean_se, _with_score

__all__ = ["TUNED", "Entry", "TunedComparison", "compare_tuned", "paper_cells", "run_tuned"]

#: The results file of the tuned runs, in each cell's folder.
TUNED = "tuned_priors.csv"
#: The share of the ground-truth cell's separation rate the tuned priors must reach.
SEPARATION_SHARE = 0.9


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


def _tuned_group(head_kwargs, snr, seeds):
    """Tune every seed at one noise level and run both stages at its priors."""
    from skf_ref import simulate
    from skf_ref.head import make_head
    from skf_ref.sweep import run_on_head
    from skf_ref.tune import tune

    head = make_head(**dict(head_kwargs, montage=MONTAGE))
    scenario = simulate.p20n20_scenario()
    runs = [
        (exponent, None if smoother == "none" else smoother) for _, (exponent, smoother) in STAGES
    ]
    rows = []
    for seed in seeds:
        sim = simulate.simulate(head, scenario, snr, seed)
        chosen = tune(
            head.leadfield,
            sim.Y,
            noise_std=sim.sigma,
            pm_snr_db=FINE_RANGE,
            ep_snr_db=FINE_RANGE,
            grid=TUNE_GRID,
        )
        group = run_on_head(
            head,
            snr,
            chosen.ep_snr_db,
            chosen.pm_snr_db,
            [(exponent, smoother, seed) for exponent, smoother in runs],
        )
        for row in group:
            if not np.isclose(row["log_likelihood"], chosen.log_likelihood, rtol=1e-9, atol=0):
                raise RuntimeError(
                    f"seed {seed}, {snr:g} dB: the run's log-likelihood "
                    f"{row['log_likelihood']!r} is not tune's maximum {chosen.log_likelihood!r}"
                )
        rows += group
    return rows


def run_tuned(head_kwargs, seeds, path, n_jobs=1):
    """The tuned runs of one cell, computed or read back from ``path``.

    Parameters
    ----------
    head_kwargs : dict
        Keyword arguments of :func:`skf_ref.head.make_head` (picklable).
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
        chosen for each seed.
    """
    from joblib import Parallel, delayed

    path = Path(path)
    if path.exists():
        return pd.read_csv(path)
    groups = Parallel(n_jobs=n_jobs)(
        delayed(_tuned_group)(head_kwargs, snr, range(seeds)) for snr in NOISE_LEVELS
    )
    table = pd.DataFrame([row for rows in groups for row in rows])
    table = table.sort_values(["snr_db", "exponent", "smoother", "seed"], ignore_index=True)
    table["blas"] = table["blas"].map(lambda value: " ".join(sorted(value.split())))
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False, lineterminator="\n")
    return pd.read_csv(path)


@dataclass(frozen=True)
class Entry:
    """One set of priors at one setting: how it scores over the seeds.

    Attributes
    ----------
    label : str
    priors : str
        The cell, or the median and range of the per-seed choices.
    score : tuple
        Mean, SE and count of the localization score (mm).
    separation : float
        Fraction of seeds with separation.
    correlation : float
        Mean over seeds of the mean of the two time-course correlations.
    """

    label: str
    priors: str
    score: tuple
    separation: float
    correlation: float


@dataclass(frozen=True)
class TunedComparison:
    """The tuned priors beside the ground truth's and the paper's, at one setting.

    Attributes
    ----------
    snr : float
    stage : tuple
        (exponent, smoother label).
    tuned, best : Entry
    paper : list of Entry
    met : bool
        The stated target: separation rate >= 90 % of the best cell's, and the mean score
        within one SE of the best cell's.
    edges : dict
        ``"ep_snr_db"``, ``"pm_snr_db"`` -> seeds whose choice lies on an end of the search
        range (within 0.01 dB): the likelihood would go further there.
    """

    snr: float
    stage: tuple
    tuned: Entry
    best: Entry
    paper: list
    met: bool
    edges: dict


def _entry(label, priors, rows):
    rows = _with_score(rows)
    correlation = ((rows["deep_corr"] + rows["superficial_corr"]) / 2.0).mean()
    return Entry(
        label,
        priors,
        _mean_se(rows["score"]),
        float(rows["separation"].astype(bool).mean()),
        float(correlation),
    )


def _setting(table, snr, stage, seeds):
    exponent, smoother = stage
    rows = table[
        (table["snr_db"] == snr)
        & (table["exponent"] == exponent)
        & (table["smoother"] == smoother)
        & (table["seed"] < seeds)
    ]
    return _with_score(rows)


def _at(rows, ep, pm):
    return rows[(rows["ep_snr_db"] == ep) & (rows["pm_snr_db"] == pm)]


def _chosen(rows):
    text = []
    for name, column in (("EP", "ep_snr_db"), ("PM", "pm_snr_db")):
        values = rows[column]
        text.append(f"{name} {values.median():.1f} ({values.min():.1f} to {values.max():.1f})")
    return ", ".join(text)


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

    Returns
    -------
    list of TunedComparison
        One per noise level and stage.
    """
    out = []
    for snr in NOISE_LEVELS:
        for _, stage in STAGES:
            cells = _setting(fixed, snr, stage, seeds).drop_duplicates(
                ["ep_snr_db", "pm_snr_db", "seed"]
            )
            means = cells.groupby(["ep_snr_db", "pm_snr_db"])["score"].mean()
            ep, pm = means.idxmin()  # ties: the first in (EP, PM) order
            best = _entry("best of the map", _cell((ep, pm)), _at(cells, ep, pm))
            recommended = paper_cells(snr, stage)
            paper = [_entry("paper", _cell((e, p)), _at(cells, e, p)) for e, p in recommended]
            rows = _setting(tuned, snr, stage, seeds)
            entry = _entry("tuned", _chosen(rows), rows)
            met = bool(
                entry.separation >= SEPARATION_SHARE * best.separation
                and entry.score[0] <= best.score[0] + best.score[1]
            )
            low, high = FINE_RANGE[0] + 0.01, FINE_RANGE[1] - 0.01
            edges = {
                column: int(((rows[column] <= low) | (rows[column] >= high)).sum())
                for column in ("ep_snr_db", "pm_snr_db")
            }
            out.append(TunedComparison(snr, stage, entry, best, paper, met, edges))
    return out
