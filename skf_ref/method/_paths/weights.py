"""The spectral path's standardization weights ``W_t^(alpha)``, for any rows and steps.

They depend on the model and the exponent only, not on the data: ``w_t = (V o V) omega_t``
(docs/model.md §2, §2.2 eq. (7)), one number a row from the steady state on. A model
applied to many data sets keeps those of the steps before it (:data:`CACHE_BYTES`).

:class:`Standardization` is the column form; ``skf_ref.method._paths.block_weights`` holds
the standardization per position, with the same methods: :meth:`~Standardization.
standardized` (``z_t = W_t^(alpha) V u_t`` of any rows and steps), :meth:`~Standardization.
held_basis` (``W V`` in the steady state), the weights themselves (``transient``,
``scale``) and the raw weights for a diagnosis.
"""

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._utils.threads import map_threads
from .._standardization import standardization_weights
from . import tiles

__all__ = ["CACHE_BYTES", "Standardization"]

#: The standardization weights of the steps before the steady state are kept, for every
#: exponent applied to a second data set, when they take at most this much: a model
#: applied to many data sets then pays for them once.
CACHE_BYTES = 256 * 2**20


_Array = NDArray[np.float64]


class Standardization:
    """``W_t^(alpha)`` of one model and exponent, for any rows and steps: no data needed.

    Parameters
    ----------
    V : ndarray, shape (n_sources, r)
    omega : ndarray, shape (n_stored, r)
        ``s^2 p_{t|t-1} / (s^2 p_{t|t-1} + 1)`` (:class:`~.recursions.Recursions`): the
        raw weights are ``(V o V) omega_t``; the last row holds from step ``steady`` on.
    steady : int
        First step of the steady state (``n_times``: none).
    n_times : int
    exponent : float
    """

    #: Rows standardized together: one (each column on its own).
    align = 1

    def __init__(
        self, V: _Array, omega: _Array, steady: int, n_times: int, exponent: float
    ) -> None:
        self.V, self.omega, self.exponent = V, omega, exponent
        self.steady, self.n_times = steady, n_times
        # what the tiles share, computed once (prepare, projector)
        self._scale: Any = None
        self._cache: Any = None
        self._projector: Any = None
        self.applications = 0  # data sets this standardization served (SpectralRows)

    @property
    def held(self) -> bool:
        """bool : Whether the recording reaches the steady state."""
        return self.steady < self.n_times

    @property
    def kept(self) -> bool:
        """bool : Whether the weights of the steps before ``steady`` are kept
        (:data:`CACHE_BYTES`)."""
        return self._cache is not None

    def prepare(self) -> None:
        """Compute what the tiles share, in the calling thread (the workers only read it)."""
        if self.held and self._scale is None:
            # W^(alpha) = Diag((V o V) omega)^(-alpha), one number a row  §2.2 (7)
            raw = np.empty(len(self.V))
            for rows in tiles.slices(0, len(self.V), tiles.PROJECTION_COLUMNS):
                np.matmul(np.square(self.V[rows]), self.omega[-1], out=raw[rows])
            self._scale = standardization_weights(raw, self.exponent, out=raw)
        n, S = len(self.V), self.steady
        if self._cache is None and self.applications > 1 and 0 < 8 * n * S <= CACHE_BYTES:
            cache = np.empty((S, n))  # time-major, as the outputs held in memory

            def fill(item: tuple[slice, slice]) -> None:  # the tiles of a time-major output
                rows, times = item
                self.transient(rows, times, cache[times, rows].T)

            for _ in map_threads(fill, tiles.tiles(0, n, S, cache.T)):
                pass
            self._cache = cache

    def transient(self, rows: slice, times: slice, out: _Array | None = None) -> _Array:
        """The weights of ``rows`` at ``times`` (steps before ``steady``): (n_rows, n_steps).

        Parameters
        ----------
        rows, times : slice
        out : ndarray, shape (n_rows, n_steps), optional
            Where to write them (default a new array).

        Returns
        -------
        ndarray
            A view of the kept weights, or ``out`` filled.
        """
        if self._cache is not None:
            return self._cache[times, rows].T
        # w_t = (V o V) omega_t                                          §2.2 (7)
        w = np.matmul(np.square(self.V[rows]), self.omega[times].T, out=out)
        return standardization_weights(w, self.exponent, out=w)

    def scale(self, rows: slice) -> _Array:
        """The held weights of ``rows``, (n_rows, 1): ``W^(alpha)`` from ``steady`` on."""
        return self._scale[rows, None]

    def held_basis(self, rows: slice) -> _Array:
        """``D V`` at ``rows``, (n_rows, r): ``z_t = (D V) u_t`` from ``steady`` on."""
        return self.V[rows] * self._scale[rows, None]

    def standardized(self, u: _Array, rows: slice, times: slice, out: _Array) -> _Array:
        """``z_t = W_t^(alpha) V u_t`` of ``rows`` at ``times`` into ``out`` (n_rows,
        n_steps), for whitened coordinates ``u`` (n_times, r).  §2.2 (6)-(7)"""
        transient, held = tiles.split(times, self.steady)
        V = self.V[rows]
        if transient:
            part = out[:, : transient.stop - transient.start]
            np.matmul(V, u[transient].T, out=part)
            part *= self.transient(rows, transient, np.empty_like(part))
        if held:  # one product: z_t = (D V) u_t
            part = out[:, held.start - times.start :]
            np.matmul(self.held_basis(rows), u[held].T, out=part)
        return out

    def raw(self, rows: slice, times: slice) -> _Array:
        """Raw weights ``w_t`` of ``rows`` at any steps, (n_rows, n_steps), for a diagnosis."""
        first, stop, _ = times.indices(self.n_times)
        index = np.minimum(np.arange(first, stop), len(self.omega) - 1)
        return (self.V[rows] ** 2) @ self.omega[index].T

    def projector(self) -> _Array:
        """``V^T D V`` (r, r): ``zeta_t = V^T z_t`` from ``u_t`` in the steady state."""
        if self._projector is None:
            self.prepare()
            self._projector = self.held_basis(slice(None)).T @ self.V
        return self._projector
