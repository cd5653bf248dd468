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

:class:`BlockStandardization` has the methods of the column form's
:class:`~.weights.Standardization`, which :class:`~.spectral_rows.SpectralRows` calls; its
rows come in whole positions (``align = 3``).
"""

import threading
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._powers import SYM3_ENTRIES, sym3_apply, sym3_power
from . import tiles

__all__ = ["BlockStandardization"]

_Array = NDArray[np.float64]
_DIAGONAL = (0, 3, 5)  # the diagonal among SYM3_ENTRIES
#: Positions computed at once within a tile: their blocks, means and estimates (12 numbers
#: a position and step) stay in cache between the product, the power and the copy out.
_CHUNK_POSITIONS = 256


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
        self.applications = 0  # data sets this standardization served
        self.kept = False  # the column form keeps its transient weights; blocks do not
        # the blocks of a whole output: the compiled closed form pays off on many of them
        self._jobs = len(V) // 3 * min(steady, n_times)
        self._pairs = threading.local()  # each worker's last rows and their products

    @property
    def held(self) -> bool:
        """bool : Whether the recording reaches the steady state."""
        return self.steady < self.n_times

    def _blocks(self, rows: slice, omega: _Array, tile: Any = None) -> _Array:
        """The entries ``b_ab`` (6, n_positions, n_steps) of the blocks at ``rows`` for the
        rows ``omega`` (n_steps, r): ``B_t(i) = V_i Diag(omega_t) V_i^T``. With ``tile`` (the
        rows of the tile ``rows`` is part of) the products of ``V``'s rows are kept for the
        worker's next tile of the same rows: the tiles of a row block come one after
        another, and the products cost a quarter of the blocks' product if made anew."""
        pairs = self._products(rows, tile)
        # b_ab = (V_a o V_b) omega_t                                   docs/model.md §2
        return (pairs @ omega.T).reshape(6, len(pairs) // 6, len(omega))

    def _products(self, rows: slice, tile: Any = None) -> _Array:
        """The rows ``V_a o V_b`` of the positions at ``rows`` (6 n_positions, r)."""
        kept = self._pairs.__dict__
        if tile is not None and kept.get("tile") != tile:
            kept.clear()
            kept["tile"] = tile
        key = (rows.start, rows.stop)  # a tile's weights take it whole, its z in chunks
        if tile is not None and key in kept:
            return kept[key]
        Vi = self.V[rows].reshape(-1, 3, self.V.shape[1])
        pairs = np.concatenate([Vi[:, a] * Vi[:, b] for a, b in SYM3_ENTRIES])
        if tile is not None:
            kept[key] = pairs
        return pairs

    def prepare(self) -> None:
        """Compute what the tiles share, in the calling thread (the workers only read it)."""
        if self.held and self._held is None:
            n, r = self.V.shape
            held = self._blocks(slice(0, n), self.omega[-1:])[..., 0]
            F = sym3_power(held, self.exponent)
            full = np.empty((n // 3, 3, 3))
            for k, (i, j) in enumerate(SYM3_ENTRIES):
                full[:, i, j] = full[:, j, i] = F[k]
            # z_t = (F V) u_t: F_i V_i, the rows of position i
            held_basis = np.einsum("pij,pjr->pir", full, self.V.reshape(-1, 3, r))
            diagonal = F[list(_DIAGONAL)].T.reshape(n)
            self._held = (held_basis.reshape(n, r), diagonal)

    def transient(self, rows: slice, times: slice, out: _Array | None = None) -> _Array:
        """The diagonal of ``W_t^(alpha)`` at ``rows`` and ``times`` (steps before
        ``steady``): (n_rows, n_steps)."""
        F = sym3_power(
            self._blocks(rows, self.omega[times], (rows.start, rows.stop)),
            self.exponent,
            n_blocks=self._jobs,
        )
        out = np.empty((3 * F.shape[1], F.shape[2])) if out is None else out
        for a, k in enumerate(_DIAGONAL):
            out[a::3] = F[k]
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
            omega, u_steps = self.omega[transient], u[transient].T
            n = transient.stop - transient.start
            first = rows.start
            # a few hundred positions at a time: the blocks, the means and z stay in cache
            for chunk in tiles.slices(rows.start, rows.stop, 3 * _CHUNK_POSITIONS):
                v = (self.V[chunk] @ u_steps).reshape(-1, 3, n)
                b = self._blocks(chunk, omega, tile=(rows.start, rows.stop))
                v = np.ascontiguousarray(v.transpose(1, 0, 2))
                z = sym3_apply(b, v, self.exponent, n_blocks=self._jobs)
                _scatter(out[chunk.start - first : chunk.stop - first, :n], z)
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
