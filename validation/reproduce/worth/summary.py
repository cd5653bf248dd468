"""From runs to numbers: thresholds, rates with their intervals, medians, ROC areas.

:func:`summarize` turns one method's runs (of one set and design) into long rows
``(quantity, snr_db, value, low, high, n)``: for medians ``low`` and ``high`` are the
quartiles, for rates the Clopper-Pearson interval, for ROC areas Newcombe's interval.
:func:`as_linear_tables` puts the per-run methods' rows in the linear study's tables.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from skf_ref.study.detection import null_threshold

from .design import MOMENTS
from .intervals import clopper_pearson, newcombe_auc

__all__ = ["as_linear_tables", "read_runs", "summarize", "thresholds"]


def read_runs(path):
    """A linear results file as ``{"lone": ..., "nulls": ..., "configurations": ...}``."""
    table = pd.read_csv(path)
    return {
        name: part.drop(columns="table").dropna(axis=1, how="all").reset_index(drop=True)
        for name, part in table.groupby("table", sort=False)
    }


def as_linear_tables(rows):
    """Per-run rows (:mod:`.runs`) as the linear study's tables."""
    rows = pd.DataFrame(rows)
    out = {}
    lone = rows[rows["kind"].isin(("thalamic", "cortical"))]
    if len(lone):
        thalamic = lone["kind"] == "thalamic"
        out["lone"] = pd.DataFrame(
            dict(
                kind=lone["kind"],
                index=lone["index"],
                snr_db=lone["snr_db"],
                error_mm=np.where(thalamic, lone["deep_error_mm"], lone["superficial_error_mm"]),
                own_structure=np.where(
                    thalamic,
                    lone["deep_in_thalamus"] == True,  # noqa: E712
                    lone["superficial_in_thalamus"] == False,  # noqa: E712
                ),  # fmt: skip
                dispersion_mm=lone["dispersion_mm"],
            )
        ).reset_index(drop=True)
    nulls = rows[rows["kind"].isin(("noise", "cortical-null"))]
    if len(nulls):
        out["nulls"] = nulls.assign(kind=nulls["kind"].replace({"cortical-null": "cortical"}))[
            ["kind", "index", "snr_db", "level", "ratio_db"]
        ].reset_index(drop=True)
    configs = rows[rows["kind"] == "config"]
    if len(configs):
        columns = ["snr_db", "moment", "level", "ratio_db", "deep_error_mm",
                   "superficial_error_mm", "deep_r"]  # fmt: skip
        out["configurations"] = configs.rename(columns={"index": "config"})[
            ["config", *columns]
        ].reset_index(drop=True)
    return out


def thresholds(nulls):
    """SNR -> the calibrated threshold (:func:`skf_ref.study.detection.null_threshold`)."""
    out = {}
    for snr, group in nulls.groupby("snr_db"):
        kinds = [part["level"].to_numpy() for _, part in group.groupby("kind")]
        out[float(snr)] = null_threshold(*kinds)
    return out


def _median(values):
    values = pd.Series(values, dtype=float).dropna()
    if values.empty:
        return np.nan, np.nan, np.nan, 0
    q1, median, q3 = np.percentile(values, [25, 50, 75])
    return median, q1, q3, len(values)


def _rate(flags):
    flags = np.asarray(flags, dtype=bool)
    k, n = int(flags.sum()), flags.size
    low, high = clopper_pearson(k, n) if n else (np.nan, np.nan)
    return (k / n if n else np.nan), low, high, n


def _lone_rows(lone):
    rows = []
    for (kind, snr), group in lone.groupby(["kind", "snr_db"]):
        rows.append((f"lone_{kind}_error", snr, *_median(group["error_mm"])))
        rows.append((f"lone_{kind}_own", snr, *_rate(group["own_structure"].astype(bool))))
        if "dispersion_mm" in group:
            rows.append((f"lone_{kind}_dispersion", snr, *_median(group["dispersion_mm"])))
        if (
            kind == "cortical"
            and "cross_talk_db" in group
            and group["cross_talk_db"].notna().any()
        ):
            rows.append(("cross_talk_db", snr, *_median(group["cross_talk_db"])))
            rows.append(("cross_talk_within_6db", snr, *_rate(group["cross_talk_db"] > -6.0)))
    return rows


def _detection_rows(nulls, configs, levels):
    rows = []
    for snr, group in configs.groupby("snr_db"):
        tau = levels.get(float(snr), np.nan)
        rows.append(("threshold", snr, tau, np.nan, np.nan, 0))
        null = nulls[nulls["snr_db"] == snr] if nulls is not None else None
        if null is not None:
            for kind, part in null.groupby("kind"):
                rows.append((f"false_{kind}", snr, *_rate(part["level"] > tau)))
        for moment in MOMENTS:
            part = group[group["moment"] == moment]
            if len(part):
                rows.append((f"true_{moment:g}", snr, *_rate(part["level"] > tau)))
        one = group[group["moment"] == MOMENTS[0]]
        if null is not None and len(one):
            cortical = null[null["kind"] == "cortical"]
            for score in ("level", "ratio_db"):
                area, low, high = newcombe_auc(one[score], cortical[score])
                rows.append((f"auc_{score}", snr, area, low, high, len(one) + len(cortical)))
        for name in ("deep_error_mm", "superficial_error_mm", "deep_r"):
            if name in one and one[name].notna().any():
                rows.append((name.removesuffix("_mm"), snr, *_median(one[name])))
    return rows


def summarize(runs, levels):
    """Long summary rows of one method's runs of one set and design.

    Parameters
    ----------
    runs : dict
        ``"lone"``, ``"nulls"``, ``"configurations"`` tables (any of them).
    levels : dict
        SNR -> detection threshold (calibrated on the choice set's nulls).

    Returns
    -------
    pandas.DataFrame
        Columns ``quantity, snr_db, value, low, high, n``.
    """
    rows = []
    if "lone" in runs:
        rows += _lone_rows(runs["lone"])
    if "configurations" in runs:
        rows += _detection_rows(runs.get("nulls"), runs["configurations"], levels)
    return pd.DataFrame(rows, columns=["quantity", "snr_db", "value", "low", "high", "n"])
