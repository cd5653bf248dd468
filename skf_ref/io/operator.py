"""A prepared SKF, like MNE's inverse operator: made once, applied to many data sets.

:func:`make_skf_operator` does every step that does not depend on the data, once:

1. **Channels.** The channels of the types asked for (``meg``, ``eeg``, as
   ``mne.pick_types`` names them) that are good in the info, in the forward and in the
   noise covariance, in the info's order. Each one left out is listed, with the reason,
   in :class:`SKFOperator`'s ``dropped`` and in the "skf_ref" log (``verbose=``).
2. **Reference** (EEG only). Data and lead field must carry the same reference
   (docs/model.md §1): the whitener includes an average-reference projector over the EEG
   channels used (the info's own, or one added), so the forward is given the average
   reference and the data are projected onto it. Data may come with that projector, or be
   average referenced already, to their precision (MNE's default,
   ``set_eeg_reference("average", projection=False)``; float32 files included); any other
   reference is refused when the operator is applied (:meth:`SKFOperator.select`).
3. **Whitening.** MNE's whitener (``mne.cov.compute_whitener``, ``pca=True``) of the noise
   covariance with every projector applied: a block per channel type (MEG, EEG), so it
   whitens mixed units as MNE does, and it reduces the data to the covariance's rank. The
   covariance is checked first: finite, in range, symmetric, positive semi-definite with a
   nonzero block per channel type after projection.
4. **The SKF's model.** The thin SVD of the whitened lead field
   (:class:`skf_ref.method.SpectralBasis`) once, and for each number
   of samples the covariance recursion (:class:`skf_ref.method.SpectralModel`
   with that basis), kept for the next data set of that length. The priors come from
   PM-SNR and EP-SNR on the whitened lead field (docs/model.md §4): ``q`` depends on the
   number of samples, ``"auto"`` on the data (chosen again for each data set).
"""

import collections

import numpy as np

from .._utils import memory
from .._utils.checks import (
    InputError,
    InputTypeError,
    check_array,
    check_choice,
    check_db,
    check_leadfield,
    describe,
)
from .._utils.extras import optional
from .._utils.log import logger, verbosity
from .._utils.precision import zero_tolerance
from ..method import SpectralBasis, SpectralModel, StateSpaceModel, priors_from_snr, reconstruct
from ..method._model import missing_steps
from ..method._settings import check_gaps, check_settings
from ..method._tuning import choose_priors
from .channels import (
    channel_kind,
    channel_types,
    check_reference,
    has_average_reference_projector,
    pick_channels,
)
from .noise_cov import check_noise_covariance, noise_covariance
from .stc import PICK_ORIS, make_stc

__all__ = ["SKFOperator", "make_skf_operator"]

_MODELS_KEPT = 4  # covariance recursions kept, one per number of samples and priors


class SKFOperator:
    """A prepared SKF: channels, whitener, whitened forward and its SVD, and the priors.

    Made by :func:`make_skf_operator`; applied by :func:`skf_ref.apply_skf`,
    :func:`skf_ref.apply_skf_epochs` and :func:`skf_ref.apply_skf_raw`, or to an array by
    :meth:`reconstruct`.

    Attributes
    ----------
    ch_names : list of str
        The channels used, in the info's order.
    dropped : dict
        The channels of the types asked for that were left out, by reason (``"bad"``,
        ``"not in the forward"``, ``"not in the noise covariance"``).
    info : mne.Info
        The info of the channels used, with every projector the whitener applies.
    whitener : ndarray, shape (rank, n_channels)
        MNE's whitener, projectors included.
    rank : int
        Rank of the noise covariance after projection (rows of ``whitener``).
    leadfield : ndarray, shape (rank, n_sources)
        The whitened lead field ``whitener @ L``.
    forward : mne.Forward
        The forward restricted to ``ch_names`` (free orientation in MNE's x, y, z).
    n_components : int
        Columns per source position: 3 (free orientation) or 1 (fixed).
    eeg_names : list of str
        The EEG channels among them: the whitener gives them the average reference.
    pm_snr_db, ep_snr_db : float or "auto"
        The priors (docs/model.md §4).
    """

    def __init__(self, *, info, ch_names, dropped, whitener, forward, fixed, pm, ep):
        self.info, self.ch_names, self.dropped = info, list(ch_names), dropped
        self.whitener, self.rank, self.forward = whitener, len(whitener), forward
        self.n_components = 1 if fixed else 3
        self.pm_snr_db, self.ep_snr_db = pm, ep
        leadfield = whitener @ np.asarray(forward["sol"]["data"], dtype=float)
        if not np.all(np.isfinite(leadfield)):
            raise InputError("the whitened forward is not finite: noise_cov is out of range")
        self.leadfield = check_leadfield(leadfield, "the whitened forward")
        self._basis = SpectralBasis(self.leadfield, np.eye(self.rank))
        self._models, self._prior_cache = collections.OrderedDict(), {}
        self.eeg_names = [name for name in self.ch_names if channel_kind(info, name) == "eeg"]

    @property
    def n_sources(self):
        """int : Columns of the lead field."""
        return self.leadfield.shape[1]

    def __repr__(self):
        priors = ", ".join(
            "auto" if v == "auto" else f"{v:g} dB" for v in (self.pm_snr_db, self.ep_snr_db)
        )
        return (
            f"<SKFOperator | {len(self.ch_names)} channels, rank {self.rank}, "
            f"{self.n_sources // self.n_components} positions x {self.n_components}, "
            f"PM-SNR and EP-SNR {priors}>"
        )

    def _priors(self, n_times):
        """``theta0, q`` of the operator's SNRs for ``n_times`` samples (docs/model.md §4)."""
        if n_times not in self._prior_cache:
            self._prior_cache[n_times] = priors_from_snr(
                self.leadfield, 1.0, self.pm_snr_db, self.ep_snr_db, n_times
            )
        return self._prior_cache[n_times]

    def _model(self, n_times, theta0, q):
        """The spectral model for ``n_times`` samples and these priors; the last few kept."""
        key = (n_times, theta0, q)
        if key not in self._models:
            model = StateSpaceModel.create(self.leadfield, noise_std=1.0, theta0=theta0, q=q)
            self._models[key] = SpectralModel(model, n_times, basis=self._basis)
            while len(self._models) > _MODELS_KEPT:
                self._models.popitem(last=False)  # the least recently used
        self._models.move_to_end(key)
        return self._models[key]

    def check_pick_ori(self, pick_ori):
        """Refuse a ``pick_ori`` the operator's forward cannot give."""
        check_choice("pick_ori", pick_ori, PICK_ORIS)
        if pick_ori == "vector" and self.n_components == 1:
            raise InputError(
                "pick_ori='vector' needs a free-orientation forward; this one is fixed"
            )

    def select(self, info, data, name="data"):
        """The operator's channels of ``data``, checked against it.

        Every channel used must be in ``info`` and good there; every projector of ``info``
        must be one the operator applies; with EEG, the data must carry an
        average-reference projector or be average referenced (to their precision) over
        their good, or all, EEG channels.

        Parameters
        ----------
        info : mne.Info
        data : ndarray, shape (len(info.ch_names), n_times)
        name : str
            What the data are, for the messages (``"evoked"``, ``"epochs[3]"``).

        Returns
        -------
        ndarray, shape (len(ch_names), n_times)
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
        P = make_projector(info["projs"], self.ch_names)[0]
        scale = np.max(np.abs(self.whitener))
        if np.max(np.abs(self.whitener - self.whitener @ P)) > zero_tolerance(P) * scale:
            raise InputError(
                f"{name} has projectors the operator does not apply ({len(info['projs'])} "
                "in its info): make the operator from this info"
            )
        data = np.asarray(data)
        if data.ndim != 2 or len(data) != len(info.ch_names):
            raise InputError(
                f"{name}.data must have shape ({len(info.ch_names)}, n_times) (the channels of "
                f"its info), got {data.shape}"
            )
        index = [info.ch_names.index(c) for c in self.ch_names]
        picked = check_array(f"{name}.data", data[index], (len(index), "n_times"))
        if self.eeg_names:
            check_reference(info, data, name)
        return picked

    def reconstruct(self, data, *, exponent=0.5, smoother=None, method="auto", memory_limit=None):
        """The SKF on data of the operator's channels (in ``ch_names`` order).

        Parameters
        ----------
        data : ndarray, shape (len(ch_names), n_times)
            In the data's units, as :meth:`select` returns them; whitened here. A column of
            NaN is a missing step (a bad segment; docs/model.md §2).
        exponent : float
        smoother : {None, "rts-standardized", "rts-state"}
        method : {"auto", "spectral", "dense", "filterpy"}
            ``"auto"`` and ``"spectral"`` reuse the operator's SVD and recursions.
        memory_limit : float, optional
            Bytes the reconstruction may use (default half the memory available).

        Returns
        -------
        skf_ref.Reconstruction
            In whitened units; ``tuning`` says what ``"auto"`` chose.
        """
        data = check_array("data", data, (len(self.ch_names), "n_times"), finite=False)
        missing = missing_steps(data, "data")  # columns of NaN: bad segments
        settings = check_settings(exponent, smoother, method)
        check_gaps(settings.smoother, missing)
        exponent, smoother, method = settings.exponent, settings.smoother, settings.method
        whitened = self.whitener @ data
        if not np.all(np.isfinite(whitened[:, ~missing])):
            raise InputError("the whitened data are not finite: noise_cov is out of range")
        n, T = self.n_sources, whitened.shape[1]
        if "auto" in (self.pm_snr_db, self.ep_snr_db):
            theta0, q, tuning = choose_priors(
                self.leadfield,
                whitened,
                noise_std=1.0,
                pm_snr_db=self.pm_snr_db,
                ep_snr_db=self.ep_snr_db,
            )
        else:
            tuning = None
            theta0, q = self._priors(T)
        if method in ("auto", "spectral"):  # the operator's SVD (and recursions) again
            memory.check_reconstruction("spectral", smoother, n, self.rank, T, memory_limit)
            rec = self._model(T, theta0, q).apply(whitened, exponent, smoother, memory_limit)
        else:
            rec = reconstruct(
                self.leadfield,
                whitened,
                noise_std=1.0,
                theta0=theta0,
                q=q,
                exponent=exponent,
                smoother=smoother,
                method=method,
                memory_limit=memory_limit,
            )
        return rec.with_tuning(tuning)

    def to_stc(self, reconstruction, tmin, tstep, pick_ori=None):
        """A reconstruction as an MNE source estimate on the operator's source space.

        See :func:`skf_ref.io.stc.make_stc`.
        """
        return make_stc(reconstruction, self.forward["src"], tmin, tstep, pick_ori=pick_ori)


def _snr(name, value):
    if isinstance(value, str) and value == "auto":
        return value
    return check_db(name, value)


def make_skf_operator(
    info,
    forward,
    noise_cov=None,
    *,
    noise_std=None,
    pm_snr_db=0.0,
    ep_snr_db=20.0,
    meg=False,
    eeg=True,
    rank=None,
    verbose=None,
):
    """Prepare the SKF for data of one info, a forward and a noise covariance.

    Everything that does not depend on the data is done here, once (the module docstring
    lists the steps): apply the operator with :func:`skf_ref.apply_skf` (an evoked),
    :func:`skf_ref.apply_skf_epochs` or :func:`skf_ref.apply_skf_raw`, as MNE's inverse
    operators are applied with ``apply_inverse``, ``apply_inverse_epochs`` and
    ``apply_inverse_raw``. ``apply_skf(evoked, forward, noise_cov)`` makes one from the
    evoked's info and gives the same numbers.

    Parameters
    ----------
    info : mne.Info
        The measurement info of the data the operator will be applied to (its channels,
        bad channels and projectors).
    forward : mne.Forward
        Any channels it has beyond the info's are ignored; free or fixed orientation.
    noise_cov : mne.Covariance, optional
        E.g. ``mne.compute_covariance(epochs, tmax=0)``.
    noise_std : float or dict, optional
        Or: the noise standard deviation of every EEG channel in the data's units (V), or
        a dict ``{"eeg": V, "grad": T/m, "mag": T}`` when MEG is used
        (``mne.make_ad_hoc_cov``). Give exactly one of the two.
    pm_snr_db, ep_snr_db : float or "auto"
        The priors' SNRs in dB (docs/model.md §4, on the whitened lead field). ``"auto"``
        chooses them from each data set the operator is applied to (marginal likelihood).
    meg : bool or "mag" or "grad"
        Use MEG channels: all, or magnetometers or gradiometers only (``mne.pick_types``).
    eeg : bool
        Use EEG channels.
    rank : None or "info" or "full" or dict
        The noise covariance's rank, as MNE's ``make_inverse_operator`` takes it: None
        estimates it from the covariance; ``"info"`` reads it from the info, which is right
        for Maxwell-filtered (SSS) MEG, whose covariance has far fewer real dimensions than
        channels.
    verbose : bool or str or int, optional
        The "skf_ref" log's level for this call: the channels used and left out are logged
        at INFO.

    Returns
    -------
    SKFOperator

    Examples
    --------
    >>> import mne
    >>> montage = mne.channels.make_standard_montage("biosemi32")
    >>> info = mne.create_info(montage.ch_names, 1000.0, "eeg").set_montage(montage)
    >>> sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    >>> src = mne.setup_volume_source_space(sphere=sphere, pos=30.0, verbose=False)
    >>> forward = mne.make_forward_solution(info, None, src, sphere, verbose=False)
    >>> info["bads"] = ["Oz"]
    >>> operator = make_skf_operator(info, forward, noise_std=1e-6, verbose=False)
    >>> operator.dropped
    {'bad': ['Oz']}
    >>> operator  # doctest: +ELLIPSIS
    <SKFOperator | 31 channels, rank 30, ... positions x 3, PM-SNR and EP-SNR 0 dB, 20 dB>
    """
    mne = optional("mne", "mne", "make_skf_operator")
    from mne.cov import compute_whitener
    from mne.proj import make_eeg_average_ref_proj

    with verbosity(verbose):
        if not isinstance(info, mne.Info):
            raise InputTypeError(f"info must be an mne.Info, got {describe(info)}")
        if not isinstance(forward, mne.Forward):
            raise InputTypeError(f"forward must be an mne.Forward, got {describe(forward)}")
        channel_types(meg, eeg)
        pm, ep = _snr("pm_snr_db", pm_snr_db), _snr("ep_snr_db", ep_snr_db)
        covariance = noise_covariance(noise_cov, noise_std, info, meg)
        used, dropped = pick_channels(info, forward, covariance, meg, eeg)
        eeg_used = [name for name in used if channel_kind(info, name) == "eeg"]
        picked = mne.pick_info(info, [info.ch_names.index(name) for name in used])
        if eeg_used and not has_average_reference_projector(picked):
            average = mne.create_info(eeg_used, picked["sfreq"], "eeg")
            picked["projs"].append(make_eeg_average_ref_proj(average, False, verbose=False))
        check_noise_covariance(covariance, picked, used)
        whitener = compute_whitener(
            covariance, picked, picks=used, rank=rank, pca=True, verbose=False
        )[0]
        forward = mne.pick_channels_forward(forward, used, ordered=True, verbose=False)
        fixed = mne.forward.is_fixed_orient(forward)
        if not fixed:  # MNE's x, y, z per position, head coordinates
            forward = mne.convert_forward_solution(
                forward, surf_ori=False, force_fixed=False, copy=True, verbose=False
            )
        operator = SKFOperator(
            info=picked,
            ch_names=used,
            dropped=dropped,
            whitener=whitener,
            forward=forward,
            fixed=fixed,
            pm=pm,
            ep=ep,
        )
        logger.debug("    %r", operator)
    return operator
