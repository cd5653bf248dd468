"""The SKF on MNE-Python objects, modelled on ``apply_inverse`` and its kin.

An evoked, epochs or a raw recording in, MNE source estimates out, through a prepared
:class:`~skf_ref.io.operator.SKFOperator` (:func:`~skf_ref.io.operator.make_skf_operator`:
channels, reference, whitening, SVD, priors; see that module):

- :func:`apply_skf`: an ``mne.Evoked``, with an operator or, in one call, with a forward
  and a noise covariance (the operator made from the evoked's info: the same numbers);
- :func:`apply_skf_epochs`: each epoch of an ``mne.Epochs`` (a list, or a generator);
- :func:`skf_ref.io.raw.apply_skf_raw`: a continuous recording (its own module).
"""

import warnings
from dataclasses import dataclass

import numpy as np

from .._utils.checks import InputError, InputTypeError, check_choice, check_instance, describe
from .._utils.extras import optional
from .._utils.log import caller_stacklevel, verbosity
from .noise_cov import baseline_covariance
from .operator import SKFOperator, make_skf_operator
from .stc import PICK_ORIS

__all__ = ["PICK_ORIS", "WhitenedProblem", "apply_skf", "apply_skf_epochs", "prepare"]


@dataclass(frozen=True, eq=False)
class WhitenedProblem:
    """The SKF's inputs from MNE objects, whitened: unit free, noise covariance ``I``.

    Attributes
    ----------
    leadfield : ndarray, shape (rank, n_sources)
        Whitened lead field ``W L``; free orientation in MNE's x, y, z (head coordinates).
    data : ndarray, shape (rank, n_times)
        Whitened data ``W Y``.
    ch_names : list of str
        The channels used, in the evoked's order.
    rank : int
        Rank of the noise covariance after projection (rows of ``W``).
    forward : mne.Forward
        The forward restricted to ``ch_names`` (free orientation in head coordinates).
    n_components : int
        Columns per source position: 3 (free orientation) or 1 (fixed).
    tmin, tstep : float
        First sample's time and the sampling interval, seconds.
    """

    leadfield: np.ndarray
    data: np.ndarray
    ch_names: list
    rank: int
    forward: object
    n_components: int
    tmin: float
    tstep: float


def _check_evoked(evoked):
    mne = optional("mne", "mne", "apply_skf")
    if not isinstance(evoked, mne.Evoked):
        raise InputTypeError(f"evoked must be an mne.Evoked, got {describe(evoked)}")


def _operator(evoked, forward, noise_cov, noise_std, snrs, types, verbose):
    """The operator given, or one made from the evoked's info (the one-call route)."""
    mne = optional("mne", "mne", "apply_skf")
    given = dict(noise_cov=noise_cov, noise_std=noise_std, **snrs, **types)
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
    types = dict(meg=types["meg"] or False, eeg=True if types["eeg"] is None else types["eeg"])
    if isinstance(noise_cov, str) and noise_cov == "baseline" and noise_std is None:
        noise_cov = baseline_covariance(evoked, **types)
    elif isinstance(noise_cov, (int, float, np.floating)) and not isinstance(noise_cov, bool):
        warnings.warn(
            "a number as noise_cov is a noise standard deviation: give it as noise_std= (the "
            "keyword of reconstruct and the command line); noise_cov=<float> goes in 0.4",
            FutureWarning,
            stacklevel=caller_stacklevel(),
        )
        noise_cov, noise_std = None, noise_cov
    elif isinstance(noise_cov, str):
        check_choice("noise_cov", noise_cov, ("baseline",))
    snrs = {
        name: default if snrs[name] is None else snrs[name]
        for name, default in (("pm_snr_db", 0.0), ("ep_snr_db", 20.0))
    }
    return make_skf_operator(
        evoked.info, forward, noise_cov, noise_std=noise_std, **snrs, **types, verbose=verbose
    )


def prepare(evoked, forward, noise_cov=None, *, noise_std=None):
    """Pick, reference and whiten MNE objects for the SKF.

    Parameters
    ----------
    evoked : mne.Evoked
    forward : mne.Forward or SKFOperator
    noise_cov : mne.Covariance or "baseline", optional
    noise_std : float, optional
        The noise, as :func:`apply_skf` takes it.

    Returns
    -------
    WhitenedProblem
    """
    _check_evoked(evoked)
    snrs, types = dict(pm_snr_db=None, ep_snr_db=None), dict(meg=None, eeg=None)
    operator = _operator(evoked, forward, noise_cov, noise_std, snrs, types, False)
    data = operator.select(evoked.info, evoked.data, "evoked")
    return WhitenedProblem(
        leadfield=operator.leadfield,
        data=operator.whitener @ data,
        ch_names=operator.ch_names,
        rank=operator.rank,
        forward=operator.forward,
        n_components=operator.n_components,
        tmin=float(evoked.times[0]),
        tstep=1.0 / evoked.info["sfreq"],
    )


def apply_skf(
    evoked,
    forward,
    noise_cov=None,
    *,
    noise_std=None,
    pm_snr_db=None,
    ep_snr_db=None,
    exponent=0.5,
    smoother=None,
    pick_ori=None,
    method="auto",
    meg=None,
    eeg=None,
    return_reconstruction=False,
    verbose=None,
):
    """The standardized Kalman filter on an evoked: an evoked in, a source estimate out.

    ``apply_skf(evoked, operator)`` applies an operator made by
    :func:`skf_ref.make_skf_operator`; ``apply_skf(evoked, forward, noise_cov)`` makes one
    from the evoked's info first (channels matched by name, the average reference given to
    data and lead field alike, whitening with the noise covariance reduced to its rank:
    :mod:`skf_ref.io.operator`) and gives the same numbers. Priors come from PM-SNR and
    EP-SNR on the whitened lead field, so they do not depend on units. Free-orientation
    forwards give the per-position norm (``pick_ori=None``) or the three components
    (``"vector"``); fixed orientation gives the signed estimate.

    Which setting. The defaults are the setting the package recommends
    (:data:`skf_ref.RECOMMENDED_SETTING`): the original SKF, exponent 0.5 without smoothing.
    In the study it tells a deep source present from absent about as well as MNE's sLORETA,
    where the paper's setting (``**skf_ref.PAPER_SETTING``) does not
    (validation/report/REPORT.md, "Which setting, and against what"). On an MNE sphere
    forward (12 mm volume grid of 1254 positions, biosemi64; one dipole at a time at 9
    positions from the bottom of the grid to its top, 30 averaged epochs, peak SNR 20 dB;
    ``tests/test_apply.py`` measures this) the peak at the pulse's maximum was, median
    (range) over the dipoles: 17 mm (0-69) off with exponent 0.5 and no smoothing, 17 mm
    (0-51) with ``"rts-state"``, 24 mm (17-74) with ``"rts-standardized"``, and 50 mm
    (29-123) with exponent 1.25 and no smoothing (the maximum goes to weakly seen positions,
    the bottom of the grid). The largest errors belong to the deepest dipoles: free
    orientation standardizes each of a position's three columns on its own (docs/model.md
    §1), which is not rotation invariant and misplaces deep sources by a grid step or more
    even without noise.

    Parameters
    ----------
    evoked : mne.Evoked
        With an average-reference projector, or average referenced (EEG).
    forward : SKFOperator or mne.Forward
        A prepared operator, or a forward solution (any channels it has beyond the
        evoked's are ignored).
    noise_cov : mne.Covariance or "baseline", optional
        Without an operator: a covariance (e.g. ``mne.compute_covariance(epochs,
        tmax=0)``) or ``"baseline"``: estimated from the evoked's samples at t <= 0
        (:func:`baseline_covariance`). (A float here is read as ``noise_std``, with a
        ``FutureWarning``.)
    noise_std : float or dict, optional
        Or: the noise standard deviation in the evoked's units (see
        :func:`skf_ref.make_skf_operator`). Give exactly one of the two.
    pm_snr_db, ep_snr_db : float or "auto", optional
        Without an operator: the priors' SNRs in dB (docs/model.md §4, "gain" convention,
        whitened lead field), default 0 and 20 dB. ``"auto"``: chosen by the marginal
        likelihood of the data (-20..40 dB); the reconstruction's ``tuning`` says what was
        chosen.
    exponent : float
        Standardization exponent alpha, >= 0.
    smoother : {None, "rts-standardized", "rts-state"}
    pick_ori : {None, "vector"}
        ``None``: per-position amplitude (free) or signed values (fixed); ``"vector"``: the
        three components of a free-orientation forward.
    method : {"auto", "filterpy", "dense", "spectral"}
    meg, eeg : optional
        Without an operator: the channel types (:func:`skf_ref.make_skf_operator`), default
        EEG only.
    return_reconstruction : bool
        Also return the :class:`skf_ref.Reconstruction` (its arrays are in whitened units).
    verbose : bool or str or int, optional
        The "skf_ref" log's level: the channels used and left out are logged at INFO.

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
        snrs = dict(pm_snr_db=pm_snr_db, ep_snr_db=ep_snr_db)
        operator = _operator(
            evoked, forward, noise_cov, noise_std, snrs, dict(meg=meg, eeg=eeg), verbose
        )
        operator.check_pick_ori(pick_ori)
        data = operator.select(evoked.info, evoked.data, "evoked")
        rec = operator.reconstruct(data, exponent=exponent, smoother=smoother, method=method)
        stc = operator.to_stc(rec, evoked.times[0], 1.0 / evoked.info["sfreq"], pick_ori)
    return (stc, rec) if return_reconstruction else stc


def apply_skf_epochs(
    epochs,
    operator,
    *,
    exponent=0.5,
    smoother=None,
    pick_ori=None,
    method="auto",
    return_generator=False,
    verbose=None,
):
    """The SKF on each epoch, as MNE's ``apply_inverse_epochs``.

    The operator's SVD and covariance recursion are computed once for the epochs' length;
    each epoch costs its filter only (with ``"auto"`` priors, each epoch is tuned).

    Parameters
    ----------
    epochs : mne.Epochs
    operator : SKFOperator
    exponent, smoother, pick_ori, method
        As :func:`apply_skf`.
    return_generator : bool
        Return a generator that computes an estimate when asked for, not a list.
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
    settings = dict(exponent=exponent, smoother=smoother, method=method)
    tmin, tstep = float(epochs.times[0]), 1.0 / epochs.info["sfreq"]

    def estimates():
        with verbosity(verbose):
            for k, epoch in enumerate(epochs):
                data = operator.select(epochs.info, epoch, f"epochs[{k}]")
                rec = operator.reconstruct(data, **settings)
                yield operator.to_stc(rec, tmin, tstep, pick_ori)

    return estimates() if return_generator else list(estimates())
