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

from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._powers import SYM3_ENTRIES, sym3_apply, sym3_power
from . import tiles

__all__ = ["BlockStandardization"]

_Array = NDArray[np.float64]
_DIAGONAL = (0, 3, 5)  # the diagonal among SYM3_ENTRIES


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

    @property
    def held(self) -> bool:
        """bool : Whether the recording reaches the steady state."""
        return self.steady < self.n_times

    def _blocks(self, rows: slice, omega: _Array) -> _Array:
        """The entries ``b_ab`` (6, n_positions, n_steps) of the blocks at ``rows`` for the
        rows ``omega`` (n_steps, r): ``B_t(i) = V_i Diag(omega_t) V_i^T``."""
        Vi = self.V[rows].reshape(-1, 3, self.V.shape[1])
        pairs = np.concatenate([Vi[:, a] * Vi[:, b] for a, b in SYM3_ENTRIES])
        # b_ab = (V_a o V_b) omega_t                                   docs/model.md §2
        return (pairs @ omega.T).reshape(6, len(Vi), len(omega))

    def prepare(self) -> None:
        """Compute what the tiles share, in the calling thread (the workers only read it)."""
        if self.held and self._held is None:
            n, r = self.V.shape
            F = sym3_power(self._blocks(slice(0, n), self.omega[-1:])[..., 0], self.exponent)
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
        F = sym3_power(self._blocks(rows, self.omega[times]), self.exponent, n_blocks=self._jobs)
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
            part = out[:, : transient.stop - transient.start]
            v = (self.V[rows] @ u[transient].T).reshape(-1, 3, part.shape[1])
            b = self._blocks(rows, self.omega[transient])
            v = np.ascontiguousarray(v.transpose(1, 0, 2))
            z = sym3_apply(b, v, self.exponent, n_blocks=self._jobs)
            for a in range(3):  # rows 3i + a: orientation a of each position
                part[a::3] = z[a]
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
