"""Statistics over seeds of a sweep table, and the text they are written in.

Pure functions of a sweep table (the rows of :func:`skf_ref.study.sweep.run_sweep`, with
``smoother`` as a label, ``"none"`` for no smoothing); the decision rules, the figures and
the report all read the table through them.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from .settings import CORNERS, NOISE_LEVELS, TIE_MM, TUNING

__all__ = [
    "cell_stats",
    "corner_stats",
    "iqr_text",
    "mean_and_iqr",
    "median_iqr",
    "quartiles",
    "summary_table",
]

#: The columns aggregated over seeds (mean, SE, median and quartiles) in ``summary.csv``.
_SUMMARY_COLUMNS = (
    "score",
    "deep_error_mm",
    "superficial_error_mm",
    "deep_region_db",
    "deep_region_at_superficial_peak_db",
    "echo",
)


def _with_score(table):
    """Add ``score`` = (deep_error_mm + superficial_error_mm) / 2 (mm)."""
    return table.assign(score=(table["deep_error_mm"] + table["superficial_error_mm"]) / 2.0)


def _setting_rows(table, exponent, smoother):
    """The scored rows of one (exponent, smoother) setting, at every noise level and prior."""
    return _with_score(table[(table["exponent"] == exponent) & (table["smoother"] == smoother)])


def _select(table, snr, ep, pm, exponent, smoother):
    """The scored rows of one setting, sorted by seed; ValueError naming it if it has none."""
    rows = table[
        (table["snr_db"] == snr)
        & (table["ep_snr_db"] == ep)
        & (table["pm_snr_db"] == pm)
        & (table["exponent"] == exponent)
        & (table["smoother"] == smoother)
    ]
    if rows.empty:
        raise ValueError(
            f"table has no rows for snr_db={snr:g}, ep_snr_db={ep:g}, pm_snr_db={pm:g}, "
            f"exponent={exponent:g}, smoother={smoother!r}"
        )
    return _with_score(rows.sort_values("seed"))


def _finite(values):
    values = np.asarray(values, dtype=float)
    return values[np.isfinite(values)]


def _mean_se(values):
    """Mean, standard error (ddof 1; NaN for one value) and count of the finite values."""
    values = _finite(values)
    n = values.size
    if n == 0:
        return math.nan, math.nan, 0
    se = float(np.std(values, ddof=1) / np.sqrt(n)) if n > 1 else math.nan
    return float(np.mean(values)), se, n


def quartiles(values):
    """Median, first and third quartiles, and count of the finite values.

    The distribution over seeds that every table of the report shows beside (or instead
    of) the mean: peak errors are grid distances and take two or three values across seeds,
    which a mean ± SE hides. Quartiles interpolate linearly between order statistics
    (numpy's default, as ``pandas.Series.quantile``).

    Parameters
    ----------
    values : array_like, shape (n,)

    Returns
    -------
    median, q1, q3 : float
        NaN if no value is finite.
    n : int
        Finite values.

    Examples
    --------
    >>> quartiles([4.0, 1.0, 3.0, 2.0, 5.0, float("nan")])
    (3.0, 2.0, 4.0, 5)
    """
    values = _finite(values)
    if values.size == 0:
        return math.nan, math.nan, math.nan, 0
    q1, median, q3 = (float(v) for v in np.percentile(values, [25.0, 50.0, 75.0]))
    return median, q1, q3, int(values.size)


def _column_stats(rows):
    """:func:`_mean_se` of every column of :data:`_SUMMARY_COLUMNS` in ``rows``."""
    return {column: _mean_se(rows[column]) for column in _SUMMARY_COLUMNS}


def cell_stats(table, snr, ep, pm, exponent, smoother, column="score"):
    """Mean, standard error and count over seeds of one column at one setting.

    Parameters
    ----------
    table : pandas.DataFrame
        Sweep rows (columns of :func:`skf_ref.study.metrics.summarize` and the grid axes;
        ``smoother`` as a label, ``"none"`` for no smoothing).
    snr, ep, pm, exponent : float
    smoother : str
    column : str
        A metric column, or ``"score"``: (deep_error_mm + superficial_error_mm) / 2.

    Returns
    -------
    mean, se : float
    n : int
        Seeds with a finite value.

    Examples
    --------
    >>> t = pd.DataFrame(dict(snr_db=10.0, ep_snr_db=0.0, pm_snr_db=0.0, exponent=0.5,
    ...     smoother="none", seed=[0, 1], deep_error_mm=[2.0, 4.0],
    ...     superficial_error_mm=[0.0, 2.0]))
    >>> cell_stats(t, 10.0, 0.0, 0.0, 0.5, "none")
    (2.0, 1.0, 2)
    """
    return _mean_se(_select(table, snr, ep, pm, exponent, smoother)[column])


def corner_stats(table, snr, exponent=TUNING[0], smoother=TUNING[1]):
    """Score mean and SE on the 2 x 2 EP/PM grid at one noise level.

    Parameters
    ----------
    table : pandas.DataFrame
    snr : float
    exponent : float
    smoother : str

    Returns
    -------
    pandas.DataFrame
        Index: (EP, PM) in :data:`CORNERS` order; columns ``mean``, ``se``, ``n``.
    """
    stats = [cell_stats(table, snr, ep, pm, exponent, smoother) for ep, pm in CORNERS]
    index = pd.MultiIndex.from_tuples(CORNERS, names=["ep", "pm"])
    return pd.DataFrame(stats, index=index, columns=["mean", "se", "n"])


def _best(stats):
    """Cells (index labels) tied for the lowest mean, in index order."""
    low = stats["mean"].min()
    return [key for key, mean in stats["mean"].items() if mean <= low + TIE_MM]


def _rate(table, snr, ep, pm, exponent, smoother, predicate):
    """Seeds of one setting for which ``predicate(rows)`` holds, and the number of seeds."""
    rows = _select(table, snr, ep, pm, exponent, smoother)
    return int(predicate(rows).astype(bool).sum()), len(rows)


def _separated(rows):
    return rows["separation"]


def _fine_means(table, values, exponent, smoother):
    """Mean score per noise level as arrays (len(PM values), len(EP values))."""
    means = _setting_rows(table, exponent, smoother)
    means = means.groupby(["snr_db", "pm_snr_db", "ep_snr_db"])["score"].mean()
    return {
        snr: np.array([[means.loc[snr, pm, ep] for ep in values] for pm in values])
        for snr in NOISE_LEVELS
    }


def summary_table(paper, fine):
    """Per-setting aggregates over seeds of both sweeps (the ``summary.csv`` of the report).

    Parameters
    ----------
    paper, fine : pandas.DataFrame

    Returns
    -------
    pandas.DataFrame
        One row per (sweep, snr_db, ep_snr_db, pm_snr_db, exponent, smoother): ``n``, mean,
        SE, median and first and third quartiles (``_q1``, ``_q3``, :func:`quartiles`) of
        each of score, peak errors, region levels and echo, and the fraction of seeds with
        deep detected and with separation.
    """
    keys = ["snr_db", "ep_snr_db", "pm_snr_db", "exponent", "smoother"]
    frames = []
    for name, table in (("paper_grid", paper), ("fine_grid", fine)):
        scored = _with_score(table.sort_values([*keys, "seed"]))
        for key, rows in scored.groupby(keys, sort=True):
            record = dict(sweep=name, **dict(zip(keys, key, strict=True)), n=len(rows))
            for column, (mean, se, _) in _column_stats(rows).items():
                record[f"{column}_mean"], record[f"{column}_se"] = mean, se
                median, q1, q3, _ = quartiles(rows[column])
                record[f"{column}_median"], record[f"{column}_q1"] = median, q1
                record[f"{column}_q3"] = q3
            for column in ("deep_detected", "separation"):
                record[f"{column}_rate"] = float(rows[column].astype(bool).mean())
            frames.append(record)
    return pd.DataFrame(frames)


# --------------------------------------------------------------------------- text


def _fmt(value, digits=1):
    """Fixed-point text without a negative zero ("-0.0" reads as a sign that is not there)."""
    if not math.isfinite(value):
        return "n/a"
    text = f"{value:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text


def _pm(mean, se, digits=1):
    """``mean ± se`` in fixed point, or "n/a" for an undefined mean."""
    if not math.isfinite(mean):
        return "n/a"
    return f"{_fmt(mean, digits)} ± {_fmt(se, digits)}"


def iqr_text(median, q1, q3, digits=1):
    """``median [Q1, Q3]`` in fixed point, or "n/a" for an undefined median.

    Examples
    --------
    >>> iqr_text(3.0, 2.0, 4.25, digits=2)
    '3.00 [2.00, 4.25]'
    """
    if not math.isfinite(median):
        return "n/a"
    return f"{_fmt(median, digits)} [{_fmt(q1, digits)}, {_fmt(q3, digits)}]"


def median_iqr(values, digits=1):
    """``median [Q1, Q3]`` of the finite values (:func:`quartiles`, :func:`iqr_text`).

    Examples
    --------
    >>> median_iqr([10.0, 12.0, 12.0, 30.0])
    '12.0 [11.5, 16.5]'
    """
    return iqr_text(*quartiles(values)[:3], digits=digits)


def mean_and_iqr(values, digits=1):
    """``mean ± SE`` (what the v1 and v2 rules read) over ``median [Q1, Q3]``.

    The two lines of one cell of a Markdown table (``<br>`` between them).

    Examples
    --------
    >>> mean_and_iqr([10.0, 12.0, 12.0, 30.0])
    '16.0 ± 4.7<br>12.0 [11.5, 16.5]'
    """
    return f"{_pm(*_mean_se(values)[:2], digits)}<br>{median_iqr(values, digits)}"


def _cell(key):
    """An (EP, PM) cell as text."""
    return f"(EP {key[0]:g}, PM {key[1]:g})"


def _setting_label(exponent, smoother):
    """An (exponent, smoother) setting as text."""
    if smoother == "none":
        return f"no smoothing, exponent {exponent:g}"
    return f"{smoother}, exponent {exponent:g}"
