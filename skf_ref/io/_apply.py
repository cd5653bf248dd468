"""The SKF on MNE-Python objects, modelled on ``apply_inverse`` and its kin.

An evoked, epochs or a raw recording in, MNE source estimates out, through a prepared
:class:`~skf_ref.io._operator.SKFOperator` (:func:`~skf_ref.io._make_operator.make_skf_operator`:
channels, reference, whitening, SVD, priors; see that module):

- :func:`apply_skf`: an ``mne.Evoked``, with an operator or, in one call, with a forward
  and a noise covariance (the operator made from the evoked's info: the same numbers);
- :func:`apply_skf_epochs`: each epoch of an ``mne.Epochs`` (a list, or a generator);
- :func:`skf_ref.io._raw.apply_skf_raw`: a continuous recording (its own module).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from .._utils.checks import (
    InputError,
    InputTypeError,
    check_choice,
    check_instance,
    describe,
    path_renamed,
)
from .._utils.extras import optional
from .._utils.log import logger, verbosity
from .._utils.parallel import HERE, check_n_jobs, plan_jobs
from ..method._search import check_time_constant
from ..method._units import units_cause, units_mismatch, warn_units
from ._jobs import epochs_in_jobs
from ._make_operator import make_skf_operator
from ._noise_cov import baseline_covariance
from ._operator import SKFOperator
from ._stc import PICK_ORIS

__all__ = ["apply_skf", "apply_skf_epochs"]


def _check_evoked(evoked: Any) -> None:
    mne = optional("mne", "mne", "apply_skf")
    if not isinstance(evoked, mne.Evoked):
        raise InputTypeError(f"evoked must be an mne.Evoked, got {describe(evoked)}")


def _operator(evoked, forward, noise_cov, noise_std, snrs, types, verbose, rank=None):
    """The operator given, or one made from the evoked's info (the one-call route)."""
    mne = optional("mne", "mne", "apply_skf")
    given = dict(noise_cov=noise_cov, noise_std=noise_std, **snrs, **types, rank=rank)
    if isinstance(forward, SKFOperator):
        fixed = [name for name, value in given.items() if value is not None]
        if fixed:
            raise InputError(
                f"the operator fixes {', '.join(fixed)}: give them to make_skf_operator, "
                "not to apply_skf with an operator"
            )
        return forward
    if not isinstance(forward, mne.Forward):
        raise InputTypeError(
            f"forward must be an SKFOperator or an mne.Forward, got {describe(forward)}"
        )
    if isinstance(noise_cov, str):
        check_choice("noise_cov", noise_cov, ("baseline",))
        if noise_std is None:
            noise_cov = baseline_covariance(evoked, **types)
    snrs = {name: value for name, value in snrs.items() if value is not None}  # or its defaults
    return make_skf_operator(
        evoked.info,
        forward,
        noise_cov,
        noise_std=noise_std,
        **snrs,
        **types,
        rank=rank,
        verbose=verbose,
    )


@path_renamed
def apply_skf(
    evoked: Any,
    forward: Any,
    noise_cov: Any = None,
    *,
    noise_std: float | dict[str, float] | None = None,
    pm_snr_db: Any = None,
    ep_snr_db: Any = None,
    time_constant_ms: Any = None,
    exponent: float = 0.5,
    smoother: str | None = "rts-smoothed-weights",
    pick_ori: str | None = None,
    path: str = "auto",
    standardize: str | None = None,
    meg: bool | str | None = None,
    eeg: bool | None = None,
    rank: Any = None,
    return_reconstruction: bool = False,
    verbose: bool | str | int | None = None,
) -> Any:
    """The standardized Kalman filter on an evoked: an evoked in, a source estimate out.

    ``apply_skf(evoked, operator)`` applies an operator made by
    :func:`skf_ref.make_skf_operator`; ``apply_skf(evoked, forward, noise_cov)`` makes one
    from the evoked's info first (channels matched by name and type, the average reference
    given to data and lead field alike, whitening with the noise covariance reduced to its
    rank: :mod:`skf_ref.io._make_operator`) and gives the same numbers. As MNE's
    ``apply_inverse``, the evoked is whitened with the noise covariance divided by its
    ``nave``: the covariance is that of one trial, and an average of ``nave`` trials has
    ``nave`` times less noise. Priors come from PM-SNR and EP-SNR on the whitened lead
    field, so they do not depend on units. Free-orientation forwards give the
    per-position norm (``pick_ori=None``) or the three components (``"vector"``); fixed
    orientation gives the signed estimate.

    Which setting. The defaults are exponent 0.5 with ``"rts-smoothed-weights"``
    (:data:`skf_ref.RECOMMENDED_SETTING`), each source position standardized as a whole
    (``standardize="position"``, ``n_orient`` from the forward; for MEG alone, whose blocks
    are singular where the radial orientation is silent, ``"column"``), PM-SNR 0 dB and the
    AR(1) prior with its time constant chosen by the data. The paper's form is
    ``standardize="column"``, which is not rotation invariant for a free orientation
    (docs/model.md §2). docs/choosing.md says how the defaults were chosen and where they
    lose; the CHANGELOG, what they were before.

    Parameters
    ----------
    evoked : mne.Evoked
        With an average-reference projector over its EEG channels, or average referenced
        (EEG). Its ``nave`` divides the noise covariance.
    forward : SKFOperator or mne.Forward
        A prepared operator, or a forward solution (any channels it has beyond the
        evoked's are ignored).
    noise_cov : mne.Covariance or "baseline", optional
        Without an operator: the covariance of one trial (e.g.
        ``mne.compute_covariance(epochs, tmax=0)``), or ``"baseline"``: estimated from the
        evoked's own samples at t <= 0 (:func:`skf_ref.io.baseline_covariance`: the
        covariance of the average, times ``nave``, so that the evoked is whitened with the
        covariance of its own baseline).
    noise_std : float or dict, optional
        Or: the noise standard deviation of one trial in the evoked's units, one per
        channel type in use (see :func:`skf_ref.make_skf_operator`). Give exactly one of
        the two.
    pm_snr_db, ep_snr_db : float or "auto" or (float, float), optional
        Without an operator: the priors' SNRs in dB (docs/model.md §4, "gain" convention,
        whitened lead field), default 0 and 0 dB. ``"auto"`` or a range ``(low, high)``:
        chosen by the marginal likelihood of the data (``"auto"``: -20 to 40 dB); the
        reconstruction's ``tuning`` says what was chosen.
    time_constant_ms : float or "auto" or (float, float), optional
        The stationary AR(1) prior (:func:`skf_ref.ar1_priors`) in place of the EP-SNR's
        random walk: the sources' time constant in ms, the sampling step from the evoked's
        ``info["sfreq"]``; ``"auto"`` or a range ``(low, high)`` in ms: chosen by the
        marginal likelihood in ``log(tau)`` (``"auto"``: 1 to 1000 ms), logged and in the
        reconstruction's ``tuning``. Without an operator, give it or ``ep_snr_db``, not
        both; with an operator it replaces the operator's evolution prior for this evoked
        (the PM-SNR stays the operator's). Default None: the operator's, or the random walk.
    exponent : float
        Standardization exponent alpha, >= 0.
    smoother : {"rts-smoothed-weights", None, "rts-standardized", "rts-state"}
        docs/model.md §3; ``"rts-smoothed-weights"`` divides the smoothed state by its own
        standard deviation.
    pick_ori : {None, "vector"}
        ``None``: per-position amplitude (free) or signed values (fixed); ``"vector"``: the
        three components of a free-orientation forward.
    path : {"auto", "filterpy", "dense", "spectral"}
    standardize : {"column", "position"}, optional
        ``"position"``: each source position's orientations as a whole, as sLORETA
        (docs/model.md §2), the columns per position from the forward (3 free, 1 fixed);
        ``"column"`` (the paper's): each column of the forward on its own. Default: the
        operator's ``SKFOperator.default_standardize`` (``"position"`` with
        EEG, ``"column"`` for MEG alone).
    meg : None or bool or "mag" or "grad"
    eeg : None or bool
        Without an operator: the channel types (:func:`skf_ref.make_skf_operator`);
        default every MEG and EEG channel the evoked, the forward and the covariance
        share, as ``apply_inverse``.
    rank : None or "info" or "full" or dict
        Without an operator: the noise covariance's rank, as MNE takes it (None: estimated
        from it; ``{"eeg": 20}``; :func:`skf_ref.make_skf_operator`). The rank used is
        logged at INFO, and one below half the dimensions the channels carry is warned of.
    return_reconstruction : bool
        Also return the :class:`skf_ref.Reconstruction` (its arrays are in whitened units;
        see :meth:`skf_ref.SKFOperator.reconstruct`).
    verbose : bool or str or int, optional
        The "skf_ref" log's level: the channels used and left out, and ``nave``, are
        logged at INFO.

    Returns
    -------
    stc : mne.SourceEstimate or mne.VolSourceEstimate or mne.MixedSourceEstimate or vector kin
        Times, vertices and subject from the inputs.
    reconstruction : skf_ref.Reconstruction
        Only with ``return_reconstruction=True``.
    """
    with verbosity(verbose):
        _check_evoked(evoked)
        check_choice("pick_ori", pick_ori, PICK_ORIS)
        override = isinstance(forward, SKFOperator)  # else the operator made here holds it
        snrs = dict(pm_snr_db=pm_snr_db, ep_snr_db=ep_snr_db)
        if not override:
            snrs["time_constant_ms"] = time_constant_ms
        operator = _operator(
            evoked, forward, noise_cov, noise_std, snrs, dict(meg=meg, eeg=eeg), verbose, rank
        )
        operator.check_pick_ori(pick_ori)
        data = operator.select(evoked.info, evoked.data, "evoked")
        logger.info(
            "SKF: nave = %g, the evoked whitened with the noise covariance / %g",
            evoked.nave,
            evoked.nave,
        )
        units = units_mismatch(  # the level before the response says the units
            operator.whitener @ data * np.sqrt(evoked.nave), evoked.times <= 0
        )
        warn_units(units)
        with units_cause(units):
            rec = operator.reconstruct(
                data,
                nave=evoked.nave,
                exponent=exponent,
                smoother=smoother,
                path=path,
                standardize=standardize,
                time_constant_ms=time_constant_ms if override else None,
                sfreq=evoked.info["sfreq"],
            )
        stc = operator.to_stc(rec, evoked.times[0], 1.0 / evoked.info["sfreq"], pick_ori)
    return (stc, rec) if return_reconstruction else stc


@path_renamed
def apply_skf_epochs(
    epochs: Any,
    operator: SKFOperator,
    *,
    exponent: float = 0.5,
    smoother: str | None = "rts-smoothed-weights",
    pick_ori: str | None = None,
    path: str = "auto",
    standardize: str | None = None,
    nave: float = 1,
    time_constant_ms: Any = None,
    return_generator: bool = False,
    n_jobs: int | None = None,
    verbose: bool | str | int | None = None,
) -> list[Any] | Iterator[Any]:
    """The SKF on each epoch, as MNE's ``apply_inverse_epochs``.

    The operator's SVD and covariance recursion are computed once for the epochs' length,
    and the epochs' info is checked once; each epoch costs its filter only (with
    ``"auto"`` priors, each epoch is tuned).

    Parameters
    ----------
    epochs : mne.Epochs
    operator : SKFOperator
    exponent : float
        As :func:`apply_skf`.
    smoother : {"rts-smoothed-weights", None, "rts-standardized", "rts-state"}
        As :func:`apply_skf`.
    pick_ori : {None, "vector"}
        As :func:`apply_skf`.
    path : {"auto", "filterpy", "dense", "spectral"}
        As :func:`apply_skf`.
    standardize : {"column", "position"}
        As :func:`apply_skf`.
    nave : float
        The trials each epoch averages, as ``apply_inverse_epochs`` takes it: 1 (single
        trials) unless the epochs hold averages.
    time_constant_ms : float or "auto" or (float, float), optional
        The stationary AR(1) prior (:func:`skf_ref.ar1_priors`) in place of the operator's
        evolution prior, the sampling step from the epochs' ``info["sfreq"]``
        (:meth:`skf_ref.SKFOperator.reconstruct`; ``"auto"`` is chosen on each epoch).
        Default None: the operator's.
    return_generator : bool
        Return a generator that computes an estimate when asked for, not a list.
    n_jobs : int or None
        Jobs the epochs are shared among (MNE's convention), each job one run of
        consecutive epochs and the operator sent to it once: 1 in this process, -1 every
        core; None (default) in this process unless a ``joblib.parallel_config`` is
        active (``with joblib.parallel_config(backend="dask")``: on a Dask cluster). The
        estimates equal those in this process to rounding. A generator computes its
        estimates here: ``return_generator=True`` takes ``n_jobs`` None or 1.
    verbose : bool or str or int, optional

    Returns
    -------
    list or generator of source estimates
        One per epoch, in order.
    """
    mne = optional("mne", "mne", "apply_skf_epochs")
    if not isinstance(epochs, mne.BaseEpochs):
        raise InputTypeError(f"epochs must be an mne.Epochs, got {describe(epochs)}")
    check_instance("operator", operator, SKFOperator, "an SKFOperator (make_skf_operator)")
    operator.check_pick_ori(pick_ori)
    if not isinstance(return_generator, bool):
        raise InputTypeError(f"return_generator must be a bool, got {describe(return_generator)}")
    n_jobs = check_n_jobs(n_jobs)
    if return_generator and n_jobs not in (None, 1):
        raise InputError(
            f"n_jobs={n_jobs} shares the epochs among jobs, each returning its estimates "
            "whole, which a generator (return_generator=True) computes one at a time when "
            "asked for: give one of them"
        )
    if time_constant_ms is not None:  # refused now, not at the first epoch
        time_constant_ms = check_time_constant(time_constant_ms)
    # checked once here; each epoch is run on the checked settings
    checked = operator._check_settings(exponent, smoother, path, standardize)
    settings: dict[str, Any] = dict(settings=checked, nave=nave)
    settings |= dict(time_constant_ms=time_constant_ms, sfreq=epochs.info["sfreq"])
    tmin, tstep = float(epochs.times[0]), 1.0 / epochs.info["sfreq"]
    with verbosity(verbose):
        check = operator.check_info(epochs.info, "epochs")
    jobs = HERE if return_generator else plan_jobs(n_jobs, "apply_skf_epochs")

    def selected() -> Iterator[Any]:
        for k, epoch in enumerate(epochs):
            yield operator.select(epochs.info, epoch, f"epochs[{k}]", check=check)

    def estimates() -> Iterator[Any]:
        with verbosity(verbose):
            for data in selected():
                rec = operator._reconstruct(data, **settings)
                yield operator.to_stc(rec, tmin, tstep, pick_ori)

    if return_generator or jobs.local:
        return estimates() if return_generator else list(estimates())
    with verbosity(verbose):
        data = list(selected())  # read and checked here, as in this process
    return epochs_in_jobs(data, operator, settings, (tmin, tstep), pick_ori, jobs, verbose)
