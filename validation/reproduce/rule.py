"""Section 6: the summaries a criterion reads, the success criteria, the default."""

from __future__ import annotations

import numpy as np
import pandas as pd

from .design import DESIGNS, MINIMUM_NORM

#: Lower is better for these; higher for the rest.
LOWER = ("deep error", "superficial error", "EMD", "latency", "left error", "right error",
         "lone thalamic error", "lone cortical error", "lone thalamic EMD",
         "lone cortical EMD")  # fmt: skip
#: (metric, margin) per design kind; the latency margin is 10 % of the deep support (ms).
CRITERIA = {
    "pair": (("deep error", 5.0), ("superficial error", 5.0), ("EMD", 5.0), ("detection", 0.10),
             ("latency", None), ("r", 0.05)),
    "two": (("left error", 5.0), ("right error", 5.0), ("EMD", 5.0)),
    "lone": (("lone thalamic error", 5.0), ("lone cortical error", 5.0)),
}  # fmt: skip
REFERENCES = tuple(f"{m}, lambda2 matched" for m in MINIMUM_NORM)


def thresholds(rows):
    """Each method's detection threshold per condition and design, from the choice nulls."""
    nulls = rows[(rows["set"] == "choice") & rows["kind"].isin(["noise null", "cortical null"])]
    q95 = nulls.groupby(["method", "condition", "design", "kind"])["S"].quantile(
        0.95, interpolation="higher"
    )
    return q95.groupby(["method", "condition", "design"]).max().rename("threshold")


def with_detection(rows, limits):
    """Rows of configurations with ``detected`` (S above the method's threshold)."""
    out = rows.join(limits, on=["method", "condition", "design"])
    out["detection"] = np.where(out["threshold"].notna(), out["S"] > out["threshold"], np.nan)
    return out


def summarize(rows, by=("set", "design", "method")):
    """Medians of every metric and the detection rate, per group (configurations, lone, two)."""
    runs = rows[~rows["kind"].isin(["noise null", "cortical null"])]
    metrics = [c for c in (*LOWER, "r", "detection") if c in runs]
    return runs.groupby(list(by))[metrics].agg(
        lambda v: (
            np.nan
            if v.notna().sum() == 0
            else float(np.nanmedian(v))
            if v.name != "detection"
            else float(np.nanmean(v))
        )
    )


def reference(summary, design):
    """The best of MNE's four methods at the matched lambda2, metric by metric."""
    ref = summary.loc[design].loc[list(REFERENCES)]
    return pd.Series(
        {c: ref[c].min() if c in LOWER else ref[c].max() for c in ref.columns}, name="reference"
    )


def criteria(row, ref, design):
    """``{metric: met}`` of one method against the reference in a design."""
    spec = DESIGNS[design]
    met = {}
    for metric, margin in CRITERIA[spec.kind]:
        if metric == "latency":
            margin = 0.1 * spec.support_s * 1e3
        value, best = row[metric], ref[metric]
        if metric in LOWER:
            met[metric] = bool(value <= best + margin)
        else:
            met[metric] = bool(value >= best - margin)
    return met


def headline_error(summary, design, method):
    """The error the rule ranks by: deep, mean of left and right, lone thalamic."""
    row = summary.loc[(design, method)]
    kind = DESIGNS[design].kind
    if kind == "pair":
        return row["deep error"]
    if kind == "two":
        return 0.5 * (row["left error"] + row["right error"])
    return row["lone thalamic error"]


def judge(summary, label):
    """``{design: all criteria met}`` of one method (a candidate or not) on a summary."""
    designs = [d for d in DESIGNS if (d, label) in summary.index]
    return {d: all(criteria(summary.loc[(d, label)], reference(summary, d), d).values())
            for d in designs}  # fmt: skip


def choose(summary, candidates):
    """The rule: the default, and the table of every candidate's criteria per design.

    Parameters
    ----------
    summary : DataFrame
        :func:`summarize` of the choice set, indexed by (design, method).
    candidates : sequence of Setting

    Returns
    -------
    default : Setting
    table : DataFrame
        Per candidate: designs met, the mean error, and per design whether all criteria hold.
    """
    designs = [d for d in DESIGNS if d in summary.index.get_level_values(0)]
    refs = {d: reference(summary, d) for d in designs}
    rows = []
    for setting in candidates:
        met = {d: all(criteria(summary.loc[(d, setting.label)], refs[d], d).values())
               for d in designs}  # fmt: skip
        error = float(np.mean([headline_error(summary, d, setting.label) for d in designs]))
        rows.append(dict(method=setting.label, designs_met=sum(met.values()), mean_error=error,
                         **met, _setting=setting))  # fmt: skip
    table = pd.DataFrame(rows)
    order = sorted(
        range(len(rows)),
        key=lambda k: (-rows[k]["designs_met"], rows[k]["mean_error"],
                       rows[k]["_setting"].simplicity),
    )  # fmt: skip
    default = rows[order[0]]["_setting"]
    return default, table.drop(columns="_setting").iloc[order].reset_index(drop=True)
