"""The names of a reconstruction's outputs, and what computes them on demand.

Every source-space output has shape (n_sources, n_times), MNE's layout; the conformance
cases and ``compare`` add the scalar innovation log-likelihood. A path hands the result
type its outputs either as arrays or as a :class:`LazyOutputs`: an object that computes
any output whole, or any block of its rows, when asked (the spectral path's, so that a
reconstruction of 150 000 sources never holds more than the outputs asked for).
"""

from collections.abc import Iterator, Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

__all__ = ["ARRAYS", "OUTPUTS", "LazyOutputs"]

#: The (n_sources, n_times) arrays of a :class:`~skf_ref.Reconstruction`.
ARRAYS = ("z", "x", "z_filtered", "x_filtered", "weights")
#: Everything a reconstruction outputs, in the order the conformance cases list it.
OUTPUTS = ("z", "z_filtered", "x", "x_filtered", "weights", "log_likelihood")


class LazyOutputs(Protocol):
    """What computes a reconstruction's outputs when they are asked for.

    ``name`` is one of :data:`ARRAYS`. Rows can be computed in any blocks: a block may need
    a share of every other block first (the paper's smoother sums ``V^T z`` over all rows),
    which :meth:`share` and :meth:`combine` compute, so that blocks can be computed apart
    (on a cluster: :func:`skf_ref.io.to_dask`).
    """

    def array(self, name: str) -> NDArray[np.float64]:
        """Output ``name`` whole, (n_sources, n_times)."""
        ...

    def blocks(
        self, name: str, rows: int | None = None
    ) -> Iterator[tuple[slice, NDArray[np.float64]]]:
        """Output ``name`` block of ``rows`` rows by block (default a few MiB each):
        ``(rows, block)`` with ``block`` of shape (n_rows, n_times)."""
        ...

    def share(self, name: str, rows: slice) -> object:
        """What rows ``rows`` contribute to every block of output ``name`` (or None)."""
        ...

    def combine(self, name: str, shares: Sequence[object]) -> object:
        """The shares of every block of rows, combined for :meth:`block`."""
        ...

    def block(self, name: str, rows: slice, shared: object = None) -> NDArray[np.float64]:
        """Rows ``rows`` of output ``name``, (n_rows, n_times), given :meth:`combine`'s
        result (computed here when None)."""
        ...

    def min_raw_weight(self) -> float:
        """The smallest raw weight ``w_t`` over every source and observed step (to say
        why an output overflowed)."""
        ...
