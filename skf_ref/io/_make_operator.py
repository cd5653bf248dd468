"""Making a prepared SKF, as MNE's ``make_inverse_operator``: every step that does not
depend on the data, done once (:func:`make_skf_operator`):

1. **Channels.** Every MEG and EEG channel the info, the forward and the noise covariance
   share and that is good in each, in the info's order, as MNE's ``apply_inverse`` takes
   them; ``meg=`` and ``eeg=`` restrict the types (as ``mne.pick_types`` names them).
   Channels are matched by name and type (a channel the forward models as EEG that the
   data call ``csd`` or ``misc`` is refused). Each one left out is listed, with the
   reason, in :class:`skf_ref.SKFOperator`'s ``dropped`` and in the "skf_ref" log (``verbose=``).
2. **Reference** (EEG only). Data and lead field must carry the same reference
   (docs/model.md §1): the whitener includes an average-reference projector over the EEG
   channels used (the info's own, which must cover every one of them, or one added), so
   the forward is given the average reference and the data are projected onto it. Data
   may come with that projector, or be average referenced already, to their precision
   (MNE's default, ``set_eeg_reference("average", projection=False)``; float32 files
   included); any other reference is refused when the operator is applied
   (:meth:`skf_ref.SKFOperator.select`).
3. **Whitening.** MNE's whitener (``mne.cov.compute_whitener``, ``pca=True``) of the noise
   covariance of one trial with every projector applied: a block per channel type (MEG,
   EEG), so it whitens mixed units as MNE does, and it reduces the data to the
   covariance's rank. The covariance is checked first: finite, in range, symmetric,
   positive semi-definite with a nonzero block per channel type after projection. An
   average of ``nave`` trials is whitened with the covariance divided by ``nave`` when the
   operator is applied (:meth:`skf_ref.SKFOperator.reconstruct`), as MNE's
   ``prepare_inverse_operator`` does.
4. **The SKF's model.** The thin SVD of the whitened lead field
   (:class:`skf_ref.method.SpectralBasis`) once, and for each number
   of samples the covariance recursion (:class:`skf_ref.method.SpectralModel`
   with that basis), kept for the next data set of that length. The priors come from
   PM-SNR and EP-SNR on the whitened lead field (docs/model.md §4): ``q`` depends on the
   number of samples; ``"auto"`` or a search range on the data (chosen again for each
   data set). Or, with a time constant, from PM-SNR and the stationary AR(1) prior
   (:func:`skf_ref.ar1_priors`), whose ``q`` and transition depend on the data's sampling
   rate only.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from .._utils.checks import InputError, InputTypeError, describe
from .._utils.extras import optional
from .._utils.log import caller_stacklevel, logger, verbosity
from ..method._priors import DEFAULT_TIME_CONSTANT_MS
from ..method._search import check_one_evolution_prior, check_time_constant
from ._channels import channel_types, has_average_reference_projector, pick_channels
from ._noise_cov import ad_hoc_covariance, check_noise_covariance, given_covariance
from ._operator import SKFOperator, check_prior

__all__ = ["check_rank", "make_skf_operator"]

_RANKS = (None, "info", "full")


def check_rank(rank: Any) -> None:
    """Refuse a ``rank`` MNE's whitener does not take: None, ``"info"``, ``"full"``, or a
    dict of positive ints by channel type (``{"eeg": 20}``)."""
    if isinstance(rank, dict):
        for kind, value in rank.items():
            if kind not in ("eeg", "meg", "mag", "grad") or isinstance(value, bool):
                break
            if not isinstance(value, int | np.integer) or value < 1:
                break
        else:
            return
    elif isinstance(rank, str | type(None)) and rank in _RANKS:
        return
    raise InputError(
        "rank must be None (estimated from the noise covariance), 'info', 'full' or a dict "
        f"of positive ints by channel type (e.g. {{'eeg': 20}}), got {rank!r}"
    )


def _about_rank(rank: int, asked: Any, info: Any, used: list[str], covariance: Any) -> None:
    """Log the whitener's rank, as MNE's ``apply_inverse`` does, and warn when it drops
    most of the dimensions the channels carry (their number minus the projectors)."""
    carried = len(used) - sum(
        1 for proj in info["projs"] if set(proj["data"]["col_names"]) & set(used)
    )
    logger.info(
        "    Computing rank from the noise covariance with rank=%r: whitener of rank %d, of "
        "the %d dimensions the %d channels carry",
        asked,
        rank,
        carried,
        len(used),
    )
    if rank * 2 >= carried:
        return
    nfree = int(covariance.get("nfree", 0) or 0)
    cause = (
        f"the noise covariance was estimated from too few samples (its nfree is {nfree}, "
        f"for {carried} dimensions)"
        if 0 < nfree < carried
        else "the noise covariance is nearly singular"
    )
    warnings.warn(
        f"the whitener has rank {rank} for {len(used)} channels ({carried} dimensions after "
        f"the projectors): {carried - rank} dimensions of every data set are dropped; "
        f"{cause}: regularize it (mne.cov.regularize, or mne.compute_covariance(..., "
        "method='shrunk')), or give rank= (e.g. {'eeg': N}) when the rank estimated is wrong",
        UserWarning,
        stacklevel=caller_stacklevel(),
    )


def make_skf_operator(
    info: Any,
    forward: Any,
    noise_cov: Any = None,
    *,
    noise_std: float | dict[str, float] | None = None,
    pm_snr_db: Any = 0.0,
    ep_snr_db: Any = None,
    time_constant_ms: Any = None,
    meg: bool | str | None = None,
    eeg: bool | None = None,
    rank: Any = None,
    verbose: bool | str | int | None = None,
) -> SKFOperator:
    """Prepare the SKF for data of one info, a forward and a noise covariance.

    Everything that does not depend on the data is done here, once (the module docstring
    lists the steps): apply the operator with :func:`skf_ref.apply_skf` (an evoked),
    :func:`skf_ref.apply_skf_epochs` or :func:`skf_ref.apply_skf_raw`, as MNE's inverse
    operators are applied with ``apply_inverse``, ``apply_inverse_epochs`` and
    ``apply_inverse_raw``; save it with :func:`skf_ref.write_skf_operator`.
    ``apply_skf(evoked, forward, noise_cov)`` makes one from the evoked's info and gives
    the same numbers.

    Parameters
    ----------
    info : mne.Info
        The measurement info of the data the operator will be applied to (its channels,
        their types, bad channels and projectors).
    forward : mne.Forward
        Any channels it has beyond the info's are ignored; free or fixed orientation.
    noise_cov : mne.Covariance, optional
        The noise covariance of one trial, e.g. ``mne.compute_covariance(epochs,
        tmax=0)``: an evoked is whitened with it divided by its ``nave``.
    noise_std : float or dict, optional
        Or: the noise standard deviation of one trial in the data's units: one number
        when the channels used are of one type (V for EEG), else a dict naming every type
        in use, ``{"eeg": V, "grad": T/m, "mag": T}`` (``mne.make_ad_hoc_cov``). Give
        exactly one of the two.
    pm_snr_db, ep_snr_db : float or "auto" or (float, float)
        The priors' SNRs in dB (docs/model.md §4, on the whitened lead field), default 0
        dB for the PM-SNR. ``"auto"`` or a range ``(low, high)`` in dB: chosen from each data
        set the operator is applied to by the marginal likelihood (:func:`skf_ref.tune`;
        ``"auto"`` searches -20 to 40 dB). ``ep_snr_db`` given: the paper's random walk at
        that EP-SNR; None (default): the AR(1) prior below.
    time_constant_ms : float or "auto" or (float, float), optional
        In place of the EP-SNR's random walk, the stationary AR(1) prior
        (:func:`skf_ref.ar1_priors`): the sources' time constant in ms, ``rho =
        exp(-dt / tau)`` with ``dt`` from the data's ``info["sfreq"]``; ``"auto"`` or a
        range ``(low, high)`` in ms: chosen from each data set by the marginal likelihood in
        ``log(tau)`` (``"auto"`` searches 1 to 1000 ms). Give it or ``ep_snr_db``, not
        both. Default None: ``"auto"`` (docs/choosing.md), unless ``ep_snr_db`` is given.
    meg : None or bool or "mag" or "grad"
        MEG channels: None (default) uses them when the info, the forward and the noise
        covariance share them; True asks for them; ``"mag"`` or ``"grad"`` for one kind
        only; False leaves them out.
    eeg : None or bool
        EEG channels, likewise.
    rank : None or "info" or "full" or dict
        The noise covariance's rank, as MNE's ``make_inverse_operator`` takes it: None
        estimates it from the covariance; ``"info"`` reads it from the info, which is right
        for Maxwell-filtered (SSS) MEG, whose covariance has far fewer real dimensions than
        channels; a dict gives it per channel type (``{"eeg": 20}``). The whitener keeps
        that many dimensions of the data, and drops the rest: the rank used is logged at
        INFO, and a rank below half the dimensions the channels carry (their number
        minus the projectors) is warned of, with its likely cause (a covariance estimated
        from fewer samples than channels: regularize it, ``mne.cov.regularize`` or
        ``mne.compute_covariance(..., method="shrunk")``, or give ``rank=``).
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
    <SKFOperator | 31 channels, rank 30, ... positions x 3, PM-SNR 0 dB, time constant auto>
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
        check_one_evolution_prior(ep_snr_db, time_constant_ms)
        pm, tau, ep = check_prior("pm_snr_db", pm_snr_db), None, None
        if ep_snr_db is not None:  # the paper's random walk
            ep = check_prior("ep_snr_db", ep_snr_db)
        else:  # the AR(1) prior, its time constant chosen by the data unless given
            given = DEFAULT_TIME_CONSTANT_MS if time_constant_ms is None else time_constant_ms
            tau = check_time_constant(given)
        covariance = given_covariance(noise_cov, noise_std)
        used, dropped = pick_channels(info, forward, covariance, meg, eeg)
        picked = mne.pick_info(info, [info.ch_names.index(name) for name in used])
        eeg_used = [c for c, k in zip(used, picked.get_channel_types(), strict=True) if k == "eeg"]
        if eeg_used and not has_average_reference_projector(picked, eeg_used, "info"):
            average = mne.create_info(eeg_used, picked["sfreq"], "eeg")
            picked["projs"].append(make_eeg_average_ref_proj(average, False, verbose=False))
        if covariance is None:
            covariance = ad_hoc_covariance(noise_std, picked)
        check_noise_covariance(covariance, picked, used)
        check_rank(rank)
        whitener = compute_whitener(
            covariance, picked, picks=used, rank=rank, pca=True, verbose=False
        )[0]
        _about_rank(len(whitener), rank, picked, used, covariance)
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
            time_constant=tau,
        )
        logger.debug("    %r", operator)
    return operator
