"""The spectral path's outputs, any block of rows at a time (docs/model.md §2-3).

Given the r x T quantities of one reconstruction (the filtered and smoothed singular
coordinates, the covariance recursion, the scalar complement gains), every row of every
output (``z``, ``x``, the weights, the smoothed ``z``) depends only on that row of ``V``:
rows can be computed in any blocks, in memory (:meth:`SpectralRows.array`), streamed to disk
or on a cluster (:meth:`SpectralRows.block`). The one exception is the paper's smoother,
``"rts-standardized"``: its correction ``V delta`` needs ``zeta = V^T z_{t|t}`` summed over
all rows, which one pass over the blocks computes first (r x T numbers; kept).

Blocks are time-major, (n_times, n_rows), like the paths' internal arrays; results hand
them out transposed.
"""

import numpy as np
from scipy.linalg import blas

from ..._utils import memory
from ..outputs import ARRAYS
from ..standardization import standardization_weights, standardized_means
from .singular_basis import backward, map_threads

__all__ = [
    "BLOCK_BYTES",
    "MIN_BLOCK_COLUMNS",
    "NAMES",
    "PROJECTION_COLUMNS",
    "PROJECTION_STEPS",
    "SMOOTH_BYTES",
    "SMOOTH_COLUMNS",
    "SpectralRows",
]

#: The outputs a reconstruction holds.
NAMES = ARRAYS  # the outputs it computes rows of
#: Temporaries of at most this size when forming (T, n) outputs: small enough for the
#: allocator to reuse them (a fresh large allocation costs a page fault per 4 KiB) and for
#: a block to stay in cache between the steps that touch it.
BLOCK_BYTES = 4 * 2**20
#: But never fewer columns than this: each block reads the whole (T, r) recursions, so on
#: long recordings (T = 200 000: 2 columns in 4 MiB) narrow blocks would read them
#: thousands of times and multiply matrices one or two columns wide.
MIN_BLOCK_COLUMNS = 64
#: Streamed "rts-standardized" outputs narrower than SMOOTH_COLUMNS are computed several
#: blocks at a time, up to that width or SMOOTH_BYTES: the smoother's backward pass costs
#: T vector operations per block whatever its width.
SMOOTH_COLUMNS = 512
SMOOTH_BYTES = 256 * 2**20
#: The "rts-standardized" correction sums zeta over groups of this many rows, in tiles of
#: this many steps (one work item of the worker threads each): items small enough for
#: memory and for both cores to share even at T = 1000, large enough to amortize their cost.
PROJECTION_COLUMNS = 8192
PROJECTION_STEPS = 8192


class SpectralRows:
    """Rows of the outputs of one spectral reconstruction.

    Parameters
    ----------
    V : ndarray, shape (n_sources, r)
    omega : ndarray, shape (n_times, r)
        ``s^2 p_{t|t-1} / (s^2 p_{t|t-1} + 1)``: the raw weights are ``(V o V) omega``.
    p_pred : ndarray, shape (n_times, r)
    xi : ndarray, shape (n_times, r)
        Filtered singular coordinates ``V^T x_{t|t}``.
    exponent : float
    smoother : {None, "rts-standardized", "rts-state"}
    xi_smoothed : ndarray, shape (n_times, r), optional
        ``V^T x^s_t`` for ``"rts-state"``.
    gains : (gamma, beta, a), optional
        The smoother's gains (T-1, r), (T-1,) and the transition, for ``"rts-standardized"``.
    memory_limit : float, optional
        Bytes a whole output (:meth:`array`) may take; default half the memory available.
    """

    def __init__(
        self,
        V,
        omega,
        p_pred,
        xi,
        exponent,
        smoother,
        xi_smoothed=None,
        gains=None,
        memory_limit=None,
    ):
        self.V, self.V_squared, self.omega = V, V**2, omega
        self.n_sources, self.n_times = V.shape[0], len(omega)
        self.exponent, self.smoother, self.gains = exponent, smoother, gains
        self.memory_limit = memory_limit
        self.xi, self.xi_smoothed = xi, xi_smoothed
        root = np.sqrt(p_pred)
        # P_{t|t-1}^{-1/2} x = V diag(p^{-1/2}) xi                      §2.2 (6)
        self.u = xi / root
        self.u_smoothed = None if xi_smoothed is None else xi_smoothed / root
        self._delta = None

    # --- one block of columns (sources), time-major ---------------------------------------

    def block(self, name, columns, out=None, delta=None):
        """Rows ``columns`` of output ``name``, as a (n_times, n_rows) array.

        Filled in sub-blocks of about :data:`BLOCK_BYTES` on worker threads
        (:func:`skf_ref.method.paths.singular_basis.map_threads`), then smoothed as a whole.

        Parameters
        ----------
        name : {"z", "x", "z_filtered", "x_filtered", "weights"}
        columns : slice
            With a step of 1.
        out : ndarray, shape (n_times, n_rows), optional
            Where to write.
        delta : ndarray, shape (n_times, r), optional
            The "rts-standardized" correction (:meth:`correction_from`); default computed
            here by a pass over every row (:meth:`correction`).

        Returns
        -------
        ndarray, shape (n_times, n_rows)
        """
        first, stop, _ = columns.indices(self.n_sources)
        out = np.empty((self.n_times, stop - first)) if out is None else out

        def fill(part):
            self._filtered(name, part, out[:, part.start - first : part.stop - first])

        for _ in map_threads(fill, self._column_blocks(first, stop)):
            pass
        if name == "z" and self.smoother == "rts-standardized":
            self._smooth(columns, out, self.correction() if delta is None else delta)
        return out

    def _filtered(self, name, columns, out):
        """``block`` without the "rts-standardized" correction, for one cache-sized block."""
        if name == "x_filtered" or (name == "x" and self.smoother != "rts-state"):
            return np.matmul(self.xi, self.V[columns].T, out=out)
        if name == "x":
            return np.matmul(self.xi_smoothed, self.V[columns].T, out=out)
        if name == "weights":
            return standardization_weights(self._raw(columns, out), self.exponent, out=out)
        smoothed = name == "z" and self.smoother == "rts-state"
        return self._standardized(self.u_smoothed if smoothed else self.u, columns, out)

    def _raw(self, columns, out, times=slice(None)):
        # w_t = (V o V) omega_t                                        §2.2 (7)
        return np.matmul(self.omega[times], self.V_squared[columns].T, out=out)

    def _standardized(self, u, columns, out, times=slice(None)):
        """``z`` of these columns at steps ``times`` into ``out`` (n_steps, k), a few time
        steps at a time: on long recordings a block of :data:`MIN_BLOCK_COLUMNS` is larger
        than the cache."""
        first, stop, _ = times.indices(self.n_times)
        step = max(1, BLOCK_BYTES // (8 * out.shape[1]))
        work = np.empty((min(step, stop - first), out.shape[1]))
        for start in range(first, stop, step):
            steps = slice(start, min(start + step, stop))
            part = out[start - first : steps.stop - first]
            w = work[: len(part)]
            # z_t = W_t^(alpha) V diag(p_pred^{-1/2}) xi_t           §2.2 (6)-(7)
            np.matmul(u[steps], self.V[columns].T, out=part)
            standardized_means(self._raw(columns, w, steps), part, self.exponent, out=part)
        return out

    def _smooth(self, columns, out, delta):
        """s = h + V delta (spectral module docstring) over z_{t|t} of ``columns``, in place.

        The backward recursion is one scalar gain per step for every row: over a whole
        (T, n) array it costs T vector operations, over blocks T per block.
        """
        gamma, beta, a = self.gains
        backward(out, beta, a, overwrite=True)  # h: scalar gains, row by row
        _add_product(out, delta, self.V[columns])

    def projection(self, columns, times=slice(None)):
        """These rows' share of ``zeta = V^T z_{t|t}`` at steps ``times``: (n_steps, r).

        The shares of disjoint rows add up to ``zeta``. Computed a few time steps at a time:
        no (n_steps, n_rows) array is formed.
        """
        first, stop, _ = times.indices(self.n_times)
        share = np.zeros((stop - first, self.V.shape[1]))
        tile = max(1, BLOCK_BYTES // (8 * MIN_BLOCK_COLUMNS))
        for start in range(first, stop, tile):
            steps = slice(start, min(start + tile, stop))
            width = max(MIN_BLOCK_COLUMNS, BLOCK_BYTES // (8 * (steps.stop - start)))
            work = np.empty((steps.stop - start, width))
            for block in _slices(*columns.indices(self.n_sources)[:2], width):
                z = self._standardized(self.u, block, work[:, : block.stop - block.start], steps)
                share[start - first : steps.stop - first] += z @ self.V[block]
        return share

    def _projected(self, columns, out):
        """``zeta``'s share of these rows, with ``z_{t|t}`` of these rows left in ``out``."""
        return self._standardized(self.u, columns, out) @ self.V[columns]

    def correction(self):
        """delta (T, r) of the spectral module docstring, by one pass over every row.

        ``zeta`` is summed over groups of :data:`PROJECTION_COLUMNS` rows in a fixed order,
        per tile of :data:`PROJECTION_STEPS` steps on worker threads: the same bits whatever
        the number of threads, and memory of a few (tile, r) arrays, not (T, r) per block.
        """
        if self._delta is None:
            zeta = np.zeros_like(self.u)
            items = [
                (rows, steps)
                for steps in _slices(0, self.n_times, PROJECTION_STEPS)
                for rows in _slices(0, self.n_sources, PROJECTION_COLUMNS)
            ]
            shares = map_threads(lambda item: self.projection(*item), items)
            for (_, steps), share in zip(items, shares, strict=True):
                zeta[steps] += share  # in a fixed order, whatever the number of threads
            self._delta = self.correction_from(zeta)
        return self._delta

    def correction_from(self, zeta):
        """delta (T, r) from ``zeta = V^T z_{t|t}`` (T, r), the sum of :meth:`projection`."""
        gamma, beta, a = self.gains
        chi = backward(zeta, beta, a)  # = V^T h
        delta = np.zeros_like(zeta)
        for t in range(len(zeta) - 2, -1, -1):
            # delta_t = gamma_t delta_{t+1} + (gamma_t - beta_t)(chi_{t+1} - a zeta_t)
            delta[t] = gamma[t] * delta[t + 1] + (gamma[t] - beta[t]) * (chi[t + 1] - a * zeta[t])
        return delta

    def _column_blocks(self, first, stop):
        """Slices of columns ``first:stop`` of about :data:`BLOCK_BYTES` of (T, k) each."""
        return _slices(first, stop, max(MIN_BLOCK_COLUMNS, BLOCK_BYTES // (8 * self.n_times)))

    # --- a whole output in memory -------------------------------------------------------

    def array(self, name):
        """Output ``name`` whole, (n_times, n_sources), filled block by block in threads.

        ``"z"`` of ``"rts-standardized"`` is filled with ``z_{t|t}`` and the projection
        ``zeta`` in one pass, then smoothed in place: one (T, n) array.
        """
        n, T = self.n_sources, self.n_times
        memory.require(
            8 * n * T,
            f"a ({n}, {T}) output array in memory (stream it instead: Reconstruction.to_zarr, "
            ".blocks or .to_dask)",
            budget=self.memory_limit,
        )
        result = np.empty((T, n))
        if name == "z" and self.smoother == "rts-standardized" and self._delta is None:
            zeta = np.zeros_like(self.u)

            def fill(columns):
                return self._projected(columns, result[:, columns])

            for share in map_threads(fill, self._column_blocks(0, n)):
                zeta += share  # in block order, whatever the number of threads
            self._delta = self.correction_from(zeta)
            self._smooth(slice(None), result, self._delta)  # whole rows: T steps, not T a block
            return result
        return self.block(name, slice(0, n), out=result)

    def min_raw_weight(self):
        """The smallest raw weight over every source and step (only to explain a failure)."""
        return min(
            np.min(self._raw(columns, np.empty((self.n_times, columns.stop - columns.start))))
            for columns in self._column_blocks(0, self.n_sources)
        )


def _slices(first, stop, step):
    """Consecutive slices of ``first:stop``, ``step`` long (the last may be shorter)."""
    for start in range(first, stop, step):
        yield slice(start, min(start + step, stop))


def _add_product(out, delta, V_rows):
    """``out += delta @ V_rows.T`` ((T, k) += (T, r) (r, k)) without a (T, k) temporary.

    BLAS gemm with beta = 1 accumulates into ``out`` where it is C-contiguous (its
    transpose is the column-major (k, T) matrix gemm writes); elsewhere numpy.
    """
    if not out.flags.c_contiguous:
        out += delta @ V_rows.T
        return out
    # out^T (k, T) += V_rows (k, r) @ delta^T (r, T), every operand column-major
    a, trans_a = (V_rows.T, 1) if V_rows.flags.c_contiguous else (V_rows, 0)
    blas.dgemm(
        1.0, a, np.ascontiguousarray(delta).T, beta=1.0, c=out.T, trans_a=trans_a, overwrite_c=1
    )
    return out
