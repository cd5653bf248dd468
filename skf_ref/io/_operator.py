"""A prepared SKF, like MNE's inverse operator: made once, applied to many data sets.

:class:`SKFOperator` holds what :func:`skf_ref.io._make_operator.make_skf_operator` prepared
(the channels, MNE's whitener, the whitened lead field and its SVD, the priors) and applies
it: :meth:`SKFOperator.check_info` and :meth:`SKFOperator.select` check data against it,
:meth:`SKFOperator.reconstruct` whitens them (an average with the covariance over its
``nave``) and runs the SKF, reusing the SVD and, for each number of samples, the
covariance recursion; :meth:`SKFOperator.to_stc` makes the MNE source estimate.
"""

from __future__ import annotations

import collections
import contextlib
import html
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils.checks import (
    InputError,
    check_array,
    check_choice,
    check_db,
    check_leadfield,
    check_real,
    path_renamed,
)
from .._utils.log import logger
from .._utils.precision import zero_tolerance
from .._utils.threads import one_blas_thread
from ..method import (
    Reconstruction,
    SpectralBasis,
    SpectralModel,
    StateSpaceModel,
    TuneResult,
    ar1_priors,
    priors_from_snr,
)
from ..method._model import missing_steps
from ..method._reconstruct import run_checked
from ..method._search import TimeConstant, check_searched, check_time_constant
from ..method._settings import Settings, check_gaps, check_settings
from ..method._tuning import choose_priors
from ._channels import (
    check_average_referenced,
    check_channel_types,
    has_average_reference_projector,
)
from ._stc import PICK_ORIS, make_stc, stc_layout

__all__ = ["InfoCheck", "Prior", "SKFOperator", "check_prior"]

_MODELS_KEPT = 4  # covariance recursions kept, one per number of samples and priors

#: A prior SNR as an operator holds it: a number (dB), ``"auto"``, or a search range.
Prior = float | str | tuple[float, float]


#: Multiply-adds of a product below which it runs on one BLAS thread (about 10 ms of one core).
_SMALL_PRODUCT = 2**25


def _one_blas_thread(work: int) -> Any:
    """One BLAS thread for a product of ``work`` multiply-adds below :data:`_SMALL_PRODUCT`
    (a context; none for a larger one). An epoch's whitening and projection (rank x channels
    x samples, 7e6 on the sample subject) took 20-70 ms on two BLAS threads on a machine
    busy with other work, against 2-3 ms on one: the threads wait for a core each, for
    little work (validation/epochs_bench.py). The rows of the outputs run on worker threads,
    each on one BLAS thread, already (``skf_ref._utils.threads``)."""
    if work >= _SMALL_PRODUCT:
        return contextlib.nullcontext()
    return one_blas_thread()


def check_prior(name: str, value: Any) -> Prior:
    """A prior SNR: a number in dB, ``"auto"``, or a search range ``(low, high)`` in dB.

    ``"auto"`` and a range are searched by the marginal likelihood of each data set
    (:func:`skf_ref.tune`; ``"auto"`` is its default range).

    Examples
    --------
    >>> check_prior("pm_snr_db", [-40, 20])
    (-40.0, 20.0)
    >>> check_prior("pm_snr_db", "auto"), check_prior("ep_snr_db", 20)
    ('auto', 20.0)
    """
    return check_searched(name, value, "a number (dB)", "dB", check_db)


def _describe_prior(value: Prior | None, unit: str = "dB") -> str:
    if value is None:
        return "none"
    if isinstance(value, str):
        return value
    if isinstance(value, tuple):
        return f"searched in ({value[0]:g}, {value[1]:g}) {unit}"
    return f"{value:g} {unit}"


def _describe_tuning(tuning: TuneResult) -> str:
    """What ``"auto"`` chose, for the log: the time constant to two significant digits, the
    precision the search settles to (its optimum is flat: another BLAS kernel moves the
    third digit, and the log-likelihood's sixth; the reconstruction's ``tuning`` holds it)."""
    if tuning.time_constant_ms is None:
        evolution = f"EP-SNR {tuning.ep_snr_db:.2f} dB"
    else:
        evolution = f"time constant {float(f'{tuning.time_constant_ms:.2g}'):g} ms"
    return f"PM-SNR {tuning.pm_snr_db:.2f} dB, {evolution}"


@dataclass(frozen=True)
class InfoCheck:
    """What :meth:`SKFOperator.check_info` found: the rows to take, and the reference.

    Attributes
    ----------
    index : ndarray of int, shape (len(ch_names),)
        The operator's channels among the info's.
    must_be_referenced : bool
        Whether each data set must be average referenced (EEG without a projector).
    """

    index: NDArray[np.intp]
    must_be_referenced: bool


class SKFOperator:
    """A prepared SKF: channels, whitener, whitened forward and its SVD, and the priors.

    Made by :func:`skf_ref.make_skf_operator` (or read by :func:`skf_ref.read_skf_operator`);
    applied by :func:`skf_ref.apply_skf`, :func:`skf_ref.apply_skf_epochs` and
    :func:`skf_ref.apply_skf_raw`, or to an array by :meth:`reconstruct`.

    Parameters
    ----------
    info : mne.Info
        The info of the channels used, with every projector the whitener applies.
    ch_names : list of str
        The channels used, in the info's order.
    dropped : dict
        The channels left out, by reason.
    whitener : ndarray, shape (rank, n_channels)
        MNE's whitener of the noise covariance of one trial.
    forward : mne.Forward
        The forward restricted to ``ch_names``, free orientation in MNE's x, y, z.
    fixed : bool
        Whether the forward has fixed orientations (one column per position).
    pm, ep : float or "auto" or (float, float)
        The priors PM-SNR and EP-SNR in dB, or ranges to search on each data set; ``ep``
        None with ``time_constant``.
    time_constant : float or "auto" or (float, float), optional
        The stationary AR(1) prior's time constant in ms (:func:`skf_ref.ar1_priors`) in
        place of the EP-SNR's random walk, or a range to search; None (default): the
        random walk.

    Attributes
    ----------
    ch_names : list of str
        The channels used, in the info's order.
    dropped : dict
        The channels of the types used that were left out, by reason (``"bad"``,
        ``"not in the forward"``, ``"not in the noise covariance"``, ``"bad in the noise
        covariance"``).
    info : mne.Info
        The info of the channels used, with every projector the whitener applies.
    whitener : ndarray, shape (rank, n_channels)
        MNE's whitener of the noise covariance of one trial, projectors included.
    rank : int
        Rank of the noise covariance after projection (rows of ``whitener``).
    leadfield : ndarray, shape (rank, n_sources)
        The whitened lead field ``whitener @ L``.
    forward : mne.Forward
        The forward restricted to ``ch_names`` (free orientation in MNE's x, y, z).
    n_components : int
        Columns per source position: 3 (free orientation) or 1 (fixed).
    ch_types : list of str
        Each channel's type (``"mag"``, ``"grad"``, ``"eeg"``).
    eeg_names : list of str
        The EEG channels among them: the whitener gives them the average reference.
    pm_snr_db : float or "auto" or (float, float)
        The PM-SNR (docs/model.md §4): a number in dB, or searched on each data set.
    ep_snr_db : float or "auto" or (float, float) or None
        The EP-SNR of the paper's random walk, likewise; None with a time constant.
    time_constant_ms : float or "auto" or (float, float) or None
        The time constant of the stationary AR(1) prior (ms, :func:`skf_ref.ar1_priors`):
        a number, or searched on each data set in ``log(tau)``; None for the random walk.
    """

    def __init__(
        self,
        *,
        info: Any,
        ch_names: list[str],
        dropped: dict[str, list[str]],
        whitener: NDArray[np.float64],
        forward: Any,
        fixed: bool,
        pm: Prior,
        ep: Prior | None,
        time_constant: TimeConstant | None = None,
    ) -> None:
        self.info, self.ch_names, self.dropped = info, list(ch_names), dropped
        self.whitener, self.rank, self.forward = whitener, len(whitener), forward
        self.n_components = 1 if fixed else 3
        self.pm_snr_db, self.ep_snr_db, self.time_constant_ms = pm, ep, time_constant
        leadfield = whitener @ np.asarray(forward["sol"]["data"], dtype=float)
        if not np.all(np.isfinite(leadfield)):
            raise InputError("the whitened forward is not finite: noise_cov is out of range")
        self.leadfield = check_leadfield(leadfield, "the whitened forward")
        self._basis = SpectralBasis(self.leadfield, np.eye(self.rank))
        self._models: collections.OrderedDict = collections.OrderedDict()
        self._prior_cache: dict[Any, tuple[float, float, float]] = {}
        self._layouts: dict[Any, Any] = {}
        self.ch_types = info.get_channel_types(ch_names)
        self.eeg_names = [c for c, k in zip(ch_names, self.ch_types, strict=True) if k == "eeg"]

    @property
    def default_standardize(self) -> str:
        """What :meth:`reconstruct` standardizes as a whole by default (str).

        ``"position"`` (each position's orientations as a whole) when the operator uses EEG
        channels (docs/choosing.md). ``"column"`` for MEG alone: MEG barely sees, and in a
        spherical head does not see, a position's radial orientation, so its 3 x 3 blocks
        are singular or nearly so.
        """
        return "position" if self.eeg_names else "column"

    @property
    def n_sources(self) -> int:
        """Columns of the lead field (int)."""
        return self.leadfield.shape[1]

    def _summary(self) -> dict[str, str]:
        types = collections.Counter(self.ch_types)
        return {
            "channels": f"{len(self.ch_names)} ("
            + ", ".join(f"{n} {kind}" for kind, n in types.items())
            + ")",
            "rank": str(self.rank),
            "source positions": f"{self.n_sources // self.n_components} x "
            f"{self.n_components} ({'fixed' if self.n_components == 1 else 'free'} orientation)",
            "PM-SNR": _describe_prior(self.pm_snr_db),
            **self._evolution_summary(),
            "left out": "; ".join(f"{k}: {len(v)}" for k, v in self.dropped.items()) or "none",
        }

    def _evolution_summary(self) -> dict[str, str]:
        if self.time_constant_ms is None:
            return {"EP-SNR": _describe_prior(self.ep_snr_db)}
        return {"time constant": _describe_prior(self.time_constant_ms, "ms")}

    def __repr__(self) -> str:
        if self.time_constant_ms is None:
            values = (self.pm_snr_db, self.ep_snr_db)
            priors = "PM-SNR and EP-SNR " + ", ".join(_describe_prior(v) for v in values)
        else:
            priors = (
                f"PM-SNR {_describe_prior(self.pm_snr_db)}, time constant "
                f"{_describe_prior(self.time_constant_ms, 'ms')}"
            )
        return (
            f"<SKFOperator | {len(self.ch_names)} channels, rank {self.rank}, "
            f"{self.n_sources // self.n_components} positions x {self.n_components}, "
            f"{priors}>"
        )

    def _repr_html_(self) -> str:
        """A table for notebooks, as MNE's objects show themselves."""
        rows = "".join(
            f"<tr><th style='text-align:left'>{html.escape(k)}</th>"
            f"<td style='text-align:left'>{html.escape(v)}</td></tr>"
            for k, v in self._summary().items()
        )
        return f"<table><caption>SKFOperator</caption>{rows}</table>"

    def _priors(
        self, n_times: int, ep: Prior | None, tau: TimeConstant | None, sfreq: float
    ) -> tuple[float, float, float]:
        """``theta0, q, transition`` of fixed priors (docs/model.md §4): the random walk's
        for ``n_times`` samples, or the AR(1) prior's at ``sfreq``; kept."""
        key = ("ep", ep, n_times) if tau is None else ("tau", tau, sfreq)
        if key not in self._prior_cache:
            pm = cast(float, self.pm_snr_db)
            if tau is None:
                theta0, q = priors_from_snr(self.leadfield, 1.0, pm, cast(float, ep), n_times)
                self._prior_cache[key] = (theta0, q, 1.0)
            else:
                self._prior_cache[key] = ar1_priors(
                    self.leadfield, 1.0, pm, cast(float, tau), sfreq
                )
        return self._prior_cache[key]

    def _model(self, n_times: int, model: StateSpaceModel) -> SpectralModel:
        """The spectral model of ``model`` (this lead field, scalar priors) for ``n_times``
        samples; the last few kept."""
        key = (n_times, model.theta0, model.q, model.transition)
        if key not in self._models:
            self._models[key] = SpectralModel(model, n_times, basis=self._basis)
            while len(self._models) > _MODELS_KEPT:
                self._models.popitem(last=False)  # the least recently used
        self._models.move_to_end(key)
        return self._models[key]

    def check_pick_ori(self, pick_ori: str | None) -> None:
        """Refuse a ``pick_ori`` the operator's forward cannot give.

        Parameters
        ----------
        pick_ori : None or "normal" or "vector"
            As MNE's ``apply_inverse``.
        """
        check_choice("pick_ori", pick_ori, PICK_ORIS)
        if pick_ori == "vector" and self.n_components == 1:
            raise InputError(
                "pick_ori='vector' needs a free-orientation forward; this one is fixed"
            )

    def check_info(self, info: Any, name: str = "data") -> InfoCheck:
        """Check an info against the operator, once for every data set it describes.

        Every channel used must be in ``info``, good there and of the operator's type;
        every projector of ``info`` must be one the operator applies; with EEG, an
        average-reference projector must cover every EEG channel used (else each data set
        must be average referenced: :meth:`select` checks it).

        Parameters
        ----------
        info : mne.Info
        name : str
            What the data are, for the messages (``"evoked"``, ``"epochs"``).

        Returns
        -------
        InfoCheck
        """
        from mne.proj import make_projector

        missing = [c for c in self.ch_names if c not in info.ch_names]
        if missing:
            raise InputError(
                f"{name} lacks {len(missing)} channels the operator uses: {missing[:5]}; make "
                "the operator from this info"
            )
        bad = [c for c in self.ch_names if c in info["bads"]]
        if bad:
            raise InputError(
                f"{name} marks {bad[:5]} bad, which the operator uses: make the operator from "
                "this info (bad channels are left out there)"
            )
        check_channel_types(info, dict(zip(self.ch_names, self.ch_types, strict=True)), name)
        referenced = bool(self.eeg_names) and not has_average_reference_projector(
            info, self.eeg_names, name
        )
        P = make_projector(info["projs"], self.ch_names)[0]
        scale = np.max(np.abs(self.whitener))
        if np.max(np.abs(self.whitener - self.whitener @ P)) > zero_tolerance(P) * scale:
            raise InputError(
                f"{name} has projectors the operator does not apply ({len(info['projs'])} "
                "in its info): make the operator from this info"
            )
        names = {c: i for i, c in enumerate(info.ch_names)}
        return InfoCheck(np.array([names[c] for c in self.ch_names], dtype=np.intp), referenced)

    def select(
        self, info: Any, data: ArrayLike, name: str = "data", *, check: InfoCheck | None = None
    ) -> NDArray[np.float64]:
        """The operator's channels of ``data``, checked against it.

        Parameters
        ----------
        info : mne.Info
        data : array_like, shape (len(info.ch_names), n_times)
        name : str
            What the data are, for the messages (``"evoked"``, ``"epochs[3]"``).
        check : InfoCheck, optional
            :meth:`check_info`'s answer for ``info``, when many data sets share it.

        Returns
        -------
        ndarray, shape (len(ch_names), n_times)
        """
        check = self.check_info(info, name) if check is None else check
        data = np.asarray(data)
        if data.ndim != 2 or len(data) != len(info.ch_names):
            raise InputError(
                f"{name}.data must have shape ({len(info.ch_names)}, n_times) (the channels of "
                f"its info), got {data.shape}"
            )
        picked = check_array(f"{name}.data", data[check.index], (len(check.index), "n_times"))
        if check.must_be_referenced:
            check_average_referenced(info, data, name)
        return picked

    @path_renamed
    def reconstruct(
        self,
        data: ArrayLike,
        *,
        nave: float = 1,
        exponent: float = 0.5,
        smoother: str | None = "rts-smoothed-weights",
        path: str = "auto",
        memory_limit: float | None = None,
        standardize: str | None = None,
        time_constant_ms: float | str | tuple[float, float] | None = None,
        sfreq: float | None = None,
    ) -> Reconstruction:
        """The SKF on data of the operator's channels (in ``ch_names`` order).

        Parameters
        ----------
        data : array_like, shape (len(ch_names), n_times)
            In the data's units, as :meth:`select` returns them; whitened here. A column of
            NaN is a missing step (a bad segment; docs/model.md §2).
        nave : float
            The number of trials averaged (``evoked.nave``; 1 for epochs and raw
            recordings): the data are whitened with the noise covariance divided by it.
        exponent : float
        smoother : {"rts-smoothed-weights", None, "rts-standardized", "rts-state"}
        path : {"auto", "spectral", "dense", "filterpy"}
            ``"auto"`` and ``"spectral"`` reuse the operator's SVD and recursions.
        memory_limit : float, optional
            Bytes the reconstruction may use (default half the memory available).
        standardize : {"column", "position"}, optional
            Each source position's ``n_components`` columns standardized as a whole
            (docs/model.md §2; with fixed orientation the same as ``"column"``), or each
            column of the forward on its own (the paper's). Default
            ``default_standardize``: ``"position"`` when the operator uses EEG,
            ``"column"`` for MEG alone.
        time_constant_ms : float or "auto" or (float, float), optional
            None (default): the operator's evolution prior (``ep_snr_db`` or
            ``time_constant_ms``). A time constant in ms, ``"auto"`` or a range: the
            stationary AR(1) prior (:func:`skf_ref.ar1_priors`) in its place for these data,
            the PM-SNR the operator's (``"auto"`` and a range are chosen by the marginal
            likelihood, in ``log(tau)``; ``"auto"`` searches 1 to 1000 ms).
        sfreq : float, optional
            The data's sampling rate in Hz, for a time constant (default the operator's
            ``info["sfreq"]``).

        Returns
        -------
        skf_ref.Reconstruction
            In whitened units; ``tuning`` says what ``"auto"`` chose (also logged at INFO).
            ``z``, the weights, the log-likelihood and the priors do not depend on ``nave``;
            ``x`` is the state of the data scaled by ``sqrt(nave)`` (below).
        """
        settings = self._check_settings(exponent, smoother, path, standardize)
        return self._reconstruct(
            data,
            settings,
            nave=nave,
            memory_limit=memory_limit,
            time_constant_ms=time_constant_ms,
            sfreq=sfreq,
        )

    def _check_settings(
        self,
        exponent: float = 0.5,
        smoother: str | None = "rts-smoothed-weights",
        path: str = "auto",
        standardize: str | None = None,
    ) -> Settings:
        """The settings of :meth:`reconstruct` checked for this operator, once per call.

        Parameters
        ----------
        exponent, smoother, path, standardize
            As :meth:`reconstruct`.

        Returns
        -------
        skf_ref.method.Settings
        """
        standardize = self.default_standardize if standardize is None else standardize
        return check_settings(
            exponent, smoother, path, standardize, self.n_components, self.n_sources
        )

    def _reconstruct(
        self,
        data: ArrayLike,
        settings: Settings,
        *,
        nave: float = 1,
        memory_limit: float | None = None,
        time_constant_ms: float | str | tuple[float, float] | None = None,
        sfreq: float | None = None,
    ) -> Reconstruction:
        """:meth:`reconstruct` with settings checked (:meth:`_check_settings`), not again:
        the kernel of every public route that applies the operator."""
        data = check_array("data", data, (len(self.ch_names), "n_times"), finite=False)
        missing = missing_steps(data, "data")  # columns of NaN: bad segments
        check_gaps(settings.smoother, missing)
        nave = check_real("nave", nave, positive=True)
        if memory_limit is not None:
            memory_limit = check_real("memory_limit", memory_limit, positive=True)
        ep, tau = self.ep_snr_db, self.time_constant_ms
        if time_constant_ms is not None:  # the AR(1) prior in place of the operator's
            ep, tau = None, check_time_constant(time_constant_ms)
        rate = self.info["sfreq"] if sfreq is None else sfreq
        rate = check_real("sfreq", rate, positive=True) if tau is not None else None
        # An average of nave trials has noise covariance C / nave: its whitener is
        # sqrt(nave) W, and its whitened lead field sqrt(nave) W L, whose priors
        # (PM-SNR, docs/model.md §4) are theta0 / nave and q / nave. That model is this
        # one, W L with theta0 and q, for the state sqrt(nave) x: the same S_t, the same
        # raw weights w_t (§2.2 eq. (7)) and the same z (eq. (6)), likelihood and "auto"
        # choice. So the whitened data alone are scaled (MNE's prepare_inverse_operator
        # scales noise and source covariance alike, to the same effect).
        with _one_blas_thread(self.whitener.size * data.shape[1]):
            whitened = self.whitener @ data
        if nave != 1:
            whitened *= np.sqrt(nave)
        if not np.all(np.isfinite(whitened[:, ~missing])):
            raise InputError("the whitened data are not finite: noise_cov is out of range")
        T = whitened.shape[1]
        tuning = None
        if all(isinstance(v, float | None) for v in (self.pm_snr_db, ep, tau)):
            theta0, q, transition = self._priors(T, ep, tau, cast(float, rate))
        else:
            theta0, q, transition, tuning = choose_priors(
                self.leadfield,
                whitened,
                noise_std=1.0,
                pm_snr_db=self.pm_snr_db,
                ep_snr_db=ep,
                time_constant_ms=tau,
                sfreq=rate,
            )
            if tuning is not None:  # something was searched
                logger.info("SKF: priors chosen by the data: %s", _describe_tuning(tuning))
        model = StateSpaceModel.create(
            self.leadfield, noise_std=1.0, theta0=theta0, q=q, transition=transition
        )
        # "auto" and "spectral" reuse the operator's SVD (and recursions); the r x T part
        # (projection, filter) on one BLAS thread where it is small
        with _one_blas_thread(self.whitener.size * T):
            rec = run_checked(
                model,
                model.check_data(whitened),
                settings,
                memory_limit,
                prepared=lambda: self._model(T, model),
            )
        return rec.with_tuning(tuning)

    def to_stc(
        self,
        reconstruction: Reconstruction,
        tmin: float,
        tstep: float,
        pick_ori: str | None = None,
    ) -> Any:
        """A reconstruction as an MNE source estimate on the operator's source space.

        Parameters
        ----------
        reconstruction : skf_ref.Reconstruction
            Of this operator's lead field.
        tmin, tstep : float
            The first time and the sampling step, seconds.
        pick_ori : None or "normal" or "vector"
            As MNE's ``apply_inverse`` (see :func:`skf_ref.io.make_stc`).

        Returns
        -------
        mne.SourceEstimate or mne.VolSourceEstimate or a vector estimate
            The standardized estimate ``z`` (with ``pick_ori=None`` and free orientation,
            each position's amplitude).
        """
        if pick_ori not in self._layouts:
            self._layouts[pick_ori] = stc_layout(self.n_sources, self.forward["src"], pick_ori)
        layout = self._layouts[pick_ori]
        src = self.forward["src"]
        return make_stc(reconstruction, src, tmin, tstep, pick_ori=pick_ori, layout=layout)
