"""Specificity of every method: ROC areas, detection rates, error distributions.

A source's score in a run is its region's maximum at its peak time re. the global maximum
(dB; :func:`skf_ref.study.regions.region_db`), and it "is detected" at -6 dB, the report's
threshold. The deep score is compared between the data with both sources (present) and
with the superficial source only (absent, same noise draws); the superficial score between
both sources and the deep source only. Errors are the peak localization errors with both
sources present, given as median [Q1, Q3] over the seeds: they take few values (a grid's
spacing), which a mean hides. The report's text and figures of these numbers are
:mod:`.specificity_report`'s.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from skf_ref._utils.atomic_files import atomic_path
from skf_ref.study.regions import DYNAMIC_RANGE_DB

from .recommend import recommend
from .stats import quartiles

__all__ = [
    "RECOMMENDATION",
    "auc_interval",
    "check_against_sweeps",
    "recommendation",
    "scores",
    "setting_label",
    "write_recommendation",
]

#: Where the recommendation is recorded, relative to the report folder.
RECOMMENDATION = "recommendation.json"
_SOURCES = {"deep": "superficial", "superficial": "deep"}  # source -> the data without it


def auc_interval(present, absent):
    """AUC and Newcombe's (2006) method 5 95 % interval (honest at 0 and 1).

    Parameters
    ----------
    present, absent : ndarray, shape (n_present,) and (n_absent,)

    Returns
    -------
    area, low, high : float

    Examples
    --------
    >>> area, low, high = auc_interval(np.array([2.0, 3.0]), np.array([0.0, 1.0]))
    >>> area, round(low, 2), high
    (1.0, 0.39, 1.0)
    """
    from .worth.intervals import newcombe_auc

    return newcombe_auc(np.asarray(present, float), np.asarray(absent, float))


def _rate(flags):
    """Rate and its Clopper-Pearson interval."""
    from .worth.intervals import clopper_pearson

    flags = np.asarray(flags, dtype=bool)
    return (float(flags.mean()), *clopper_pearson(int(flags.sum()), flags.size))


def scores(table):
    """One row per condition, noise level, method and setting: AUCs, rates, errors, times.

    Parameters
    ----------
    table : pandas.DataFrame
        Baseline rows (:data:`baselines.COLUMNS`) of one seed set.

    Returns
    -------
    pandas.DataFrame
    """
    rows = []
    keys = ["condition", "snr_db", "method", "setting"]
    for key, group in table.groupby(keys, sort=False):
        by = {data: part.sort_values("seed") for data, part in group.groupby("data")}
        row = dict(zip(keys, key, strict=True), n_seeds=len(by["both"]))
        for source, without in _SOURCES.items():
            column = f"{source}_region_db"
            present, absent = by["both"][column].to_numpy(), by[without][column].to_numpy()
            row[f"{source}_auc"], row[f"{source}_low"], row[f"{source}_high"] = auc_interval(
                present, absent
            )
            for name, flags in (("tpr", present), ("fpr", absent)):
                rate = _rate(flags >= -DYNAMIC_RANGE_DB)
                row[f"{source}_{name}"], row[f"{source}_{name}_low"] = rate[:2]
                row[f"{source}_{name}_high"] = rate[2]
            if source == "deep" and "deep_level" in by["both"]:
                for score in ("level", "epoch_db"):
                    present = by["both"][f"deep_{score}"].to_numpy()
                    absent = by[without][f"deep_{score}"].to_numpy()
                    area, low, high = auc_interval(present, absent)
                    row[f"deep_{score}_auc"], row[f"deep_{score}_low"] = area, low
                    row[f"deep_{score}_high"] = high
            errors = by["both"][f"{source}_error_mm"]
            row[f"{source}_err"], row[f"{source}_q1"], row[f"{source}_q3"] = quartiles(errors)[:3]
            row[f"{source}_no_estimate"] = int(errors.isna().sum())
        row["run_ms"] = 1e3 * float(group["run_s"].median())
        row["prep_ms"] = 1e3 * float(group["prep_s"].median())
        rows.append(row)
    return pd.DataFrame(rows)


def recommendation(choice):
    """The rule's setting from the choice seeds' rows, and the candidates' scores.

    Parameters
    ----------
    choice : pandas.DataFrame
        The choice seeds' baseline rows (SKF settings only).

    Returns
    -------
    setting : dict
        ``{"exponent": float, "smoother": str or None}``.
    admissible : bool
    candidates : pandas.DataFrame
        The rule's inputs, one row per setting and noise level.
    """
    table = scores(choice)
    both = choice[choice["data"] == "both"]
    summed = both["deep_error_mm"] + both["superficial_error_mm"]  # per seed
    error = summed.groupby([both["snr_db"], both["setting"]]).median()
    split = table["setting"].str.split("/", expand=True)
    candidates = pd.DataFrame(
        dict(
            exponent=split[0].astype(float),
            smoother=split[1],
            snr_db=table["snr_db"],
            deep_auc=table["deep_auc"],
            superficial_auc=table["superficial_auc"],
            error_mm=[
                error[snr, s] for snr, s in zip(table["snr_db"], table["setting"], strict=True)
            ],
        )
    )
    setting, admissible = recommend(candidates)
    return setting, admissible, candidates


def setting_label(setting):
    """``{"exponent": 0.5, "smoother": None}`` -> ``"0.5/none"`` (the results' label)."""
    return f"{setting['exponent']:g}/{setting['smoother'] or 'none'}"


def write_recommendation(out, setting, admissible, seeds):
    """Record the recommended setting, and the seeds it was chosen on, in ``out``."""
    record = dict(
        setting=setting,
        admissible=admissible,
        rule="validation/reproduce/recommend.py",
        choice_seeds=sorted(int(seed) for seed in seeds),
    )
    with atomic_path(out / RECOMMENDATION) as tmp:
        tmp.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")


def check_against_sweeps(raw, results):
    """Raise unless the SKF's baseline runs equal the sweeps' on the seeds both ran.

    The white-noise conditions' SKF rows on the superficial-only data must reproduce the
    cells' superficial control (same head, pulses, noise draws, priors and settings): the
    proof that the baselines ran on the sweeps' simulations.

    Parameters
    ----------
    raw : pandas.DataFrame
        Baseline rows.
    results : dict
        Cell name -> :class:`cells.CellResult` (with its ``controls``).
    """
    from .baselines import EXTRA_SKF
    from .settings import TUNED_PRIOR

    for name, result in results.items():
        if name not in set(raw["condition"]):
            continue  # a --quick run's baselines leave out the cells but the main one
        control = result.controls["superficial"]
        control = control[
            (control["ep_snr_db"] == TUNED_PRIOR[0]) & (control["pm_snr_db"] == TUNED_PRIOR[1])
        ]
        ours = raw[(raw["condition"] == name) & (raw["method"] == "SKF")]
        ours = ours[~ours["setting"].isin(EXTRA_SKF)]  # not in the sweeps' grid
        ours = ours[(ours["data"] == "superficial") & ours["seed"].isin(control["seed"])]
        setting = control["exponent"].map("{:g}".format) + "/" + control["smoother"]
        keyed = control.assign(setting=setting).set_index(["snr_db", "seed", "setting"])
        joined = ours.merge(
            keyed.add_suffix("_sweep"),
            left_on=["snr_db", "seed", "setting"],
            right_index=True,
            how="left",
        )
        if joined.empty or joined["deep_region_db_sweep"].isna().any():
            raise RuntimeError(f"{name}: the baselines' SKF runs are missing from the sweeps")
        differ = ~np.isclose(
            joined["deep_region_db"], joined["deep_region_db_sweep"], rtol=0, atol=1e-6
        )
        if differ.any():
            raise RuntimeError(
                f"{name}: {int(differ.sum())} baseline SKF runs differ from the sweeps' "
                "superficial control: stale results; rerun with --fresh"
            )
