"""Intervals that stay honest at 0 and 1, the paired test and Holm's correction.

- :func:`clopper_pearson`: the exact interval of a proportion;
- :func:`newcombe_auc`: the ROC area (Mann-Whitney, ties half) with Newcombe's (2006,
  Stat. Med. 25: 559-573) method 5 interval: Hanley and McNeil's variance with
  m* = n* = (m + n) / 2 - 1, inverted as a score interval, so that an area of 1 gets a
  lower limit below 1 (a percentile bootstrap gives [1, 1] there);
- :func:`median_interval`: the distribution-free interval of a median (binomial order
  statistics);
- :func:`wilcoxon_p` and :func:`holm`: the paired two-sided signed-rank test and Holm's
  step-down adjustment.
"""

from __future__ import annotations

import numpy as np

__all__ = ["LEVEL", "auc", "clopper_pearson", "holm", "median_interval", "newcombe_auc",
           "wilcoxon_p"]  # fmt: skip

#: Confidence level of every interval.
LEVEL = 0.95


def clopper_pearson(k, n, level=LEVEL):
    """Exact interval of a proportion k / n.

    Examples
    --------
    >>> tuple(round(v, 4) for v in clopper_pearson(20, 20))
    (0.8316, 1.0)
    """
    from scipy.stats import beta

    alpha = 1.0 - level
    low = 0.0 if k == 0 else float(beta.ppf(alpha / 2, k, n - k + 1))
    high = 1.0 if k == n else float(beta.ppf(1 - alpha / 2, k + 1, n - k))
    return low, high


def auc(present, absent):
    """ROC area: P(present > absent) + P(tie) / 2.

    Examples
    --------
    >>> auc([3.0, 2.0], [1.0, 2.0])
    0.875
    """
    present = np.asarray(present, dtype=float)
    absent = np.sort(np.asarray(absent, dtype=float))
    below = np.searchsorted(absent, present, side="left")
    ties = np.searchsorted(absent, present, side="right") - below
    return float((below + 0.5 * ties).sum() / (present.size * absent.size))


def _variance(theta, m, n):
    """Hanley and McNeil's variance of the area with Newcombe's m* = n* = (m + n) / 2 - 1."""
    star = (m + n) / 2.0 - 1.0
    return (
        theta
        * (1 - theta)
        / (m * n)
        * (1 + star * (1 - theta) / (2 - theta) + star * theta / (1 + theta))
    )


def newcombe_auc(present, absent, level=LEVEL):
    """ROC area and Newcombe's method 5 interval.

    The interval holds every theta with ``(theta - area)^2 <= z^2 V(theta)``.

    Examples
    --------
    >>> area, low, high = newcombe_auc(np.arange(10.0) + 10, np.arange(10.0))
    >>> area, round(low, 3), high
    (1.0, 0.8, 1.0)
    """
    from scipy.optimize import brentq
    from scipy.stats import norm

    area = auc(present, absent)
    m, n = np.size(present), np.size(absent)
    z2 = norm.ppf(0.5 + level / 2) ** 2

    def gap(theta):
        return (theta - area) ** 2 - z2 * _variance(theta, m, n)

    inner = min(max(area, 1e-12), 1 - 1e-12)
    low = 0.0 if gap(0.0) <= 0 else brentq(gap, 0.0, inner, xtol=1e-12)
    high = 1.0 if gap(1.0) <= 0 else brentq(gap, inner, 1.0, xtol=1e-12)
    return area, float(low), float(high)


def median_interval(values, level=LEVEL):
    """Median and its distribution-free interval ``[x_(k), x_(n-k+1)]``.

    k is the largest rank with ``P(B <= k - 1) <= (1 - level) / 2``, B ~ Binomial(n, 1/2);
    NaNs are left out. Too few values for the level: (median, -inf, inf).

    Examples
    --------
    >>> median_interval(np.arange(1.0, 21.0))
    (10.5, 6.0, 15.0)
    """
    from scipy.stats import binom

    x = np.sort(np.asarray(values, dtype=float))
    x = x[~np.isnan(x)]
    n = x.size
    if n == 0:
        return np.nan, np.nan, np.nan
    tail = (1.0 - level) / 2
    k = int(np.sum(binom.cdf(np.arange(n), n, 0.5) <= tail))
    if k == 0:
        return float(np.median(x)), -np.inf, np.inf
    return float(np.median(x)), float(x[k - 1]), float(x[n - k])


def wilcoxon_p(differences):
    """Two-sided Wilcoxon signed-rank p-value; zero differences dropped, 1 if all are zero.

    Examples
    --------
    >>> wilcoxon_p(np.zeros(5))
    1.0
    """
    from scipy.stats import wilcoxon

    d = np.asarray(differences, dtype=float)
    d = d[~np.isnan(d)]
    if not np.any(d != 0):
        return 1.0
    return float(wilcoxon(d, zero_method="wilcox", alternative="two-sided").pvalue)


def holm(pvalues):
    """Holm's step-down adjusted p-values (same order as given).

    Examples
    --------
    >>> holm([0.01, 0.04, 0.03])
    array([0.03, 0.06, 0.06])
    """
    p = np.asarray(pvalues, dtype=float)
    order = np.argsort(p, kind="stable")
    scaled = p[order] * (len(p) - np.arange(len(p)))
    adjusted = np.minimum(np.maximum.accumulate(scaled), 1.0)
    out = np.empty_like(p)
    out[order] = adjusted
    return out
