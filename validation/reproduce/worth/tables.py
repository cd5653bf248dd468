"""Numbers of a :class:`.run.Worth` as table cells: lookups and formats.

Every cell the report, the README and the documentation print comes through :func:`cell`,
so that the same number reads the same everywhere (and :mod:`.headline` can list them).
"""

from __future__ import annotations

import numpy as np

__all__ = ["NOISE_FREE", "cell", "lookup", "markdown_table", "percent", "snr_name"]

NOISE_FREE = np.inf


def lookup(worth, key, quantity, snr, design="D1", set_name="scored"):
    """(value, low, high, n) of a summary row, or NaNs when it is missing."""
    s = worth.summaries
    rows = s[
        (s["method"] == key)
        & (s["quantity"] == quantity)
        & (s["snr_db"] == snr)
        & (s["design"] == design)
        & (s["set"] == set_name)
    ]
    if rows.empty:
        return np.nan, np.nan, np.nan, 0
    row = rows.iloc[0]
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
