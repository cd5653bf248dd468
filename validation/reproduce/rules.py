"""The decision rules of the six findings of docs/model.md §7.

Each rule is a pure function of the paper-grid sweep table that returns a :class:`Finding`:
the criteria it checked, the numbers it used and its verdict. The rules were fixed before
any number was computed; the report states them in words before any result.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from skf_ref.study.regions import DYNAMIC_RANGE_DB as DETECTION_DB

from .settings import (
    EXPONENTS,
    NOISE_LEVELS,
    RANKED_EXPONENTS,
    SMOOTHED,
    TUNED_PRIOR,
    TUNING,
    VERDICTS,
)
from .stats import _best, _cell, _fmt, _pm, _rate, _separated, cell_stats, corner_stats

__all__ = [
    "RULES",
    "Finding",
    "evaluate",
    "rule_f1",
    "rule_f2",
    "rule_f3",
    "rule_f4",
    "rule_f5",
    "rule_f6",
    "verdict",
]


@dataclass(frozen=True)
class Finding:
    """One finding of docs/model.md §7 as judged by its decision rule.

    Attributes
    ----------
    number : int
    paper : str
        What the paper says.
    measured : str
        The numbers the rule used (Markdown, ``<br>`` between parts).
    criteria : tuple of (str, bool)
        Each criterion of the rule and whether it holds.
    verdict : str
        One of :data:`VERDICTS`.
    """

    number: int
    paper: str
    measured: str
    criteria: tuple
    verdict: str


def verdict(flags):
    """The verdict of flags: "reproduced" if all hold, "partly" if some do, else "not ...".

    Parameters
    ----------
    flags : sequence of bool

    Returns
    -------
    str

    Examples
    --------
    >>> verdict([True, True]), verdict([True, False]), verdict([False, False])
    ('reproduced', 'partly', 'not reproduced')
    """
    flags = [bool(f) for f in flags]
    return VERDICTS[0] if all(flags) else VERDICTS[1] if any(flags) else VERDICTS[2]


def _yes(flag):
    return "yes" if flag else "no"


def _criteria_text(criteria):
    return "<br>".join(
        f"({chr(97 + i)}) {text}: {_yes(ok)}" for i, (text, ok) in enumerate(criteria)
    )


def _finding(number, paper, measured, criteria, result=None):
    """A Finding whose verdict, unless given, is :func:`verdict` of its criteria."""
    if result is None:
        result = verdict([ok for _, ok in criteria])
    return Finding(number, paper, measured, criteria, result)


def _corner_finding(number, paper, stats, criteria, result=None):
    """A finding on the 2 x 2 prior grid: the cell scores, the best cell and the criteria."""
    parts = [f"{_cell(key)} {_pm(row['mean'], row['se'])}" for key, row in stats.iterrows()]
    best = " = ".join(_cell(key) for key in _best(stats))
    measured = f"score (mm, n={int(stats['n'].min())}): " + ", ".join(parts) + f"<br>best: {best}"
    return _finding(number, paper, measured + "<br>" + _criteria_text(criteria), criteria, result)


def _level_finding(number, paper, name, check):
    """A finding judged at each noise level: ``check(snr)`` gives (holds, measured text)."""
    checks = [check(snr) for snr in NOISE_LEVELS]
    criteria = tuple(
        (f"{name} at {snr:g} dB", ok) for snr, (ok, _) in zip(NOISE_LEVELS, checks, strict=True)
    )
    return _finding(number, paper, "<br>".join(text for _, text in checks), criteria)


def rule_f1(table):
    """F1, 10 dB: best at (EP 0, PM 0); raising EP costs more than raising PM.

    Parameters
    ----------
    table : pandas.DataFrame
        Sweep rows; needs the tuning setting (exponent 0.5, no smoothing) at 10 dB.

    Returns
    -------
    Finding
    """
    stats = corner_stats(table, 10.0)
    base = stats.loc[(0.0, 0.0), "mean"]
    cost_ep = stats.loc[(20.0, 0.0), "mean"] - base
    cost_pm = stats.loc[(0.0, 20.0), "mean"] - base
    criteria = (
        ("best cell is (EP 0, PM 0)", _best(stats) == [(0.0, 0.0)]),
        (f"EP cost {cost_ep:+.1f} mm > PM cost {cost_pm:+.1f} mm", bool(cost_ep > cost_pm)),
    )
    return _corner_finding(
        1,
        "10 dB: best at EP 0, PM 0 of {0, 20}²; raising EP hurts more than raising PM",
        stats,
        criteria,
    )


def _spread(stats):
    return float(stats["mean"].max() - stats["mean"].min())


def rule_f2(table):
    """F2, 20 dB: best at (EP 0, PM 0), and less sensitive to the priors than at 10 dB.

    Parameters
    ----------
    table : pandas.DataFrame
        Needs the tuning setting at 10 and 20 dB.

    Returns
    -------
    Finding
    """
    stats = corner_stats(table, 20.0)
    spread_20, spread_10 = _spread(stats), _spread(corner_stats(table, 10.0))
    criteria = (
        ("best cell is (EP 0, PM 0)", _best(stats) == [(0.0, 0.0)]),
        (
            f"spread (max - min) {spread_20:.1f} mm at 20 dB < {spread_10:.1f} mm at 10 dB",
            bool(spread_20 < spread_10),
        ),
    )
    return _corner_finding(
        2, "20 dB: same pattern (best at EP 0, PM 0), less sensitive", stats, criteria
    )


def rule_f3(table):
    """F3, 30 dB: best at (EP 20, PM 0) or (EP 0, PM 20).

    Reproduced if every cell tied for the lowest mean is one of the two; partly if not, but
    one of the two has a mean within one SE (of the best cell) of the lowest mean.

    Parameters
    ----------
    table : pandas.DataFrame
        Needs the tuning setting at 30 dB.

    Returns
    -------
    Finding
    """
    stats = corner_stats(table, 30.0)
    targets = [(20.0, 0.0), (0.0, 20.0)]
    best = _best(stats)
    low, low_se = stats.loc[best[0], "mean"], stats.loc[best[0], "se"]
    best_ok = all(key in targets for key in best)
    near = [k for k in targets if stats.loc[k, "mean"] - low <= (low_se if low_se > 0 else 0)]
    criteria = (
        ("best cell is (EP 20, PM 0) or (EP 0, PM 20)", best_ok),
        (f"one of them within one SE ({low_se:.1f} mm) of the best", bool(near)),
    )
    result = VERDICTS[0] if best_ok else VERDICTS[1] if near else VERDICTS[2]
    return _corner_finding(
        3, "30 dB: best at (EP 20, PM 0) or (EP 0, PM 20)", stats, criteria, result
    )


def rule_f4(table):
    """F4: an echo of the deep source at the superficial peak, without smoothing.

    At each noise level's best tuning cell (ties broken in :data:`CORNERS` order) the echo
    is present if its mean over seeds minus two standard errors is above zero.

    Parameters
    ----------
    table : pandas.DataFrame
        Needs the tuning setting at every noise level.

    Returns
    -------
    Finding
    """

    def echo(snr):
        ep, pm = _best(corner_stats(table, snr))[0]
        mean, se, n = cell_stats(table, snr, ep, pm, *TUNING, column="echo")
        present = bool(n > 1 and mean - 2.0 * se > 0.0)
        return present, (
            f"{snr:g} dB {_cell((ep, pm))}: echo {_pm(mean, se, 3)} (n={n}), "
            f"present: {_yes(present)}"
        )

    return _level_finding(
        4,
        "without smoothing, an echo of the deep source at the superficial peak at every "
        "noise level",
        "echo",
        echo,
    )


def _f5_suppression(table, ep, pm):
    """Criterion (a) of F5: smoothing lowers the deep region level at 1.5 ms."""
    lower, parts = 0, []
    for exponent in EXPONENTS:
        plain = cell_stats(table, 30.0, ep, pm, exponent, "none", "deep_region_db")[0]
        smooth = cell_stats(table, 30.0, ep, pm, exponent, SMOOTHED[1], "deep_region_db")[0]
        lower += int(smooth < plain)
        parts.append(f"{exponent:g}: {_fmt(plain)} → {_fmt(smooth)}")
    text = f"deep region at 1.5 ms (dB re. max), none → smoothed, by exponent: {'; '.join(parts)}"
    return (
        f"lower smoothed for {lower} of {len(EXPONENTS)} exponents",
        2 * lower > len(EXPONENTS),
    ), text


def rule_f5(table):
    """F5 (30 dB, EP 20, PM 0): smoothing suppresses deep; 1.25 best; 1 too low; 1.5 too high.

    Parameters
    ----------
    table : pandas.DataFrame
        Needs every exponent with and without "rts-standardized" at 30 dB, EP 20, PM 0.

    Returns
    -------
    Finding
    """
    ep, pm = TUNED_PRIOR
    high, n15 = _rate(
        table,
        30.0,
        ep,
        pm,
        1.5,
        SMOOTHED[1],
        lambda r: r["deep_region_at_superficial_peak_db"] > -DETECTION_DB,
    )
    return _f5_finding(
        table,
        (f"exponent 1.5: deep within 6 dB at 2.5 ms in {high}/{n15} seeds", 2 * high > n15),
    )


def _f5_finding(table, overemphasis):
    """F5 from criteria (a)-(c), the same in v1 and v2, and the rule's own (d)."""
    ep, pm = TUNED_PRIOR
    smoother = SMOOTHED[1]
    suppression, suppression_text = _f5_suppression(table, ep, pm)
    scores = pd.DataFrame(
        [cell_stats(table, 30.0, ep, pm, e, smoother) for e in RANKED_EXPONENTS],
        index=list(RANKED_EXPONENTS),
        columns=["mean", "se", "n"],
    )
    missed, n1 = _rate(
        table, 30.0, ep, pm, 1.0, smoother, lambda r: ~r["deep_detected"].astype(bool)
    )
    criteria = (
        suppression,
        ("best exponent of 1, 1.25, 1.5 is 1.25", _best(scores) == [1.25]),
        (f"exponent 1: deep not detected in {missed}/{n1} seeds", 2 * missed > n1),
        overemphasis,
    )
    score_text = ", ".join(f"{e:g}: {_pm(r['mean'], r['se'])}" for e, r in scores.iterrows())
    return _finding(
        5,
        "smoothing suppresses deep activity; of exponents 1, 1.25, 1.5, 1.25 is best; "
        "1 suppresses the deep peak, 1.5 overemphasizes it",
        f"{suppression_text}<br>smoothed score (mm) by exponent: {score_text}<br>"
        + _criteria_text(criteria),
        criteria,
    )


def rule_f6(table):
    """F6 (exponent 1.25, EP 20, PM 0): smoothing separates the sources at every noise level.

    Parameters
    ----------
    table : pandas.DataFrame
        Needs exponent 1.25 at EP 20, PM 0 with and without "rts-standardized".

    Returns
    -------
    Finding
    """
    ep, pm = TUNED_PRIOR
    exponent, smoother = SMOOTHED

    def separation(snr):
        smooth, n = _rate(table, snr, ep, pm, exponent, smoother, _separated)
        plain, n_plain = _rate(table, snr, ep, pm, exponent, "none", _separated)
        ok = bool(2 * smooth >= n and smooth / n > plain / n_plain)
        return ok, (
            f"{snr:g} dB: separated in {smooth}/{n} seeds smoothed vs {plain}/{n_plain} "
            f"not smoothed: {_yes(ok)}"
        )

    return _level_finding(
        6,
        "smoothing with exponent 1.25 (EP 20, PM 0) suppresses the residual deep activity at "
        "the superficial peak at all noise levels: clear separation",
        "separation",
        separation,
    )


RULES = (rule_f1, rule_f2, rule_f3, rule_f4, rule_f5, rule_f6)


def evaluate(table):
    """Apply every decision rule to a sweep table.

    Parameters
    ----------
    table : pandas.DataFrame
        The paper-grid sweep rows.

    Returns
    -------
    list of Finding
        F1 .. F6.
    """
    return [rule(table) for rule in RULES]
