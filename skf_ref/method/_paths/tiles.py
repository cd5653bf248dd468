"""How the spectral path cuts its outputs into tiles: the work items of its worker threads.

A tile is a block of rows (sources) by a block of steps of about :data:`BLOCK_BYTES`: small
enough to stay in cache between the steps that touch it and for every core to share even
small outputs (``skf_ref._utils.threads.map_threads``). Tiles of the same rows and steps are
the same products whatever the number of threads. With the standardization per position
(docs/model.md §2) a tile holds whole positions: its rows are multiples of ``align``.
"""

from collections.abc import Iterator

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "BLOCK_BYTES",
    "MIN_BLOCK_COLUMNS",
    "PROJECTION_COLUMNS",
    "PROJECTION_STEPS",
    "TIME_MAJOR_COLUMNS",
    "aligned",
    "row_blocks",
    "row_count",
    "slices",
    "split",
    "tiles",
    "tiles_by_steps",
]

#: One tile of an output, a work item of the worker threads: small enough to stay in
#: cache between the steps that touch it and for both cores to share even small outputs.
BLOCK_BYTES = 4 * 2**20
#: Rows of a tile on long recordings (more than BLOCK_BYTES / (8 MIN_BLOCK_COLUMNS)
#: steps), which are cut into tiles of steps too: products at least this wide.
MIN_BLOCK_COLUMNS = 64
#: Rows of a tile of a time-major output (held in memory): each step of a tile is a
#: contiguous 32 KiB run, where a source-major tile's row width (BLOCK_BYTES over the
#: steps, 524 rows at 1000 steps) cuts every step into 4 KiB pieces a page apart; at the
#: paper's scale z with kept weights takes 0.025 s in place of 0.035 (validation/bench).
TIME_MAJOR_COLUMNS = 4096
#: The "rts-standardized" correction sums zeta over groups of this many rows, in tiles of
#: this many steps (one work item of the worker threads each): the same bits whatever the
#: number of threads.
PROJECTION_COLUMNS = 8192
PROJECTION_STEPS = 8192

_Array = NDArray[np.float64]


def aligned(rows: int, align: int) -> int:
    """``rows`` rounded down to a multiple of ``align`` (at least ``align``).

    Examples
    --------
    >>> aligned(64, 3), aligned(2, 3), aligned(64, 1)
    (63, 3, 64)
    """
    return max(align, rows - rows % align)


def split(times: slice, steady: int) -> tuple[slice | None, slice | None]:
    """``times`` cut at ``steady``: the steps before it and from it on (None when empty)."""
    first, stop = times.start, times.stop
    cut = min(max(steady, first), stop)
    return (slice(first, cut) if cut > first else None), (slice(cut, stop) if stop > cut else None)


def slices(first: int, stop: int, step: int) -> Iterator[slice]:
    """Consecutive slices of ``first:stop``, ``step`` long (the last may be shorter)."""
    for start in range(first, stop, step):
        yield slice(start, min(start + step, stop))


def row_count(n_steps: int) -> int:
    """Rows in :data:`BLOCK_BYTES` at ``n_steps`` steps (at least one)."""
    return max(1, BLOCK_BYTES // (8 * n_steps))


def row_blocks(first: int, stop: int, n_steps: int, align: int = 1) -> list[slice]:
    """Row blocks of ``first:stop`` of about :data:`BLOCK_BYTES` at ``n_steps`` steps, each a
    multiple of ``align`` rows."""
    return list(slices(first, stop, aligned(row_count(n_steps), align)))


def tiles(
    first: int, stop: int, n_times: int, target: _Array | None = None, align: int = 1
) -> list[tuple[slice, slice]]:
    """(rows, steps) tiles of rows ``first:stop`` x all steps, about BLOCK_BYTES each:
    whole rows when they fit MIN_BLOCK_COLUMNS at a time, else cut in steps too. In a
    time-major ``target`` (the transpose of an (n_times, n) array) a tile is
    TIME_MAJOR_COLUMNS rows wide: each of its steps is one contiguous run of memory. Rows
    come in multiples of ``align`` (``first`` is one)."""
    rows = max(MIN_BLOCK_COLUMNS, BLOCK_BYTES // (8 * n_times))
    if target is not None and target.strides[0] < target.strides[1]:
        rows = TIME_MAJOR_COLUMNS
    rows = aligned(rows, align)
    steps = max(1, BLOCK_BYTES // (8 * min(rows, max(1, stop - first))))
    return [(r, t) for r in slices(first, stop, rows) for t in slices(0, n_times, steps)]


def tiles_by_steps(
    first: int, stop: int, step_first: int, step_stop: int, align: int = 1
) -> Iterator[tuple[slice, slice]]:
    """(steps, rows) tiles of the steps ``step_first:step_stop``, steps outermost; rows in
    multiples of ``align``."""
    n = step_stop - step_first
    width = aligned(max(MIN_BLOCK_COLUMNS, BLOCK_BYTES // (8 * max(1, min(n, 8192)))), align)
    for steps in slices(step_first, step_stop, 8192):
        for rows in slices(first, stop, width):
            yield steps, rows
