"""The result type every computational path returns, and the per-position amplitude.

The result holds results; the paths compute them (the smoothers included). A path hands
over its outputs as arrays, or as a ``LazyOutputs`` (``_outputs``) that computes them when
asked.
"""

from __future__ import annotations

import copy
from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils.checks import InputError, check_array, check_choice, check_int
from .._utils.reprs import html_table
from .._utils.threads import map_threads
from ._model import StateSpaceModel
from ._outputs import ARRAYS, LazyOutputs
from ._settings import Settings
from ._standardization import overflow_cause

__all__ = ["Reconstruction", "amplitude_from_components", "readonly", "stored_result"]

#: Bytes of z per work item of the amplitude's worker threads.
_AMPLITUDE_BYTES = 4 * 2**20
#: Default bytes of one block of rows of an output held in memory (:meth:`blocks`).
_BLOCK_BYTES = 4 * 2**20
#: The outputs that are standardized: undefined (NaN) at a missing step.
_STANDARDIZED = ("z", "z_filtered", "weights")


def amplitude_from_components(z: ArrayLike, n_components: int = 3) -> NDArray[np.float64]:
    """Position amplitude: the Euclidean norm of each position's consecutive components.

    Parameters
    ----------
    z : array_like, shape (n_components * n_positions, n_times)
        Standardized source estimate, MNE column order (x, y, z of position 0, then 1, ...).
        NaN at a missing step stays NaN there.
    n_components : {1, 2, 3}
        Components per position (3 for free orientation, 1 for fixed).

    Returns
    -------
    amplitude : ndarray, shape (n_positions, n_times)

    Examples
    --------
    >>> amplitude_from_components(np.array([[3.0], [4.0], [0.0], [0.0], [0.0], [1.0]]))
    array([[5.],
           [1.]])
    """
    n_components = check_int("n_components", n_components, minimum=1, maximum=3)
    z = check_array("z", z, ("n_components * n_positions", "n_times"), finite=False)
    if np.isinf(z).any():
        raise InputError("z contains Inf")
    if z.shape[0] % n_components:
        raise InputError(
            f"z must have shape (n_components * n_positions, n_times) with n_components="
            f"{n_components}, got shape {z.shape}"
        )
    if n_components == 1:
        return np.abs(z)
    if z.flags.f_contiguous and not z.flags.c_contiguous:  # time-major, as the paths hold it
        per_time = z.T.reshape(z.shape[1], -1, n_components)  # a view: (T, positions, k)
        out = np.empty(per_time.shape[:2])
        steps = max(1, _AMPLITUDE_BYTES // (8 * z.shape[0]))  # on every core, step blocks

        def block(times: slice) -> None:
            out[times] = _norm_of_last(per_time[times])

        for _ in map_threads(block, (slice(t, t + steps) for t in range(0, len(out), steps))):
            pass
        return out.T
    return _norm_of_last(np.moveaxis(z.reshape(-1, n_components, z.shape[1]), 1, 2))


def _norm_of_last(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sqrt(sum(x**2, axis=-1))`` for a short last axis, one component at a time: no
    temporary as large as ``x`` (``np.linalg.norm`` squares it whole, and copies a
    transposed array first)."""
    out = np.square(x[..., 0])
    for component in range(1, x.shape[-1]):
        out += np.square(x[..., component])
    return np.sqrt(out, out=out)


def readonly(value: ArrayLike) -> NDArray[np.float64]:
    """``value`` as a float array that cannot be written through (a view, not a copy).

    Examples
    --------
    >>> readonly([1, 2]).flags.writeable
    False
    """
    array = np.asarray(value, dtype=float)
    if array.flags.writeable:
        array = array.view()
        array.flags.writeable = False
    return array


def _setting(value: object) -> float | str:
    return float(value) if np.ndim(value) == 0 else "matrix"  # type: ignore[arg-type]


class Reconstruction:
    """A standardized Kalman filter reconstruction and the settings that produced it.

    All source-space arrays have shape (n_sources, n_times), MNE's layout, and are
    read-only. A path gives each output as an array, or leaves it to a ``lazy`` object
    that computes it on first access (the spectral path does this, so that asking for
    ``z`` at 150 000 sources does not also materialize four other arrays of the same
    size); printing a reconstruction never computes one. A reconstruction never changes
    once made: its attributes cannot be set, and :meth:`with_tuning` returns a new one.

    No output is NaN or infinite, except at the missing steps (``missing``: data columns
    that were all NaN, docs/model.md §2): there ``z``, ``z_filtered`` and ``weights`` are
    NaN (a step without a measurement has no standardization weights), while ``x`` and
    ``x_filtered`` hold the predicted, or for ``"rts-state"`` the smoothed, state. A
    reconstruction that would overflow elsewhere raises :class:`~skf_ref.InputError` saying
    which parameter or scale is out of range.

    Parameters
    ----------
    z, x, z_filtered, x_filtered, weights : array_like, shape (n_sources, n_times), optional
        The outputs (see Attributes); each one not given is computed by ``lazy``.
    log_likelihood : float
        Innovation log-likelihood over the observed steps.
    n_sources, n_times : int
    exponent : float
    smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}
    path : {"filterpy", "dense", "spectral"}
    theta0, q, transition : float or ndarray, shape (n_sources, n_sources)
    standardize : {"column", "position"}
    n_orient : {1, 3} or None
    missing : array_like of bool, shape (n_times,), optional
        The steps without a measurement; default none.
    lazy : LazyOutputs, optional
        What computes the outputs not given (``skf_ref.method._outputs.LazyOutputs``).
    min_raw_weight : float, optional
        The smallest raw weight ``w_t`` of the run, to say why an output overflowed
        (default asked of ``lazy``).
    tuning : TuneResult, optional

    Attributes
    ----------
    z : ndarray, shape (n_sources, n_times)
        Standardized estimate; smoothed when a smoother was asked, else ``z_filtered``.
    x : ndarray, shape (n_sources, n_times)
        Unstandardized means: the smoothed state ``x^s_t`` for ``"rts-state"`` and
        ``"rts-smoothed-weights"``, the filtered means ``x_{t|t}`` otherwise.
    z_filtered : ndarray, shape (n_sources, n_times)
        ``z_{t|t}`` of §2.2 eq. (6).
    x_filtered : ndarray, shape (n_sources, n_times)
        ``x_{t|t}`` of §2.2 eq. (5) (at a missing step the prediction ``x_{t|t-1}``).
    weights : ndarray, shape (n_sources, n_times)
        Diagonal of ``W_t^(alpha)``, §2.2 eq. (7), at each step: ``w_t ** -alpha`` for
        ``standardize="column"``, the diagonal of the blocks ``B_t(i)^(-alpha)`` for
        ``"position"`` (docs/model.md §2). Always the filter's (those of ``z_filtered``).
    log_likelihood : float
        Innovation log-likelihood ``sum_t log N(y_t - L x_{t|t-1}; 0, S_t)`` over the
        observed steps.
    n_sources, n_times : int
        The shape of every array.
    missing : ndarray of bool, shape (n_times,)
        The steps without a measurement (read-only).
    exponent : float
        The standardization exponent alpha.
    smoother : str or None
        ``None``, ``"rts-standardized"``, ``"rts-state"`` or ``"rts-smoothed-weights"``.
    path : str
        The path that computed it: ``"filterpy"``, ``"dense"`` or ``"spectral"``.
    theta0, q, transition : float or ndarray, shape (n_sources, n_sources)
        The model's ``P_0``, ``Q`` and ``A`` as given (a scalar ``c`` means ``c I``).
    standardize : {"column", "position"}
        Each column standardized on its own (the paper's), or each source position's
        ``n_orient`` columns as a whole (docs/model.md §2).
    n_orient : int or None
        Columns per source position, when given.
    tuning : TuneResult or None
        When the priors were chosen by the data (``"auto"``), how.

    Examples
    --------
    >>> z = np.array([[3.0], [4.0], [0.0], [1.0], [0.0], [0.0]])
    >>> r = Reconstruction(z=z, x=z, z_filtered=z, x_filtered=z, weights=z,
    ...                    log_likelihood=0.0, n_sources=6, n_times=1, exponent=0.5,
    ...                    smoother=None, path="dense", theta0=1.0, q=0.0)
    >>> r
    <Reconstruction | 6 sources x 1 steps, dense, exponent 0.5, filter only>
    >>> r.amplitude(3).ravel().tolist()
    [5.0, 1.0]
    """

    def __init__(
        self,
        *,
        z: ArrayLike | None = None,
        x: ArrayLike | None = None,
        z_filtered: ArrayLike | None = None,
        x_filtered: ArrayLike | None = None,
        weights: ArrayLike | None = None,
        log_likelihood: float,
        n_sources: int,
        n_times: int,
        exponent: float,
        smoother: str | None,
        path: str,
        theta0: float | NDArray[np.float64],
        q: float | NDArray[np.float64],
        transition: float | NDArray[np.float64] = 1.0,
        standardize: str = "column",
        n_orient: int | None = None,
        missing: ArrayLike | None = None,
        lazy: LazyOutputs | None = None,
        min_raw_weight: float | None = None,
        tuning: Any = None,
    ) -> None:
        self.n_sources, self.n_times = int(n_sources), int(n_times)
        given = dict(z=z, x=x, z_filtered=z_filtered, x_filtered=x_filtered, weights=weights)
        if lazy is None and any(value is None for value in given.values()):
            raise InputError("a Reconstruction needs every output, or lazy to compute them")
        missing = np.zeros(self.n_times, bool) if missing is None else np.asarray(missing)
        if missing.shape != (self.n_times,) or missing.dtype != bool:
            raise InputError(f"missing must be {self.n_times} booleans, got {missing!r}")
        self.missing = missing.copy()
        self.missing.flags.writeable = False
        self._lazy, self._min_raw_weight = lazy, min_raw_weight
        if not np.isfinite(log_likelihood):
            raise InputError(
                f"the innovation log-likelihood is {log_likelihood}: the data are too large "
                "for the noise (are Y and the noise in the same units?) or the model's "
                "covariances overflow"
            )
        self.log_likelihood = float(log_likelihood)
        self.exponent, self.smoother, self.path = float(exponent), smoother, path
        self.theta0, self.q, self.transition = theta0, q, transition
        self.standardize, self.n_orient = standardize, n_orient
        self.tuning = tuning
        self._arrays: dict[str, NDArray[np.float64]] = {}
        for name, value in given.items():
            if value is not None:
                self._arrays[name] = self._checked(name, readonly(value))
        self._frozen = True

    def __setattr__(self, name: str, value: object) -> None:
        if getattr(self, "_frozen", False):
            raise AttributeError(
                f"a Reconstruction is read-only: {name!r} cannot be set (with_tuning gives a "
                "copy with the priors' tuning)"
            )
        super().__setattr__(name, value)

    def with_tuning(self, tuning: Any) -> Reconstruction:
        """The same reconstruction, recording how the data chose its priors.

        Parameters
        ----------
        tuning : TuneResult or None

        Returns
        -------
        Reconstruction
            A new object; the arrays are shared (read-only), this one is unchanged.
        """
        other = copy.copy(self)
        object.__setattr__(other, "tuning", tuning)
        return other

    @property
    def lazy_outputs(self) -> LazyOutputs | None:
        """LazyOutputs or None : What computes the outputs not held in memory."""
        return self._lazy

    def computed(self, name: str) -> bool:
        """Whether output ``name`` is held in memory already.

        Parameters
        ----------
        name : {"z", "x", "z_filtered", "x_filtered", "weights"}

        Returns
        -------
        bool
        """
        check_choice("name", name, ARRAYS)
        return name in self._arrays

    def blocks(
        self, name: str, rows: int | None = None
    ) -> Iterator[tuple[slice, NDArray[np.float64]]]:
        """Output ``name`` block of rows by block, without holding it whole.

        Parameters
        ----------
        name : {"z", "x", "z_filtered", "x_filtered", "weights"}
        rows : int, optional
            Rows per block; default about 4 MiB a block.

        Yields
        ------
        rows : slice
        block : ndarray, shape (n_rows, n_times)
        """
        check_choice("name", name, ARRAYS)
        if rows is not None:
            rows = check_int("rows", rows)
        if self._lazy is not None and not self.computed(name):
            for where, block in self._lazy.blocks(name, rows):
                yield where, self._checked(name, block)
            return
        array = self._array(name)
        step = max(1, _BLOCK_BYTES // (8 * self.n_times)) if rows is None else rows
        for start in range(0, self.n_sources, step):
            where = slice(start, min(start + step, self.n_sources))
            yield where, array[where]

    def _shared(self, name: str) -> Any:
        """What every block of rows of output ``name`` needs of the others (the paper's
        smoother's correction, one pass over every row), or None: computed once, for blocks
        computed apart (:meth:`_block`)."""
        if self._lazy is None or self.computed(name):
            return None
        outputs = self._lazy
        return outputs.combine(name, [outputs.share(name, slice(0, self.n_sources))])

    def _block(self, name: str, rows: slice, shared: Any = None) -> NDArray[np.float64]:
        """Rows ``rows`` of output ``name``, (n_rows, n_times), checked as :meth:`blocks`
        checks them; ``shared`` is :meth:`_shared`'s answer. Jobs elsewhere (a process, a
        Dask worker) each compute their own rows from a copy of this reconstruction."""
        if self._lazy is None or self.computed(name):
            return self._array(name)[rows]
        return self._checked(name, self._lazy.block(name, rows, shared))

    def _hold(self, name: str, value: NDArray[np.float64]) -> None:
        """Keep ``value`` as output ``name``, computed elsewhere (by jobs, block by block,
        each block checked there)."""
        check_choice("name", name, ARRAYS)
        if value.shape != (self.n_sources, self.n_times):
            raise InputError(f"{name} must have shape {self.shape}, got {value.shape}")
        self._arrays[name] = readonly(value)

    def _checked(self, name: str, value: NDArray[np.float64]) -> NDArray[np.float64]:
        """``value`` (an output or a block of its rows), refused unless finite, NaN allowed
        only where a standardized output is undefined (the missing steps)."""
        with np.errstate(invalid="ignore", over="ignore"):
            totals = np.sum(value, axis=0)  # one cheap pass; a step's sum is finite only if
        allowed = self.missing if name in _STANDARDIZED else np.zeros_like(self.missing)
        bad = ~np.isfinite(totals) & ~allowed  # every term is (or it overflowed)
        if bad.any() and not np.isfinite(value[:, bad]).all():
            w_min = self._min_raw_weight
            if w_min is None and self._lazy is not None:
                w_min = self._lazy.min_raw_weight()
            cause = (
                "scales out of range" if w_min is None else overflow_cause(w_min, self.exponent)
            )
            raise InputError(f"the reconstruction's {name} is not finite: {cause}")
        if allowed.any() and np.isinf(value[:, allowed]).any():
            raise InputError(f"the reconstruction's {name} is infinite at a missing step")
        return value

    def _array(self, name: str) -> NDArray[np.float64]:
        if name not in self._arrays:
            assert self._lazy is not None  # the constructor checked
            self._arrays[name] = readonly(self._checked(name, self._lazy.array(name)))
        return self._arrays[name]

    @property
    def z(self) -> NDArray[np.float64]:
        """Standardized (smoothed) estimate, (n_sources, n_times)."""
        return self._array("z")

    @property
    def x(self) -> NDArray[np.float64]:
        """Unstandardized (smoothed) means, (n_sources, n_times)."""
        return self._array("x")

    @property
    def z_filtered(self) -> NDArray[np.float64]:
        """Filtered ``z_{t|t}``, (n_sources, n_times)."""
        return self._array("z_filtered")

    @property
    def x_filtered(self) -> NDArray[np.float64]:
        """Filtered ``x_{t|t}``, (n_sources, n_times)."""
        return self._array("x_filtered")

    @property
    def weights(self) -> NDArray[np.float64]:
        """Diagonal of ``W_t^(alpha)``, (n_sources, n_times)."""
        return self._array("weights")

    @property
    def shape(self) -> tuple[int, int]:
        """The shape ``(n_sources, n_times)`` of every output."""
        return (self.n_sources, self.n_times)

    @property
    def settings(self) -> dict[str, Any]:
        """What produced this result (dict); matrices are recorded as ``"matrix"``."""
        return {
            "path": self.path,
            "exponent": self.exponent,
            "smoother": self.smoother,
            "standardize": self.standardize,
            "n_orient": self.n_orient,
            "theta0": _setting(self.theta0),
            "q": _setting(self.q),
            "transition": _setting(self.transition),
        }

    def __repr__(self) -> str:
        smoother = self.smoother or "filter only"
        n_missing = int(np.count_nonzero(self.missing))
        gaps = f", {n_missing} missing" if n_missing else ""
        blocks = f", per position of {self.n_orient}" if self.standardize == "position" else ""
        return (
            f"<Reconstruction | {self.n_sources} sources x {self.n_times} steps{gaps}, "
            f"{self.path}, exponent {self.exponent:g}, {smoother}{blocks}>"
        )

    def _repr_html_(self) -> str:
        """The settings as a table, for notebooks; no output is computed."""
        rows = {
            "Sources x steps": f"{self.n_sources} x {self.n_times}",
            "Missing steps": int(np.count_nonzero(self.missing)),
            **self.settings,
            "Log-likelihood": f"{self.log_likelihood:.6g}",
            "Priors tuned": "no" if self.tuning is None else repr(self.tuning),
            "In memory": ", ".join(self._arrays) or "none yet",
        }
        return html_table("Reconstruction", rows)

    def amplitude(self, n_components: int = 1, *, filtered: bool = False) -> NDArray[np.float64]:
        """Per-position amplitude: the Euclidean norm of each position's components of z.

        Parameters
        ----------
        n_components : {1, 2, 3}
            Columns per position: 3 for free orientation (MNE's x, y, z order), 1 for fixed.
        filtered : bool
            Use ``z_filtered`` instead of ``z``.

        Returns
        -------
        ndarray, shape (n_sources // n_components, n_times)
            NaN at the missing steps.
        """
        n_components = check_int("n_components", n_components, minimum=1, maximum=3)
        if self.n_sources % n_components:
            raise InputError(
                f"n_components must divide n_sources={self.n_sources}, got {n_components!r}"
            )
        return amplitude_from_components(self.z_filtered if filtered else self.z, n_components)


def stored_result(
    filtered: dict[str, Any],
    x: NDArray[np.float64],
    z: NDArray[np.float64],
    model: StateSpaceModel,
    settings: Settings,
    path: str,
) -> Reconstruction:
    """The result of a path that stores every covariance (dense, filterpy).

    Parameters
    ----------
    filtered : dict
        The filter's output, time-major: ``z``, ``x_filt``, ``w``, ``weights`` of shape
        (n_times, n_sources), ``log_likelihood``, and ``missing`` (n_times,) if any.
    x, z : ndarray, shape (n_times, n_sources)
        The (smoothed) state and standardized estimate.
    model : StateSpaceModel
    settings : Settings
        The run's (exponent, smoother, standardization).
    path : str
        The path's name, as the result reports it.

    Returns
    -------
    Reconstruction
    """
    return Reconstruction(
        z=z.T,
        x=x.T,
        z_filtered=filtered["z"].T,
        x_filtered=filtered["x_filt"].T,
        weights=filtered["weights"].T,
        log_likelihood=filtered["log_likelihood"],
        n_sources=model.n_sources,
        n_times=len(z),
        exponent=settings.exponent,
        smoother=settings.smoother,
        path=path,
        theta0=model.theta0,
        q=model.q,
        transition=model.transition,
        standardize=settings.standardize,
        n_orient=settings.n_orient,
        missing=filtered.get("missing"),  # None: every step observed
        min_raw_weight=float(np.nanmin(filtered["w"])),
    )
