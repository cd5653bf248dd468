"""Numbers of a :class:`.run.Worth` as table cells: lookups and formats.

Every cell the report, the README and the documentation print comes through :func:`cell`,
so that the same number reads the same everywhere (and :mod:`.headline` can list them).
"""

from __future__ import annotations

import numpy as np

__all__ = ["NOISE_FREE", "cell", "lookup", "markdown_table", "percent", "snr_name"]

NOISE_FREE = np.inf


_KEY = ("method", "quantity", "snr_db", "design", "set")
_index: list = [None, 0, {}]  # the last summaries table, its length, {key: its first row}


def lookup(worth, key, quantity, snr, design="D1", set_name="scored"):
    """(value, low, high, n) of a summary row, or NaNs when it is missing."""
    s = worth.summaries
    if _index[0] is not s or _index[1] != len(s):
        # the report looks up about 1500 cells: index the table once, not a filter a cell
        first = {}
        for i, row in enumerate(zip(*(s[column].tolist() for column in _KEY), strict=True)):
            first.setdefault(row, i)
        _index[:] = [s, len(s), first]
    i = _index[2].get((key, quantity, snr, design, set_name))
    if i is None:
        return np.nan, np.nan, np.nan, 0
    row = s.iloc[i]
    return float(row["value"]), float(row["low"]), float(row["high"]), int(row["n"])


def percent(x):
    """0.853 -> "85 %"."""
    return "n/a" if not np.isfinite(x) else f"{100 * x:.0f} %"


def snr_name(snr):
    """inf -> "noise-free", 20.0 -> "20 dB"."""
    return "noise-free" if snr == NOISE_FREE else f"{snr:g} dB"


def cell(worth, key, quantity, snr, kind, design="D1", set_name="scored"):
    """A formatted cell: ``kind`` is "median" (value [Q1, Q3]), "median-only", "rate"
    (value [CP interval]), "rate-only", "auc" (value [Newcombe]) or "r"."""
    value, low, high, n = lookup(worth, key, quantity, snr, design, set_name)
    if not np.isfinite(value) or n == 0:
        return "n/a"
    if kind == "median":
        return f"{value:.0f} [{low:.0f}, {high:.0f}]"
    if kind == "median-only":
        return f"{value:.0f}"
    if kind == "rate":
        return f"{100 * value:.0f} % [{100 * low:.0f}, {100 * high:.0f}]"
    if kind == "rate-only":
        return f"{100 * value:.0f} %"
    if kind == "auc":
        return f"{value:.2f} [{low:.2f}, {high:.2f}]"
    if kind == "r":
        return f"{value:.2f}"
    raise ValueError(f"kind must be a known cell kind, got {kind!r}")


def markdown_table(header, rows):
    """A Markdown table from a header (list of str) and rows (lists of str)."""
    lines = ["| " + " | ".join(header) + " |", "|---" * len(header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)
