"""The spectral path's outputs, any block of rows at a time (docs/model.md §2-3).

Given the r x T quantities of one reconstruction (the filtered and smoothed singular
coordinates, the covariance recursion, the scalar complement gains), every row of every
output (``z``, ``x``, the weights, the smoothed ``z``) depends only on that row of ``V``:
rows can be computed in any blocks, in memory (:meth:`SpectralRows.array`), streamed to disk
or on a cluster (:meth:`SpectralRows.block`). The one exception is the paper's smoother,
``"rts-standardized"``: its correction ``V delta`` needs ``zeta = V^T z_{t|t}`` summed over
all rows, which one pass over the blocks computes first (r x T numbers; kept).

In the steady state (``skf_ref.method._paths.recursions``, from step ``steady`` on) the
weights are held: ``W_t^(alpha) = D``, one number a row, and every output is one product,
``z_t = (D V) u_t`` with ``u_t = p^{-1/2} xi_t``. There the smoothed ``h_t`` of the paper's
smoother (module ``skf_ref.method._paths.spectral``) stays in span ``D V``:
``h_t = D V eta_t`` with ``eta`` the scalar recursion on ``u`` (rank r), so
``s_t = [D V, V] [eta_t; delta_t]``, one product, and ``zeta_t = (V^T D V) u_t``: the pass
over the rows covers the steps before ``steady`` only.

Everything is computed in tiles of about :data:`BLOCK_BYTES` (rows, and steps on long
recordings) on worker threads (``skf_ref._utils.threads.map_threads``), each on one BLAS
thread. A block of rows (:meth:`SpectralRows.block`) is computed source-major, (n_rows,
n_times) C-ordered, as it is written to disk, and handed out as its (n_times, n_rows)
transpose; a whole output (:meth:`SpectralRows.array`) is time-major, (n_times, n_sources),
so that the paper's smoother's scalar recursion runs along contiguous rows.
"""

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import blas

from ..._utils import memory
from ..._utils.threads import map_threads
from . import tiles
from .block_weights import BlockStandardization
from .recursions import Recursions, backward
from .weights import Standardization

__all__ = ["SpectralRows"]

#: :meth:`skf_ref.Reconstruction.blocks` computes streamed ``"rts-standardized"`` outputs
#: narrower than SMOOTH_COLUMNS several blocks at a time, up to that width or
#: SMOOTH_BYTES: the backward pass over the steps before the steady state costs one
#: vector operation a step per block.
SMOOTH_COLUMNS = 512
SMOOTH_BYTES = 64 * 2**20
#: A whole output's backward pass (one numpy call a step per part) runs in parts of at least
#: this many columns, so the calls' overhead stays small beside their work (at the paper's
#: scale, 9501 columns, two parts take 0.016 s where eight took 0.024), and in at most 8,
#: so that a core another process keeps busy hands its share to the other.
SMOOTH_PART_COLUMNS = 4096

_Array = NDArray[np.float64]


class SpectralRows:
    """Rows of the outputs of one spectral reconstruction: its
    ``skf_ref.method._outputs.LazyOutputs``.

    Parameters
    ----------
    V : ndarray, shape (n_sources, r)
        The right singular vectors of the whitened lead field.
    a : float
        ``A = a I``.
    recursions : Recursions
        The covariance recursion of the data's steps (``skf_ref.method._paths.recursions``).
    standardization : Standardization or BlockStandardization
        Its weights at the exponent asked for, per column or per position
        (``skf_ref.method._paths.block_weights``).
    xi : ndarray, shape (n_times, r)
        Filtered singular coordinates ``V^T x_{t|t}``.
    smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}
    memory_limit : float, optional
        Bytes a whole output (:meth:`array`) may take; default half the memory available.
    smoothed : (Standardization or BlockStandardization or HeldInterior, ndarray), optional
        For ``"rts-smoothed-weights"``: the standardization of the smoothed state by its
        own variance and ``1 / sigma_t`` (n_times,), its whitening
        (``skf_ref.method._paths.smoothed_weights``).
    """

    def __init__(
        self,
        V: NDArray[np.float64],
        a: float,
        recursions: Recursions,
        standardization: Standardization | BlockStandardization,
        xi: NDArray[np.float64],
        smoother: str | None,
        memory_limit: float | None = None,
        smoothed: tuple[Any, _Array] | None = None,
    ) -> None:
        self.V, self.a, self.xi = V, a, xi
        self.n_sources, self.n_times = self.V.shape[0], len(xi)
        self.steady = recursions.steady
        self.exponent = standardization.exponent
        self.smoother, self.memory_limit = smoother, memory_limit
        self.standardization = standardization
        self.standardization.applications += 1
        self.align = standardization.align  # rows standardized together
        self.recursions = recursions
        # P_{t|t-1}^{-1/2} x = V diag(p^{-1/2}) xi                      §2.2 (6)
        self.u = self._whitened(xi)
        self.xi_smoothed: Any = None
        self.u_smoothed: Any = None
        # the standardization of the smoothed z: the filter's, or the smoothed state's own
        self.smoothed_standardization = standardization
        if smoother in ("rts-state", "rts-smoothed-weights"):
            self.xi_smoothed = recursions.smooth_state(xi)
        if smoother == "rts-state":
            self.u_smoothed = self._whitened(self.xi_smoothed)
        elif smoother == "rts-smoothed-weights":
            assert smoothed is not None  # the caller gives it with this smoother
            self.smoothed_standardization, inverse_sigma = smoothed
            self.smoothed_standardization.applications += 1  # kept from a second data set
            # Sigma_t^{-1/2} x^s_t = V xi^s_t / sigma_t^(1/2)         docs/model.md §3
            self.u_smoothed = self.xi_smoothed * np.sqrt(inverse_sigma)[:, None]
            # no estimate at a missing step, as on every smoother (its z is NaN there)
            self.u_smoothed[recursions.missing] = np.nan
        self._delta: Any = None

    # --- the LazyOutputs protocol -----------------------------------------------------------

    def array(self, name: str) -> NDArray[np.float64]:
        """Output ``name`` whole, (n_sources, n_times): the transpose of a time-major array
        (:meth:`time_major`), or, standardized per position, C-ordered: the three rows of
        a position are then copied out as three contiguous runs (a third of the time of
        interleaving them into each step's row)."""
        if self.align == 1 or self._needs_correction(name):
            return self.time_major(name).T
        result = self._allocate(time_major=False)
        self._fill_block(name, slice(0, self.n_sources), out=result.T)
        return result

    def _allocate(self, time_major: bool) -> _Array:
        """An empty whole output, (n_times, n_sources) or (n_sources, n_times), within the
        memory limit."""
        n, T = self.n_sources, self.n_times
        memory.require(
            8 * n * T,
            f"a ({n}, {T}) output array in memory (stream it instead: skf_ref.io.to_zarr, "
            "Reconstruction.blocks or skf_ref.io.to_dask)",
            budget=self.memory_limit,
        )
        return np.empty((T, n) if time_major else (n, T))

    def blocks(
        self, name: str, rows: int | None = None
    ) -> Iterator[tuple[slice, NDArray[np.float64]]]:
        """Output ``name`` block of ``rows`` rows by block (default about
        ``BLOCK_BYTES`` each), (n_rows, n_times) C-ordered.

        The paper's smoother's backward pass costs a vector operation a step per block
        computed, so on long recordings narrow blocks are computed several at a time (up to
        :data:`SMOOTH_COLUMNS` rows or :data:`SMOOTH_BYTES`): one group in memory at once.
        """
        n, T = self.n_sources, self.n_times
        step = tiles.aligned(tiles.row_count(T), self.align) if rows is None else rows
        width = min(SMOOTH_COLUMNS, SMOOTH_BYTES // (8 * T))
        smoothed = name == "z" and self.smoother == "rts-standardized"
        group = step * max(1, width // step) if smoothed else step
        for first in range(0, n, group):
            stop = min(first + group, n)
            many = self.block(name, slice(first, stop))
            for start in range(first, stop, step):
                where = slice(start, min(start + step, stop))
                yield where, many[where.start - first : where.stop - first]
            del many  # before the next group is computed

    def share(self, name: str, rows: slice) -> _Array | None:
        """These rows' share of what every block of ``name`` needs: of ``zeta = V^T
        z_{t|t}`` for the paper's smoothed ``z`` (:meth:`projection`), else None."""
        return self.projection(rows) if self._needs_correction(name) else None

    def combine(self, name: str, shares: Sequence[Any]) -> _Array | None:
        """The correction of the paper's smoother from every block's share (else None)."""
        if not self._needs_correction(name):
            return None
        return self.correction_from(np.sum(shares, axis=0))

    def block(self, name: str, rows: slice, shared: Any = None) -> _Array:
        """Rows ``rows`` of output ``name``, (n_rows, n_times) C-ordered; ``shared`` is
        :meth:`combine`'s result (computed here, by a pass over every row, when None).

        Rows standardized together (a position's, with the standardization per position)
        are computed together: a block that cuts a position computes all of it."""
        first, stop, _ = rows.indices(self.n_sources)
        whole = self._whole(first, stop)
        if whole == slice(first, stop):
            return self._fill_block(name, whole, delta=shared).T
        out = self._fill_block(name, whole, delta=shared).T
        return np.ascontiguousarray(out[first - whole.start : stop - whole.start])

    def _whole(self, first: int, stop: int) -> slice:
        """The smallest run of whole positions (multiples of ``align``) around rows
        ``first:stop``."""
        k = self.align
        return slice(first - first % k, min(self.n_sources, -(-stop // k) * k))

    def min_raw_weight(self) -> float:
        """The smallest raw weight over every source and observed step (only to explain a
        failure)."""
        steps = slice(0, min(self.steady + 1, self.n_times))
        return min(
            float(np.nanmin(self.standardization.raw(rows, steps)))
            for rows in tiles.slices(0, self.n_sources, tiles.row_count(steps.stop))
        )

    def _needs_correction(self, name: str) -> bool:
        return name == "z" and self.smoother == "rts-standardized"

    def _whitened(self, xi: _Array) -> _Array:
        root = np.sqrt(self.recursions.p_pred)
        own = len(root) - self.recursions.held
        return np.concatenate([xi[:own] / root[:own], xi[own:] / root[-1]])

    # --- one block of rows ------------------------------------------------------------------

    def _fill_block(
        self, name: str, columns: slice, out: _Array | None = None, delta: _Array | None = None
    ) -> _Array:
        """Rows ``columns`` of output ``name``, as a (n_times, n_rows) array.

        Computed in tiles on worker threads (``skf_ref._utils.threads.map_threads``).

        Parameters
        ----------
        name : {"z", "x", "z_filtered", "x_filtered", "weights"}
        columns : slice
            With a step of 1.
        out : ndarray, shape (n_times, n_rows), optional
            Where to write.
        delta : ndarray, optional
            The "rts-standardized" correction (:meth:`correction_from`); default computed
            here by a pass over every row (:meth:`correction`).

        Returns
        -------
        ndarray, shape (n_times, n_rows)
            The transpose of a C-ordered (n_rows, n_times) array unless ``out`` is given.
        """
        first, stop, _ = columns.indices(self.n_sources)
        target = np.empty((stop - first, self.n_times)) if out is None else out.T
        if name == "z" and self.smoother == "rts-standardized":
            delta = self.correction() if delta is None else delta
            self._fill_smoothed(first, stop, target, delta)
        else:
            self._fill(name, first, stop, target)
        return target.T

    def _fill(self, name: str, first: int, stop: int, target: _Array) -> None:
        """Output ``name`` (not the paper's smoothed z) of rows first:stop into ``target``."""
        if name in ("z", "z_filtered", "weights"):
            self.standardization.prepare()
            self.smoothed_standardization.prepare()

        def tile(item: tuple[slice, slice]) -> None:
            rows, times = item
            self._tile(name, rows, times, target[rows.start - first : rows.stop - first, times])

        items = tiles.tiles(first, stop, self.n_times, target, self.align)
        for _ in map_threads(tile, items):
            pass

    def _tile(self, name: str, rows: slice, times: slice, out: _Array) -> _Array:
        """Output ``name`` of ``rows`` at ``times`` into ``out`` (n_rows, n_steps)."""
        if name == "x_filtered" or (name == "x" and self.xi_smoothed is None):
            return np.matmul(self.V[rows], self.xi[times].T, out=out)
        if name == "x":
            return np.matmul(self.V[rows], self.xi_smoothed[times].T, out=out)
        transient, held = tiles.split(times, self.steady)
        if name == "weights":
            if transient:
                part = out[:, : transient.stop - transient.start]
                weights = self.standardization.transient(rows, transient, part)
                if weights is not part:
                    part[...] = weights
            if held:
                out[:, held.start - times.start :] = self.standardization.scale(rows)
            return out
        if name == "z" and self.u_smoothed is not None:  # a state smoother's z^s_t
            return self.smoothed_standardization.standardized(self.u_smoothed, rows, times, out)
        return self._standardized(self.u, rows, times, out)

    def _standardized(self, u: _Array, rows: slice, times: slice, out: _Array) -> _Array:
        """``z_t = W_t^(alpha) V u_t`` of ``rows`` at ``times`` into ``out``.  §2.2 (6)-(7)"""
        return self.standardization.standardized(u, rows, times, out)

    # --- the paper's smoother ---------------------------------------------------------------

    def _transient(self, rows: slice, out: _Array) -> _Array:
        """z_{t|t} of ``rows`` before ``steady`` into ``out`` (n_rows, n_times)."""
        return self._standardized(self.u, rows, slice(0, self.steady), out[:, : self.steady])

    def _smooth_transient(self, time_major: _Array, columns: slice, eta: Any) -> None:
        """The smoothed ``h`` before ``steady`` of ``columns``, in place of their z_{t|t} in
        ``time_major`` (n_times, n_rows): the scalar recursion from
        ``h_steady = D V eta_0`` (or from ``z_T`` if the recording ends before ``steady``).

        Over wide arrays (whole rows held in memory) it runs step by step on contiguous
        memory; over narrow blocks (streamed) :data:`~.recursions.CHUNK_STEPS` steps at a
        time (:func:`~.recursions.backward`).
        """
        S = self.steady
        _, beta = self.recursions.gains
        h = time_major[: S + 1] if S < self.n_times else time_major
        if S < self.n_times:  # the boundary h_S = D V eta_0 (F V eta_0 per position)
            np.matmul(self.standardization.held_basis(columns), eta[0], out=h[S])
        backward(h, beta[: len(h) - 1], self.a, overwrite=True)

    def _corrected(self, rows: slice, times: slice, out: _Array, correction: _Array) -> _Array:
        """``s = h + V delta`` of ``rows`` at ``times``: ``out`` holds ``h`` before steady;
        from ``steady`` on ``s_t = [D V, V] [eta_t; delta_t]``, one product."""
        transient, held = tiles.split(times, self.steady)
        V = self.V[rows]
        r = V.shape[1]
        if transient:
            part = out[:, : transient.stop - transient.start]
            _add_product(part, V, correction[transient, r:])
        if held:
            stacked = np.hstack([self.standardization.held_basis(rows), V])
            np.matmul(stacked, correction[held].T, out=out[:, held.start - times.start :])
        return out

    def _fill_smoothed(self, first: int, stop: int, target: _Array, correction: _Array) -> None:
        """The paper's smoothed z of rows first:stop into ``target`` (n_rows, n_times)."""
        S = self.steady
        eta = correction[S:, : self.V.shape[1]]

        def rows_of(rows: slice) -> None:
            where = target[rows.start - first : rows.stop - first]
            self._transient(rows, where)
            if S:
                self._smooth_transient(where.T, rows, eta)

        for _ in map_threads(rows_of, tiles.row_blocks(first, stop, S + 1, self.align)):
            pass
        self._correct(first, stop, target, correction)

    def _correct(self, first: int, stop: int, target: _Array, correction: _Array) -> None:
        """``s = h + V delta`` of rows first:stop into ``target`` (n_rows, n_times), which
        holds ``h`` before the steady state (:meth:`_corrected`), tile by tile."""

        def tile(item: tuple[slice, slice]) -> None:
            rows, times = item
            where = target[rows.start - first : rows.stop - first, times]
            self._corrected(rows, times, where, correction)

        for _ in map_threads(tile, tiles.tiles(first, stop, self.n_times, target, self.align)):
            pass

    def projection(self, columns: slice, times: slice | None = None) -> _Array:
        """These rows' share of ``zeta = V^T z_{t|t}`` at steps ``times``: (n_steps, r).

        ``times`` defaults to the steps before the steady state, the only ones
        :meth:`correction_from` needs (after it ``zeta`` follows from ``u``). The shares of
        disjoint rows add up to ``zeta``. No (n_steps, n_rows) array is formed.
        """
        first, stop, _ = (slice(0, self.steady) if times is None else times).indices(self.n_times)
        self.standardization.prepare()
        share = np.zeros((stop - first, self.V.shape[1]))
        asked = columns.indices(self.n_sources)[:2]
        whole = self._whole(*asked)  # z of whole positions; the asked rows' share only
        for steps, rows in tiles.tiles_by_steps(whole.start, whole.stop, first, stop, self.align):
            shape = (rows.stop - rows.start, steps.stop - steps.start)
            z = self._standardized(self.u, rows, steps, np.empty(shape))
            kept = slice(max(rows.start, asked[0]), min(rows.stop, asked[1]))
            if kept.stop > kept.start:
                mine = z[kept.start - rows.start : kept.stop - rows.start]
                share[steps.start - first : steps.stop - first] += mine.T @ self.V[kept]
        return share

    def correction(self) -> _Array:
        """The "rts-standardized" correction (:meth:`correction_from`), by one pass over
        every row; computed once, then kept.

        ``zeta`` is summed over groups of :data:`PROJECTION_COLUMNS` rows in a fixed order,
        per tile of :data:`PROJECTION_STEPS` steps on worker threads: the same bits whatever
        the number of threads.
        """
        if self._delta is None:
            self.standardization.prepare()
            S = self.steady
            zeta = np.zeros((S, self.V.shape[1]))
            items = [
                (rows, steps)
                for steps in tiles.slices(0, S, tiles.PROJECTION_STEPS)
                for rows in tiles.slices(
                    0, self.n_sources, tiles.aligned(tiles.PROJECTION_COLUMNS, self.align)
                )
            ]
            shares = map_threads(lambda item: self.projection(*item), items)
            for (_, steps), share in zip(items, shares, strict=True):
                zeta[steps] += share  # in a fixed order, whatever the number of threads
            self._delta = self.correction_from(zeta)
        return self._delta

    def correction_from(self, zeta: _Array, eta: _Array | None = None) -> _Array:
        """The correction from ``zeta = V^T z_{t|t}`` before the steady state.

        Parameters
        ----------
        zeta : ndarray, shape (steady, r)
            The sum of :meth:`projection` over every row.
        eta : ndarray, shape (n_times - steady, r), optional
            The rank-r smoothed ``h`` of the steady state (default computed here).

        Returns
        -------
        ndarray, shape (n_times, 2 r)
            ``[eta_t, delta_t]``: ``delta`` of the spectral module docstring in the last
            r columns, ``eta`` in the first r from ``steady`` on (zeros before).
        """
        S, T, r = self.steady, self.n_times, self.V.shape[1]
        full = np.empty((T, r))
        full[:S] = zeta
        if S < T:
            np.matmul(self.u[S:], self.standardization.projector(), out=full[S:])
        correction = np.zeros((T, 2 * r))
        correction[:, r:] = self.recursions.correction(full)
        if S < T:
            correction[S:, :r] = self._steady_means() if eta is None else eta
        return correction

    def _steady_means(self) -> _Array:
        """eta (T - steady, r): ``h_t = D V eta_t`` from ``steady`` on (h's scalar recursion
        on ``u``, which stays in span ``D V`` there)."""
        _, beta = self.recursions.gains
        return backward(self.u[self.steady :], beta[self.steady :], self.a)

    # --- a whole output in memory -------------------------------------------------------

    def time_major(self, name: str) -> NDArray[np.float64]:
        """Output ``name`` whole, (n_times, n_sources), filled tile by tile in threads.

        ``"z"`` of ``"rts-standardized"`` is filled with ``z_{t|t}`` before the steady state
        and the projection ``zeta`` in one pass, smoothed in place, then corrected: one
        (n, T) array.

        Returns
        -------
        ndarray, shape (n_times, n_sources)
            C-ordered: the scalar recursion of the paper's smoother runs along its rows.
        """
        n, T = self.n_sources, self.n_times
        result = self._allocate(time_major=True)
        if not (name == "z" and self.smoother == "rts-standardized" and self._delta is None):
            return self._fill_block(name, slice(0, n), out=result)
        self.standardization.prepare()
        S = self.steady
        eta = self._steady_means() if S < T else None
        zeta = np.zeros((S, self.V.shape[1]))
        if S:
            items = tiles.tiles(0, n, S, result.T, self.align)

            def transient(item: tuple[slice, slice]) -> _Array:  # z_{t|t}, its share of zeta
                rows, times = item
                z = self._standardized(self.u, rows, times, result[times, rows].T)
                return z.T @ self.V[rows]

            for (_, times), share in zip(items, map_threads(transient, items), strict=True):
                zeta[times] += share  # in tile order, whatever the number of threads
            n_parts = min(8, max(1, n // SMOOTH_PART_COLUMNS))
            parts = list(tiles.slices(0, n, -(-n // n_parts)))
            for _ in map_threads(lambda p: self._smooth_transient(result[:, p], p, eta), parts):
                pass
        self._delta = self.correction_from(zeta, eta)
        eta = None  # copied into the correction
        self._correct(0, n, result.T, self._delta)
        return result


def _add_product(out: _Array, V_rows: _Array, delta: _Array) -> _Array:
    """``out += V_rows @ delta.T`` ((k, n) += (k, r) (r, n)) without a (k, n) temporary
    where ``out`` is C-contiguous (BLAS gemm with beta = 1 accumulates into it); else
    through a temporary in ``out``'s own order."""
    if not out.flags.c_contiguous:
        if out.strides[0] < out.strides[1]:  # a view of a time-major array
            out.T[...] += delta @ V_rows.T
        else:
            out += V_rows @ delta.T
        return out
    # out^T (n, k) += delta (n, r) @ V_rows^T (r, k), every operand column-major
    a = np.asfortranarray(delta)
    b, trans_b = (V_rows, 1) if V_rows.flags.f_contiguous else (V_rows.T, 0)
    blas.dgemm(1.0, a, b, beta=1.0, c=out.T, trans_b=trans_b, overwrite_c=1)
    return out
