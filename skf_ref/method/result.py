"""The result type every computational path returns, and the per-position amplitude."""

import copy
import warnings

import numpy as np

from .._utils.checks import InputError, check_array, check_choice, check_int
from .._utils.log import caller_stacklevel
from .outputs import ARRAYS
from .standardization import overflow_cause, restandardize

__all__ = ["Reconstruction", "amplitude_from_components", "readonly"]


def amplitude_from_components(z, n_components=3):
    """Position amplitude: the Euclidean norm of each position's consecutive components.

    Parameters
    ----------
    z : ndarray, shape (n_components * n_positions, n_times)
        Standardized source estimate, MNE column order (x, y, z of position 0, then 1, ...).
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
    z = check_array("z", z, ("n_components * n_positions", "n_times"))
    if z.shape[0] % n_components:
        raise InputError(
            f"z must have shape (n_components * n_positions, n_times) with n_components="
            f"{n_components}, got shape {z.shape}"
        )
    if n_components == 1:
        return np.abs(z)
    if z.flags.f_contiguous and not z.flags.c_contiguous:  # time-major, as the paths hold it
        from .paths.singular_basis import map_threads  # (the paths import this module)

        per_time = z.T.reshape(z.shape[1], -1, n_components)  # a view: (T, positions, k)
        out = np.empty(per_time.shape[:2])
        steps = max(1, _AMPLITUDE_BYTES // (8 * z.shape[0]))  # on every core, step blocks

        def block(times):
            out[times] = _norm_of_last(per_time[times])

        for _ in map_threads(block, (slice(t, t + steps) for t in range(0, len(out), steps))):
            pass
        return out.T
    return _norm_of_last(np.moveaxis(z.reshape(-1, n_components, z.shape[1]), 1, 2))


#: Bytes of z per work item of the amplitude's worker threads.
_AMPLITUDE_BYTES = 4 * 2**20


def _norm_of_last(x):
    """``sqrt(sum(x**2, axis=-1))`` for a short last axis, one component at a time: no
    temporary as large as ``x`` (``np.linalg.norm`` squares it whole, and copies a
    transposed array first)."""
    out = np.square(x[..., 0])
    for component in range(1, x.shape[-1]):
        out += np.square(x[..., component])
    return np.sqrt(out, out=out)


def readonly(value):
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


def _setting(value):
    return float(value) if np.ndim(value) == 0 else "matrix"


class Reconstruction:
    """A standardized Kalman filter reconstruction and the settings that produced it.

    All source-space arrays have shape (n_sources, n_times), MNE's layout, and are
    read-only. A path may hand any of them over as a zero-argument function instead of an
    array: it is then computed on first access and kept (the spectral path does this, so
    that asking for ``z`` at 150 000 sources does not also materialize four other arrays
    of the same size). Printing a reconstruction never computes one. No array or scalar is
    ever non-finite: a reconstruction that would overflow raises
    :class:`~skf_ref.InputError` saying which parameter or scale is out of range. A
    reconstruction never changes once made: its attributes cannot be set, and
    :meth:`with_tuning` returns a new one.

    Attributes
    ----------
    z : ndarray, shape (n_sources, n_times)
        Standardized estimate; smoothed when a smoother was asked, else ``z_filtered``.
    x : ndarray, shape (n_sources, n_times)
        Unstandardized means: the smoothed state ``x^s_t`` for ``"rts-state"``, the
        filtered means ``x_{t|t}`` otherwise.
    z_filtered : ndarray, shape (n_sources, n_times)
        ``z_{t|t}`` of §2.2 eq. (6).
    x_filtered : ndarray, shape (n_sources, n_times)
        ``x_{t|t}`` of §2.2 eq. (5).
    weights : ndarray, shape (n_sources, n_times)
        Diagonal of ``W_t^(alpha)``, §2.2 eq. (7), at each step.
    log_likelihood : float
        Innovation log-likelihood ``sum_t log N(y_t - L x_{t|t-1}; 0, S_t)``.
    n_sources, n_times : int
        The shape of every array.
    exponent : float
        The standardization exponent alpha.
    smoother : str or None
        ``None``, ``"rts-standardized"`` or ``"rts-state"``.
    method : str
        The path that computed it: ``"filterpy"``, ``"dense"`` or ``"spectral"``.
    theta0, q, transition : float or ndarray, shape (n_sources, n_sources)
        The model's ``P_0``, ``Q`` and ``A`` as given (a scalar ``c`` means ``c I``).
    tuning : skf_ref.method.tuning.TuneResult or None
        When the priors were chosen by the data (``"auto"``), how.
    """

    _ARRAYS = ARRAYS

    def __init__(
        self,
        *,
        z,
        x,
        z_filtered,
        x_filtered,
        weights,
        log_likelihood,
        n_sources,
        n_times,
        exponent,
        smoother,
        method,
        theta0,
        q,
        transition=1.0,
        diagnose=None,
        rows=None,
        tuning=None,
    ):
        self._arrays = dict(
            z=z, x=x, z_filtered=z_filtered, x_filtered=x_filtered, weights=weights
        )
        self._diagnose, self._rows = diagnose, rows
        if not np.isfinite(log_likelihood):
            raise InputError(
                f"the innovation log-likelihood is {log_likelihood}: the data are too large "
                "for the noise (are Y and the noise in the same units?) or the model's "
                "covariances overflow"
            )
        for name, value in self._arrays.items():
            if not callable(value):
                self._check_finite(name, value)
        self.log_likelihood = float(log_likelihood)
        self.n_sources, self.n_times = int(n_sources), int(n_times)
        self.exponent, self.smoother, self.method = float(exponent), smoother, method
        self.theta0, self.q, self.transition = theta0, q, transition
        self.tuning = tuning
        self._frozen = True

    def __setattr__(self, name, value):
        if getattr(self, "_frozen", False):
            raise AttributeError(
                f"a Reconstruction is read-only: {name!r} cannot be set (with_tuning gives a "
                "copy with the priors' tuning)"
            )
        super().__setattr__(name, value)

    def with_tuning(self, tuning):
        """The same reconstruction, recording how the data chose its priors.

        Parameters
        ----------
        tuning : skf_ref.method.tuning.TuneResult or None

        Returns
        -------
        Reconstruction
            A new object; the arrays are shared (read-only), this one is unchanged.
        """
        other = copy.copy(self)
        object.__setattr__(other, "tuning", tuning)
        return other

    @classmethod
    def from_filter(cls, filtered, smoother, rts, *, model, exponent, method):
        """Smooth and package the output of a covariance-storing path (dense, filterpy).

        Parameters
        ----------
        filtered : dict
            Time-major filter output: ``x_filt``, ``z``, raw weights ``w``, ``weights``
            (n_times, n_sources); ``P_pred_inv_sqrt`` (n_times, n_sources, n_sources);
            ``log_likelihood``.
        smoother : {None, "rts-standardized", "rts-state"}
        rts : callable
            The path's RTS backward pass: a (n_times, n_sources) sequence ``m_t`` to
            ``s_t = m_t + G_t (s_{t+1} - A m_t)``, ``s_T = m_T``.
        model : StateSpaceModel
        exponent : float
        method : str

        Returns
        -------
        Reconstruction

        Raises
        ------
        skf_ref.InputError
            If an output is not finite, saying which parameter or scale is out of range.
        """
        f = filtered
        x, z = f["x_filt"], f["z"]
        if smoother == "rts-standardized":
            # the paper's smoother: RTS over the standardized sequence (docs/model.md §3)
            z = rts(f["z"])
        elif smoother == "rts-state":
            # textbook RTS on the state, then z^s_t = W_t^(alpha) P_{t|t-1}^{-1/2} x^s_t
            x = rts(f["x_filt"])
            z = restandardize(f["w"], f["P_pred_inv_sqrt"], x, exponent)
        return cls(
            z=z.T,
            x=x.T,
            z_filtered=f["z"].T,
            x_filtered=f["x_filt"].T,
            weights=f["weights"].T,
            log_likelihood=f["log_likelihood"],
            n_sources=model.n_sources,
            n_times=len(f["z"]),
            exponent=exponent,
            smoother=smoother,
            method=method,
            theta0=model.theta0,
            q=model.q,
            transition=model.transition,
            diagnose=lambda: overflow_cause(np.min(f["w"]), exponent),
        )

    @property
    def spectral_rows(self):
        """SpectralRows or None : What computes rows of the spectral outputs.

        (:class:`skf_ref.method.paths.spectral_rows.SpectralRows`.)
        """
        return self._rows

    def computed(self, name):
        """Whether output ``name`` is held in memory already (bool)."""
        return not callable(self._arrays[name])

    def blocks(self, name, rows=None):
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
        from .paths.spectral_rows import BLOCK_BYTES, NAMES, SMOOTH_BYTES, SMOOTH_COLUMNS

        check_choice("name", name, NAMES)
        n, T = self.n_sources, self.n_times
        step = BLOCK_BYTES // (8 * T) if rows is None else rows
        step = check_int("rows", max(1, step))
        computed = self.computed(name) or self._rows is None
        # the smoother's backward pass costs T vector operations per block computed, so on
        # long recordings narrow blocks are computed several at a time
        smoothed = not computed and name == "z" and self.smoother == "rts-standardized"
        width = min(SMOOTH_COLUMNS, SMOOTH_BYTES // (8 * T))
        group = step * max(1, width // step) if smoothed else step
        for first in range(0, n, group):
            stop = min(first + group, n)
            many = None if computed else self._rows.block(name, slice(first, stop)).T
            for start in range(first, stop, step):
                where = slice(start, min(start + step, stop))
                if computed:
                    block = self._array(name)[where]
                else:
                    block = many[where.start - first : where.stop - first]
                self._check_finite(name, block)
                yield where, block
            del many, block  # before the next group is computed: one group in memory

    def to_zarr(self, path, arrays=("z",), chunks=None, overwrite=False):
        """Stream outputs into a zarr store, one block of rows at a time.

        See :func:`skf_ref.io.zarr_dask.to_zarr`.
        """
        from ..io.zarr_dask import to_zarr

        return to_zarr(self, path, arrays=arrays, chunks=chunks, overwrite=overwrite)

    def to_dask(self, name="z", chunks=None):
        """Output ``name`` as a Dask array whose blocks a cluster computes.

        See :func:`skf_ref.io.zarr_dask.to_dask`.
        """
        from ..io.zarr_dask import to_dask

        return to_dask(self, name=name, chunks=chunks)

    def _check_finite(self, name, value):
        # a sum is finite only if every term is (or it overflowed): one cheap pass, and the
        # elementwise test only to confirm
        with np.errstate(invalid="ignore", over="ignore"):
            total = np.sum(value)
        if not np.isfinite(total) and not np.isfinite(value).all():
            cause = self._diagnose() if self._diagnose is not None else "scales out of range"
            raise InputError(f"the reconstruction's {name} is not finite: {cause}")

    def _array(self, name):
        value = self._arrays[name]
        if callable(value):
            value = value()
            self._check_finite(name, value)
        value = self._arrays[name] = readonly(value)
        return value

    z = property(lambda self: self._array("z"), doc="Standardized (smoothed) estimate.")
    x = property(lambda self: self._array("x"), doc="Unstandardized (smoothed) means.")
    z_filtered = property(lambda self: self._array("z_filtered"), doc="Filtered z_{t|t}.")
    x_filtered = property(lambda self: self._array("x_filtered"), doc="Filtered x_{t|t}.")
    weights = property(lambda self: self._array("weights"), doc="Diagonal of W_t^(alpha).")

    @property
    def shape(self):
        """tuple : (n_sources, n_times)."""
        return (self.n_sources, self.n_times)

    @property
    def settings(self):
        """dict : What produced this result; matrices are recorded as ``"matrix"``."""
        return {
            "method": self.method,
            "exponent": self.exponent,
            "smoother": self.smoother,
            "theta0": _setting(self.theta0),
            "q": _setting(self.q),
            "transition": _setting(self.transition),
        }

    def __repr__(self):
        smoother = self.smoother or "filter only"
        return (
            f"<Reconstruction | {self.n_sources} sources x {self.n_times} steps, "
            f"{self.method}, exponent {self.exponent:g}, {smoother}>"
        )

    def to_stc(self, src, tmin, tstep, subject=None, pick_ori=None):
        """This reconstruction as an MNE source estimate (see :func:`skf_ref.io.stc.make_stc`).

        Parameters
        ----------
        src : mne.SourceSpaces
            The source space of the lead field's columns (``forward["src"]``).
        tmin, tstep : float
            First sample's time and the sampling interval, seconds.
        subject : str, optional
            Default: the source space's subject.
        pick_ori : {None, "vector"}
            ``None``: per-position amplitude (free orientation) or the signed ``z`` (fixed);
            ``"vector"``: free orientation's three components.

        Returns
        -------
        mne.SourceEstimate or mne.VolSourceEstimate or mne.MixedSourceEstimate or vector kin
        """
        from ..io.stc import make_stc

        return make_stc(self, src, tmin, tstep, subject, pick_ori)

    def amplitude(self, n_components=1, *, filtered=False, components=None):
        """Per-position amplitude: the Euclidean norm of each position's components of z.

        Parameters
        ----------
        n_components : {1, 2, 3}
            Columns per position: 3 for free orientation (MNE's x, y, z order), 1 for fixed.
        filtered : bool
            Use ``z_filtered`` instead of ``z``.
        components : {1, 2, 3}
            The 0.2 name of ``n_components``; it warns and goes in 0.4.

        Returns
        -------
        ndarray, shape (n_sources // n_components, n_times)

        Examples
        --------
        >>> z = np.array([[3.0], [4.0], [0.0], [1.0], [0.0], [0.0]])
        >>> r = Reconstruction(z=z, x=z, z_filtered=z, x_filtered=z, weights=z,
        ...                    log_likelihood=0.0, n_sources=6, n_times=1, exponent=0.5,
        ...                    smoother=None, method="dense", theta0=1.0, q=0.0)
        >>> r.amplitude(3).ravel().tolist()
        [5.0, 1.0]
        """
        if components is not None:
            warnings.warn(
                "amplitude's components= is now n_components=; components goes in 0.4",
                FutureWarning,
                stacklevel=caller_stacklevel(),
            )
            n_components = components
        n_components = check_int("n_components", n_components, minimum=1, maximum=3)
        if self.n_sources % n_components:
            raise InputError(
                f"n_components must divide n_sources={self.n_sources}, got {n_components!r}"
            )
        return amplitude_from_components(self.z_filtered if filtered else self.z, n_components)
