r"""The spectral path's standardization per position: ``W_t^(alpha)`` in 3 x 3 blocks.

docs/model.md §2 ("Standardizing a position as a whole"). In the singular basis
``Psi_t = V Diag(omega_t) V^T``, so the block of position ``i`` (rows ``3i .. 3i + 2`` of
``V``, ``V_i``) is

    B_t(i) = V_i Diag(omega_t) V_i^T,   six numbers  b_ab = sum_k V_ia,k V_ib,k omega_t,k,

one product of the six rows ``V_a o V_b`` of each position with ``omega_t``: twice the
product of the column form's raw weights ``(V o V) omega_t``. The standardized estimate of
the position is ``z_t[c(i)] = B_t(i)^(-alpha) (V u_t)[c(i)]``, the power taken in closed form
(``skf_ref.method._powers.sym3_apply``: trigonometric eigenvalues and a Hermite
interpolation of ``x^-alpha``, compiled by numba where it is installed). In the steady
state the blocks are held: ``F_i = B(i)^(-alpha)`` once per position, and
``z_t = (F V) u_t`` is one product, as the column form's ``(D V) u_t``.

Before it, the steady state's rule is applied one component at a time: a component ``k``
within ``STEADY_RTOL / 2`` of its last stored value from step ``t_k`` on
(``skf_ref.method._paths.recursions``) is held there from ``t_k`` on. Its part of every
block is then ``omega_k V_a,k V_b,k`` at every step, summed once per position with the
other held components; a chunk of steps from ``t`` computes only the components not held at
``t``, ``B_t(i) = sum_{t_k > t} omega_t,k V_a,k V_b,k + sum_{t_k <= t} (held)``, one
product with one more column. Strong components settle within tens of steps, weak ones
never: on the benchmark problem (``validation/standardization_bench.py``, 1000 steps,
chunks of 128) the product shrinks to 64 % (60 % step by step). A held component moves a
diagonal entry (a sum of nonnegative terms) by at most ``STEADY_RTOL`` relative and an
off-diagonal one by at most ``STEADY_RTOL (b_aa b_bb)^(1/2)`` (Cauchy-Schwarz): the block
moves by ``STEADY_RTOL`` relative to its norm, as the steady state's weights do.

A standardization applied to a second data set keeps ``B_t(i)^(-alpha)`` of the steps
before the steady state (six numbers a position and step) when they take at most
:data:`~.weights.CACHE_BYTES`, as the column form keeps its weights: every later data set
then costs the products ``V_i u_t`` and one 3 x 3 product a block, not a power. Steps
are taken in chunks cut at the multiples of ``_CHUNK_STEPS``, whatever the tile, and a
chunk holds the components held at its first multiple: a block is the same sum in every
tile, so kept and computed estimates agree to rounding.

:class:`BlockStandardization` has the methods of the column form's
:class:`~.weights.Standardization`, which :class:`~.spectral_rows.SpectralRows` calls; its
rows come in whole positions (``align = 3``).
"""

import threading
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._utils.threads import map_threads
from .._powers import SYM3_ENTRIES, sym3_apply, sym3_power, sym3_times
from . import tiles
from .recursions import STEADY_RTOL
from .weights import CACHE_BYTES

__all__ = ["BlockStandardization"]

_Array = NDArray[np.float64]
_DIAGONAL = (0, 3, 5)  # the diagonal among SYM3_ENTRIES
#: Positions computed at once within a tile: their blocks, means and estimates (12 numbers
#: a position and step) stay in cache between the product, the power and the copy out.
_CHUNK_POSITIONS = 256
#: Steps computed at once: the components not held at the first of them enter the product.
_CHUNK_STEPS = 128


class BlockStandardization:
    """``W_t^(alpha)`` per position of three columns: no data needed.

    Parameters
    ----------
    V : ndarray, shape (n_sources, r)
        ``n_sources`` a multiple of 3, positions in MNE's order.
    omega : ndarray, shape (n_stored, r)
        ``Psi_t = V Diag(omega_t) V^T`` (:class:`~.recursions.Recursions`, or the smoothed
        weights of ``skf_ref.method._paths.smoothed_weights``); the last row holds from
        step ``steady`` on.
    steady : int
        First step of the steady state (``n_times``: none).
    n_times : int
    exponent : float
    """

    #: Rows standardized together: a position's three columns.
    align = 3

    def __init__(
        self, V: _Array, omega: _Array, steady: int, n_times: int, exponent: float
    ) -> None:
        self.V, self.omega, self.exponent = V, omega, exponent
        self.steady, self.n_times = steady, n_times
        self._held: Any = None  # (F V, diag F) of the steady state
        self._projector: Any = None
        self._cache: Any = None  # B_t(i)^(-alpha) before steady: (6, n_positions, steady)
        self.applications = 0  # data sets this standardization served
        # the blocks of a whole output: the compiled closed form pays off on many of them
        self._jobs = len(V) // 3 * min(steady, n_times)
        self._pairs = threading.local()  # each worker's last rows and their products
        # the components in the order they are held, the last first (module docstring)
        self._held_from = _held_from(omega)
        self._order = np.argsort(-self._held_from, kind="stable")
        self._held_from = self._held_from[self._order]

    def __getstate__(self) -> dict[str, Any]:
        """Sent to a job in another process (``skf_ref.io._jobs``) without the workers'
        kept products, which are this process's threads'."""
        state = self.__dict__.copy()
        del state["_pairs"]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._pairs = threading.local()

    @property
    def held(self) -> bool:
        """bool : Whether the recording reaches the steady state."""
        return self.steady < self.n_times

    @property
    def kept(self) -> bool:
        """bool : Whether the powers of the steps before ``steady`` are kept
        (:data:`~.weights.CACHE_BYTES`)."""
        return self._cache is not None

    def _blocks(self, rows: slice, times: slice, tile: Any = None) -> _Array:
        """The entries ``b_ab`` (6, n_positions, n_steps) of the blocks at ``rows`` and
        ``times`` (before ``steady``, within one chunk of :func:`_step_chunks`):
        ``B_t(i) = V_i Diag(omega_t) V_i^T``, the components held from the chunk's anchor on
        summed once (module docstring). With ``tile`` (the rows
        of the tile ``rows`` is part of) the products of ``V``'s rows are kept for the
        worker's next tile of the same rows: the tiles of a row block come one after
        another, and the products cost a quarter of the blocks' product if made anew."""
        pairs, held_sums = self._products(rows, tile)
        # components 0 .. c - 1 (in held order) are not held at the chunk's first step
        c = int(np.searchsorted(-self._held_from, -_anchor(times.start), "left"))
        n_steps = times.stop - times.start
        pairs[:, 0] = held_sums[:, c]
        omega = np.empty((c + 1, n_steps))
        omega[0] = 1.0
        omega[1:] = self.omega[times][:, self._order[:c]].T
        # b_ab = (V_a o V_b) omega_t                                   docs/model.md §2
        return (pairs[:, : c + 1] @ omega).reshape(6, len(pairs) // 6, n_steps)

    def _products(self, rows: slice, tile: Any = None) -> tuple[_Array, _Array]:
        """The rows ``V_a o V_b`` of the positions at ``rows`` (6 n_positions, 1 + r), the
        components in held order after a free first column, and the sums of the held ones
        (6 n_positions, r + 1): column ``c`` is ``sum_{j >= c} (V_a o V_b)_j omega_j``."""
        kept: dict[Any, Any] = self._pairs.__dict__
        if tile is not None and kept.get("tile") != tile:
            kept.clear()
            kept["tile"] = tile
        key = (rows.start, rows.stop)  # a tile's weights take it whole, its z in chunks
        if tile is not None and key in kept:
            return kept[key]
        Vi = self.V[rows][:, self._order].reshape(-1, 3, self.V.shape[1])
        pairs = np.empty((6 * len(Vi), 1 + self.V.shape[1]))
        for k, (a, b) in enumerate(SYM3_ENTRIES):
            np.multiply(Vi[:, a], Vi[:, b], out=pairs[k * len(Vi) : (k + 1) * len(Vi), 1:])
        held_sums = np.zeros((len(pairs), pairs.shape[1]))
        weighted = pairs[:, 1:] * self.omega[-1, self._order]
        np.cumsum(weighted[:, ::-1], axis=1, out=held_sums[:, -2::-1])
        if tile is not None:
            kept[key] = (pairs, held_sums)
        return pairs, held_sums

    def prepare(self) -> None:
        """Compute what the tiles share, in the calling thread (the workers only read it)."""
        if self.held and self._held is None:
            n, r = self.V.shape
            Vi = self.V.reshape(-1, 3, r)
            held = np.stack([(Vi[:, a] * Vi[:, b]) @ self.omega[-1] for a, b in SYM3_ENTRIES])
            F = sym3_power(held, self.exponent)
            full = np.empty((n // 3, 3, 3))
            for k, (i, j) in enumerate(SYM3_ENTRIES):
                full[:, i, j] = full[:, j, i] = F[k]
            # z_t = (F V) u_t: F_i V_i, the rows of position i
            held_basis = np.einsum("pij,pjr->pir", full, self.V.reshape(-1, 3, r))
            diagonal = F[list(_DIAGONAL)].T.reshape(n)
            self._held = (held_basis.reshape(n, r), diagonal)
        n_positions, S = len(self.V) // 3, min(self.steady, self.n_times)
        if (
            self._cache is None
            and self.applications > 1
            and 0 < 48 * n_positions * S <= CACHE_BYTES
        ):
            cache = np.empty((6, n_positions, S))

            def fill(chunk: slice) -> None:  # the chunks an application computes
                where = slice(chunk.start // 3, chunk.stop // 3)
                for steps in _step_chunks(0, S):
                    b = self._blocks(chunk, steps, tile=(chunk.start, chunk.stop))
                    cache[:, where, steps] = sym3_power(b, self.exponent, n_blocks=self._jobs)

            for _ in map_threads(fill, tiles.slices(0, len(self.V), 3 * _CHUNK_POSITIONS)):
                pass
            self._cache = cache

    def transient(self, rows: slice, times: slice, out: _Array | None = None) -> _Array:
        """The diagonal of ``W_t^(alpha)`` at ``rows`` and ``times`` (steps before
        ``steady``): (n_rows, n_steps)."""
        out = np.empty((rows.stop - rows.start, times.stop - times.start)) if out is None else out
        for steps in _step_chunks(times.start, times.stop):
            if self._cache is not None:
                F = self._cache[:, rows.start // 3 : rows.stop // 3, steps]
            else:
                b = self._blocks(rows, steps, (rows.start, rows.stop))
                F = sym3_power(b, self.exponent, n_blocks=self._jobs)
            where = out[:, steps.start - times.start : steps.stop - times.start]
            _scatter(where, F[list(_DIAGONAL)])
        return out

    def scale(self, rows: slice) -> _Array:
        """The held diagonal of ``W^(alpha)`` at ``rows``, (n_rows, 1), from ``steady`` on."""
        self.prepare()
        return self._held[1][rows, None]

    def held_basis(self, rows: slice) -> _Array:
        """``F V`` at ``rows``, (n_rows, r): ``z_t = (F V) u_t`` from ``steady`` on."""
        return self._held[0][rows]

    def standardized(self, u: _Array, rows: slice, times: slice, out: _Array) -> _Array:
        """``z_t[c(i)] = B_t(i)^(-alpha) (V u_t)[c(i)]`` at ``rows`` (whole positions) and
        ``times`` into ``out`` (n_rows, n_steps).  docs/model.md §2"""
        transient, held = tiles.split(times, self.steady)
        if transient:
            first = rows.start
            # a few hundred positions at a time: the blocks, the means and z stay in cache
            for chunk in tiles.slices(rows.start, rows.stop, 3 * _CHUNK_POSITIONS):
                for steps in _step_chunks(transient.start, transient.stop):
                    # (V u_t)[3i + a] as v[a, i, t]: one product per orientation
                    Vi = self.V[chunk].reshape(-1, 3, self.V.shape[1]).transpose(1, 0, 2)
                    v = np.matmul(Vi, u[steps].T)
                    if self._cache is not None:  # the kept powers: one product a block
                        z = sym3_times(
                            self._cache[:, chunk.start // 3 : chunk.stop // 3, steps], v
                        )
                    else:
                        b = self._blocks(chunk, steps, tile=(rows.start, rows.stop))
                        z = sym3_apply(b, v, self.exponent, n_blocks=self._jobs)
                    where = slice(steps.start - times.start, steps.stop - times.start)
                    _scatter(out[chunk.start - first : chunk.stop - first, where], z)
        if held:  # one product: z_t = (F V) u_t
            np.matmul(self.held_basis(rows), u[held].T, out=out[:, held.start - times.start :])
        return out

    def raw(self, rows: slice, times: slice) -> _Array:
        """The diagonal of ``Psi_t`` (the raw weights ``w_t``) at ``rows`` and any steps,
        (n_rows, n_steps), for a diagnosis."""
        first, stop, _ = times.indices(self.n_times)
        index = np.minimum(np.arange(first, stop), len(self.omega) - 1)
        return (self.V[rows] ** 2) @ self.omega[index].T

    def projector(self) -> _Array:
        """``V^T F V`` (r, r): ``zeta_t = V^T z_t`` from ``u_t`` in the steady state."""
        if self._projector is None:
            self.prepare()
            self._projector = self.held_basis(slice(None)).T @ self.V
        return self._projector


def _anchor(step: int) -> int:
    """The first step of the chunk of :data:`_CHUNK_STEPS` steps that holds ``step``."""
    return step - step % _CHUNK_STEPS


def _step_chunks(first: int, stop: int) -> list[slice]:
    """``first:stop`` cut at the multiples of :data:`_CHUNK_STEPS`: the components held in a
    chunk are those held at its anchor, so a block is the same sum whatever tile it is
    computed in (the kept powers and the computed ones agree)."""
    cuts = [first, *range(_anchor(first) + _CHUNK_STEPS, stop, _CHUNK_STEPS), stop]
    return [slice(a, b) for a, b in zip(cuts[:-1], cuts[1:], strict=True) if b > a]


def _scatter(out: _Array, z: _Array) -> None:
    """``out[3 i + a] = z[a, i]`` (rows 3i + a: orientation a of position i) for ``out``
    (3 n, n_steps) of either memory order, through a view when there is one (a third of
    the time of three strided copies into a time-major output)."""
    view = out.reshape(-1, 3, out.shape[1])
    if np.shares_memory(view, out):
        view[...] = z.transpose(1, 0, 2)
    else:  # pragma: no cover - a reshape of these outputs is always a view
        for a in range(3):
            out[a::3] = z[a]


def _held_from(omega: _Array) -> NDArray[np.intp]:
    """The step from which each component of ``omega`` (n_stored, r) stays within
    ``STEADY_RTOL / 2`` of its last stored value: the steady state's rule, one component at
    a time (``n_stored`` for one never within, or NaN: a missing step)."""
    last = omega[-1]
    with np.errstate(invalid="ignore"):
        far = ~(np.abs(omega - last) <= STEADY_RTOL / 2 * last)
    after_last_far = len(omega) - np.argmax(far[::-1], axis=0)
    return np.where(far.any(axis=0), after_last_far, 0)
