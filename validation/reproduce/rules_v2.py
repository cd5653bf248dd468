"""The v2 decision rules: the v1 rules read against the controls, with margins.

Written and committed before any v2 number was computed; the v1 rules
(:mod:`validation.reproduce.rules`) stay as they are and both are reported side by side.
What changes (docs/model.md §7 for the findings):

- **F1 (b)** holds only when raising EP costs more than raising PM by more than one standard
  error of the paired per-seed difference score(EP 20, PM 0) - score(EP 0, PM 20) (same
  seeds, same noise); within one SE it is a tie, which does not hold.
- **F2 (b)** compares *relative* spreads, (max - min) / mean of the four cell means (the
  errors saturate near the head's size at 10 dB, which shrinks absolute spreads), and holds
  only when the 10 dB spread exceeds the 20 dB spread by more than one jackknife standard
  error over seeds.
- **F3** is judged by three measures side by side: (a) the localization score (as v1's
  first criterion), (b) the time-course correlation, the mean of ``deep_corr`` and
  ``superficial_corr`` (higher is better), and (c) the innovation log-likelihood of the data
  under the priors (higher is better). Each holds when its best cell is (EP 20, PM 0) or
  (EP 0, PM 20).
- **F4, F5 (d), F6**: the deep region's level at the superficial peak is measured against
  the superficial-only control (same head, priors, seed and noise; the deep source left out
  of the data). The *deep excess* of a run is

  ``(D(2.5) - S(2.5)) / D(1.5) - r``

  with ``D`` the deep region's maximum in the run, ``S`` its maximum in the control, and
  ``r`` the true ratio of the deep waveform at the two peaks (0.25): what the deep region
  holds at 2.5 ms beyond the superficial source's spread, relative to its own peak, minus
  what the deep source truly does then. F4: the echo is present where the mean excess minus
  two SE is above zero. F5 (d): exponent 1.5 overemphasizes the deep source where the excess
  is positive in the majority of seeds. F6: a seed is separated when the deep source is
  detected at 1.5 ms, the superficial at 2.5 ms, and the excess is at most zero.
- F5 (a)-(c) are v1's.

The rules are pure functions of the paper-grid table and the control tables
(:func:`evaluate_v2`), checked on hand-made tables in ``tests/test_rules_v2.py``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .rules import _corner_finding, _criteria_text, _f5_finding, _finding, _level_finding
from .settings import CORNERS, SMOOTHED, TUNED_PRIOR, TUNING
from .stats import _best, _cell, _fmt, _mean_se, _pm, _select, cell_stats, corner_stats

__all__ = [
    "RULES_V2",
    "deep_excess",
    "evaluate_v2",
    "rule_v2_f1",
    "rule_v2_f2",
    "rule_v2_f3",
    "rule_v2_f4",
    "rule_v2_f5",
    "rule_v2_f6",
]

#: Columns that identify a run across a table and its controls.
_RUN = ["snr_db", "ep_snr_db", "pm_snr_db", "exponent", "smoother", "seed"]


def deep_excess(table, control, snr, ep, pm, exponent, smoother):
    """Per seed, the deep excess of the runs of one setting against the control.

    Parameters
    ----------
    table : pandas.DataFrame
        Runs with both sources: ``deep_max_at_deep_peak``,
        ``deep_max_at_superficial_peak`` and ``echo`` (for the true ratio).
    control : pandas.DataFrame
        The superficial-only runs of the same settings and seeds.
    snr, ep, pm, exponent : float
    smoother : str

    Returns
    -------
    pandas.DataFrame
        Indexed by seed: ``excess``, ``spread_share`` (the control's deep-region maximum at
        2.5 ms over the run's) and the run's other columns.

    Examples
    --------
    >>> run = pd.DataFrame(dict(snr_db=10.0, ep_snr_db=0.0, pm_snr_db=0.0, exponent=0.5,
    ...     smoother="none", seed=[0], deep_error_mm=0.0, superficial_error_mm=0.0,
    ...     deep_max_at_deep_peak=2.0, deep_max_at_superficial_peak=1.5, echo=0.5))
    >>> control = run.assign(deep_max_at_superficial_peak=1.0)
    >>> deep_excess(run, control, 10.0, 0.0, 0.0, 0.5, "none")["excess"].tolist()
    [0.0]
    """
    rows = _select(table, snr, ep, pm, exponent, smoother).set_index("seed")
    ctrl = _select(control, snr, ep, pm, exponent, smoother).set_index("seed")
    missing = sorted(set(rows.index) - set(ctrl.index))
    if missing:
        raise ValueError(
            f"the control lacks seeds {missing} of snr_db={snr:g}, ep_snr_db={ep:g}, "
            f"pm_snr_db={pm:g}, exponent={exponent:g}, smoother={smoother!r}"
        )
    ctrl = ctrl.loc[rows.index]
    d15, d25 = rows["deep_max_at_deep_peak"], rows["deep_max_at_superficial_peak"]
    true_ratio = d25 / d15 - rows["echo"]
    s25 = ctrl["deep_max_at_superficial_peak"]
    return rows.assign(excess=(d25 - s25) / d15 - true_ratio, spread_share=s25 / d25)


def _judged(mean, se):
    """+1 above one SE, -1 below minus one SE, 0 a tie (the v2 margin)."""
    if not np.isfinite(mean):
        return 0
    margin = se if np.isfinite(se) else 0.0
    return 1 if mean > margin else -1 if mean < -margin else 0


_WORDS = {1: "", 0: " (a tie within one SE)", -1: ""}


def rule_v2_f1(table):
    """F1 v2 (10 dB): best at (EP 0, PM 0); EP costs more than PM by more than one SE.

    Parameters
    ----------
    table : pandas.DataFrame

    Returns
    -------
    Finding
    """
    stats = corner_stats(table, 10.0)
    ep_rows = _select(table, 10.0, 20.0, 0.0, *TUNING).set_index("seed")["score"]
    pm_rows = _select(table, 10.0, 0.0, 20.0, *TUNING).set_index("seed")["score"]
    mean, se, _ = _mean_se((ep_rows - pm_rows).dropna())
    judged = _judged(mean, se)
    criteria = (
        ("best cell is (EP 0, PM 0)", _best(stats) == [(0.0, 0.0)]),
        (
            f"EP cost - PM cost = score(EP 20, PM 0) - score(EP 0, PM 20) = "
            f"{_pm(mean, se)} mm (paired over seeds) > one SE{_WORDS[judged]}",
            judged == 1,
        ),
    )
    return _corner_finding(
        1,
        "10 dB: best at EP 0, PM 0 of {0, 20}²; raising EP hurts more than raising PM",
        stats,
        criteria,
    )


def _relative_spread(table, snr, seeds=None):
    """(max - min) / mean of the four tuning cell means at one noise level."""
    rows = table if seeds is None else table[table["seed"].isin(seeds)]
    means = corner_stats(rows, snr)["mean"]
    return float((means.max() - means.min()) / means.mean())


def rule_v2_f2(table):
    """F2 v2 (20 dB): best at (EP 0, PM 0); smaller relative spread than at 10 dB by one SE.

    Parameters
    ----------
    table : pandas.DataFrame

    Returns
    -------
    Finding
    """
    stats = corner_stats(table, 20.0)
    spread_10, spread_20 = _relative_spread(table, 10.0), _relative_spread(table, 20.0)
    seeds = sorted(set(table["seed"]))
    leave_one_out = np.array(
        [
            _relative_spread(table, 10.0, kept) - _relative_spread(table, 20.0, kept)
            for kept in ([s for s in seeds if s != out] for out in seeds)
        ]
    )
    n = len(seeds)
    se = float(np.sqrt((n - 1) / n * np.sum((leave_one_out - leave_one_out.mean()) ** 2)))
    judged = _judged(spread_10 - spread_20, se)
    criteria = (
        ("best cell is (EP 0, PM 0)", _best(stats) == [(0.0, 0.0)]),
        (
            f"relative spread (max - min) / mean {spread_20:.2f} at 20 dB < {spread_10:.2f} at "
            f"10 dB by more than one jackknife SE ({se:.2f}){_WORDS[judged]}",
            judged == 1,
        ),
    )
    return _corner_finding(
        2, "20 dB: same pattern (best at EP 0, PM 0), less sensitive", stats, criteria
    )


def _measure_stats(table, snr, column):
    """Mean, SE, n of a column (or the mean correlation, ``"corr"``) on the tuning corners."""
    out = []
    for ep, pm in CORNERS:
        rows = _select(table, snr, ep, pm, *TUNING)
        values = (
            (rows["deep_corr"] + rows["superficial_corr"]) / 2
            if column == "corr"
            else rows[column]
        )
        out.append(_mean_se(values))
    index = pd.MultiIndex.from_tuples(CORNERS, names=["ep", "pm"])
    return pd.DataFrame(out, index=index, columns=["mean", "se", "n"])


def _highest(stats, tie):
    top = stats["mean"].max()
    return [key for key, mean in stats["mean"].items() if mean >= top - tie]


def rule_v2_f3(table):
    """F3 v2 (30 dB): the best cell by score, correlation and log-likelihood, side by side.

    Parameters
    ----------
    table : pandas.DataFrame
        Needs ``log_likelihood``, ``deep_corr``, ``superficial_corr`` besides the errors.

    Returns
    -------
    Finding
    """
    targets = [(20.0, 0.0), (0.0, 20.0)]
    score = corner_stats(table, 30.0)
    corr = _measure_stats(table, 30.0, "corr")
    loglik = _measure_stats(table, 30.0, "log_likelihood")
    bests = {
        "localization score (lowest)": _best(score),
        "time-course correlation (highest)": _highest(corr, 1e-9),
        "log-likelihood (highest)": _highest(loglik, 1e-6),
    }
    criteria = tuple(
        (
            f"best by {name}, {' = '.join(_cell(k) for k in best)}, is (EP 20, PM 0) or "
            "(EP 0, PM 20)",
            all(key in targets for key in best),
        )
        for name, best in bests.items()
    )

    def values(stats, digits):
        return ", ".join(
            f"{_cell(key)} {_pm(row['mean'], row['se'], digits)}" for key, row in stats.iterrows()
        )

    measured = (
        f"score (mm): {values(score, 1)}<br>correlation: {values(corr, 2)}<br>"
        f"log-likelihood: {values(loglik, 0)}<br>" + _criteria_text(criteria)
    )
    return _finding(3, "30 dB: best at (EP 20, PM 0) or (EP 0, PM 20)", measured, criteria)


def rule_v2_f4(table, controls):
    """F4 v2: the deep excess over the superficial-only control, at each best tuning cell.

    Parameters
    ----------
    table : pandas.DataFrame
    controls : dict
        ``"superficial"`` (required) and ``"deep"`` (reported if present) control tables.

    Returns
    -------
    Finding
    """

    def echo(snr):
        ep, pm = _best(corner_stats(table, snr))[0]
        joined = deep_excess(table, controls["superficial"], snr, ep, pm, *TUNING)
        mean, se, n = _mean_se(joined["excess"])
        share = _mean_se(joined["spread_share"])[0]
        present = bool(n > 1 and mean - 2.0 * se > 0.0)
        text = (
            f"{snr:g} dB {_cell((ep, pm))}: deep excess {_pm(mean, se, 3)} (n={n}), "
            f"superficial-only control holds {100 * share:.0f} % of the deep region's level at "
            f"2.5 ms"
        )
        if "deep" in controls:
            alone = cell_stats(controls["deep"], snr, ep, pm, *TUNING, column="echo")
            text += f"; deep-only echo {_pm(alone[0], alone[1], 3)}"
        return present, f"{text}; present: {'yes' if present else 'no'}"

    return _level_finding(
        4,
        "without smoothing, an echo of the deep source at the superficial peak at every "
        "noise level",
        "deep excess",
        echo,
    )


def rule_v2_f5(table, controls):
    """F5 v2 (30 dB, EP 20, PM 0): v1's (a)-(c); (d) against the superficial-only control.

    Parameters
    ----------
    table : pandas.DataFrame
    controls : dict
        Needs ``"superficial"``.

    Returns
    -------
    Finding
    """
    ep, pm = TUNED_PRIOR
    excess = deep_excess(table, controls["superficial"], 30.0, ep, pm, 1.5, SMOOTHED[1])
    high, n15 = int((excess["excess"] > 0).sum()), len(excess)
    return _f5_finding(
        table,
        (
            f"exponent 1.5: deep excess over the superficial-only control > 0 in {high}/{n15} "
            f"seeds (mean {_fmt(excess['excess'].mean(), 3)})",
            2 * high > n15,
        ),
    )


def _separated_v2(joined):
    return (
        joined["deep_detected"].astype(bool)
        & joined["superficial_detected"].astype(bool)
        & (joined["excess"] <= 0.0)
    )


def rule_v2_f6(table, controls):
    """F6 v2 (exponent 1.25, EP 20, PM 0): separation with the residual against the control.

    Parameters
    ----------
    table : pandas.DataFrame
    controls : dict
        Needs ``"superficial"``.

    Returns
    -------
    Finding
    """
    ep, pm = TUNED_PRIOR
    exponent, smoother = SMOOTHED

    def separation(snr):
        counts = {}
        for label in (smoother, "none"):
            joined = deep_excess(table, controls["superficial"], snr, ep, pm, exponent, label)
            counts[label] = (int(_separated_v2(joined).sum()), len(joined), joined)
        (smooth, n, joined), (plain, n_plain, _) = counts[smoother], counts["none"]
        ok = bool(2 * smooth >= n and smooth / n > plain / n_plain)
        residual = _mean_se(joined["deep_region_at_superficial_peak_db"])[0]
        control = _select(controls["superficial"], snr, ep, pm, exponent, smoother)
        control_db = _mean_se(control["deep_region_at_superficial_peak_db"])[0]
        return ok, (
            f"{snr:g} dB: separated in {smooth}/{n} seeds smoothed vs {plain}/{n_plain} not "
            f"smoothed (deep region at 2.5 ms: {_fmt(residual)} dB, superficial-only control "
            f"{_fmt(control_db)} dB): {'yes' if ok else 'no'}"
        )

    return _level_finding(
        6,
        "smoothing with exponent 1.25 (EP 20, PM 0) suppresses the residual deep activity at "
        "the superficial peak at all noise levels: clear separation",
        "separation",
        separation,
    )


RULES_V2 = (rule_v2_f1, rule_v2_f2, rule_v2_f3, rule_v2_f4, rule_v2_f5, rule_v2_f6)


def evaluate_v2(table, controls):
    """Apply every v2 rule.

    Parameters
    ----------
    table : pandas.DataFrame
        The paper-grid rows of one cell.
    controls : dict
        ``{"superficial": table, "deep": table}`` of the same cell.

    Returns
    -------
    list of Finding
        F1 .. F6.
    """
    return [
        rule(table) if rule in (rule_v2_f1, rule_v2_f2, rule_v2_f3) else rule(table, controls)
        for rule in RULES_V2
    ]
