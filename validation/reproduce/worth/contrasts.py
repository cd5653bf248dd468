"""The named contrasts: paired by thalamic position, Wilcoxon, Holm (pre-registration §9).

Each contrast compares two linear methods on the scored set, design D1, on five metrics at
each SNR. A metric's difference (first method minus second) is taken run by run (the same
source, or configuration, and noise), averaged over the runs of each thalamic grid position,
and the position means are tested.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .design import SNRS
from .intervals import holm, median_interval, wilcoxon_p

__all__ = ["METRICS", "contrast_table", "paired_values"]

#: Metric -> (table, column, better): "lower" or "higher".
METRICS = {
    "lone thalamic error (mm)": ("lone", "error_mm", "lower"),
    "deep error (mm)": ("configurations", "deep_error_mm", "lower"),
    "superficial error (mm)": ("configurations", "superficial_error_mm", "lower"),
    "deep time-course r": ("configurations", "deep_r", "higher"),
    "detection at 1x": ("configurations", "detected", "higher"),
}


def paired_values(runs, threshold, metric, snr):
    """One method's values of a metric at an SNR, indexed by run, with their positions.

    Returns
    -------
    pandas.DataFrame
        Index: the run (source or configuration); columns ``value`` and ``position``.
    """
    table, column, _ = METRICS[metric]
    data = runs[table]
    data = data[data["snr_db"] == snr]
    if table == "lone":
        data = data[data["kind"] == "thalamic"].set_index("index")
    else:
        data = data[data["moment"] == 1.0].set_index("config")
    if column == "detected":
        values = (data["level"] > threshold[snr]).astype(float)
    else:
        values = data[column].astype(float)
    return pd.DataFrame(dict(value=values, position=data["position"]))


def _one(first, second, metric, snr):
    a = paired_values(*first, metric, snr)
    b = paired_values(*second, metric, snr)
    joined = a.join(b, lsuffix="_a", rsuffix="_b", how="inner")
    difference = joined["value_a"] - joined["value_b"]
    per_position = difference.groupby(joined["position_a"]).mean()
    median, low, high = median_interval(per_position.to_numpy())
    return dict(
        first=float(np.nanmedian(joined["value_a"])) if metric != "detection at 1x"
        else float(joined["value_a"].mean()),
        second=float(np.nanmedian(joined["value_b"])) if metric != "detection at 1x"
        else float(joined["value_b"].mean()),
        units=int(per_position.notna().sum()),
        difference=median,
        low=low,
        high=high,
        p=wilcoxon_p(per_position.to_numpy()),
    )  # fmt: skip


def contrast_table(contrasts, runs, thresholds):
    """Every named contrast on every metric and SNR, with Holm-adjusted p-values.

    Parameters
    ----------
    contrasts : list of (name, first key, second key)
        Duplicated pairs are tested once (the first name is kept, the others noted).
    runs : dict
        Method key -> its scored D1 runs (``lone`` and ``configurations`` tables).
    thresholds : dict
        Method key -> SNR -> its calibrated threshold.

    Returns
    -------
    pandas.DataFrame
    """
    rows, seen = [], {}
    for name, first, second in contrasts:
        if (first, second) in seen:
            seen[first, second].append(name)
            continue
        seen[first, second] = [name]
        for metric in METRICS:
            for snr in SNRS:
                result = _one(
                    (runs[first], thresholds[first]), (runs[second], thresholds[second]),
                    metric, snr,
                )  # fmt: skip
                rows.append(dict(contrast=name, a=first, b=second, metric=metric,
                                 snr_db=snr, **result))  # fmt: skip
    table = pd.DataFrame(rows)
    table["p_holm"] = holm(table["p"].to_numpy())
    table["also"] = table.apply(lambda r: ", ".join(seen[r["a"], r["b"]][1:]), axis=1)
    return table
