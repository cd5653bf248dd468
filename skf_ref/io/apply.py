"""The SKF on MNE-Python objects: :func:`apply_skf`, modelled on ``apply_inverse``.

From an ``mne.Evoked``, an ``mne.Forward`` and a noise covariance to an MNE source
estimate, in three steps (:func:`prepare`, then :func:`skf_ref.reconstruct`, then
:func:`skf_ref.io.stc.make_stc`):

1. **Channels.** The good EEG channels common to the evoked, the forward and the covariance,
   by name, in the evoked's order; bad channels of any of them are dropped.
2. **Reference.** Data and lead field must carry the same reference (docs/model.md §1). The
   evoked's average-reference projector is applied to both (through the whitener, whose
   rows are orthogonal to the constant vector). Average-referenced data without the
   projector get it; any other reference is refused: the forward cannot be given it.
3. **Whitening.** MNE's whitener (``mne.cov.compute_whitener``, ``pca=True``) of the noise
   covariance with the projector applied: an average-referenced covariance is singular, so
   the data are reduced to its rank (n_channels - 1) instead of inverting it. The whitened
   lead field and data are unit free, so PM-SNR and EP-SNR (docs/model.md §4) mean the same
   whatever units the files use, and the noise covariance of the whitened data is ``I``.
"""

import warnings
from dataclasses import dataclass

import numpy as np

from .._utils.checks import (
    InputError,
    InputTypeError,
    check_array,
    check_choice,
    check_real,
    describe,
)
from .._utils.extras import optional
from .._utils.log import caller_stacklevel
from ..method.reconstruct import METHODS, check_smoother, reconstruct
from ..method.tuning import choose_priors
from .stc import PICK_ORIS

__all__ = ["PICK_ORIS", "WhitenedProblem", "apply_skf", "prepare"]

# Average referenced: the channel mean is this small relative to the data at every time.
_AVERAGE_REFERENCED_RTOL = 1e-9


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


def _average_reference_projector(info):
    """Whether ``info`` holds a projector onto the constant vector over its EEG channels."""
    for proj in info["projs"]:
        vector = np.asarray(proj["data"]["data"], dtype=float)
        names = proj["data"]["col_names"]
        if vector.shape[0] == 1 and len(names) > 1 and np.ptp(vector) <= 1e-12 * abs(vector[0, 0]):
            return True
    return False


def _checked_reference(evoked):
    """The evoked (a copy) with an average-reference projector, or an error saying why not."""
    mne = optional("mne", "mne", "apply_skf")
    from mne.proj import make_eeg_average_ref_proj

    if _average_reference_projector(evoked.info):
        return evoked
    data = evoked.data
    scale = np.max(np.abs(data))
    if scale > 0 and np.max(np.abs(data.mean(axis=0))) <= _AVERAGE_REFERENCED_RTOL * scale:
        # the same data with the projector that says so (MNE refuses to add one to data
        # whose info records a custom reference, so the info is made anew)
        info = mne.create_info(evoked.ch_names, evoked.info["sfreq"], "eeg")
        evoked = mne.EvokedArray(data, info, tmin=evoked.times[0], verbose=False)
        evoked.add_proj(make_eeg_average_ref_proj(info, activate=False, verbose=False))
        return evoked
    if evoked.info["custom_ref_applied"]:
        raise InputError(
            "evoked carries a custom EEG reference other than the average of its channels "
            "(info['custom_ref_applied']); the forward cannot be given it: re-reference with "
            "evoked.set_eeg_reference('average', projection=True)"
        )
    raise InputError(
        "evoked has neither an average-reference projector nor average-referenced data; "
        "data and lead field need the same reference: add the projector with "
        "evoked.set_eeg_reference('average', projection=True)"
    )


def _noise_covariance(noise_cov, noise_std, evoked):
    """An ``mne.Covariance`` from a Covariance, "baseline" or a noise standard deviation."""
    mne = optional("mne", "mne", "apply_skf")

    if (noise_cov is None) == (noise_std is None):
        raise InputError(
            "give exactly one of noise_cov (an mne.Covariance or 'baseline') and noise_std "
            f"(a standard deviation in the evoked's units), got noise_cov={describe(noise_cov)}"
            f" and noise_std={describe(noise_std)}"
        )
    if noise_std is not None:
        sigma = check_real("noise_std", noise_std, positive=True)
        return mne.make_ad_hoc_cov(evoked.info, std=dict(eeg=sigma), verbose=False)
    if isinstance(noise_cov, mne.Covariance):
        return noise_cov
    if isinstance(noise_cov, str):
        check_choice("noise_cov", noise_cov, ("baseline",))
        baseline = evoked.times <= 0
        n_channels, n_samples = len(evoked.ch_names), int(baseline.sum())
        if n_samples < n_channels:
            raise InputError(
                f"noise_cov='baseline' needs at least as many pre-stimulus samples (t <= 0) as "
                f"channels, {n_channels}, got {n_samples}: give noise_cov as an mne.Covariance "
                "(e.g. mne.compute_covariance(epochs, tmax=0)) or a noise standard deviation"
            )
        samples = evoked.data[:, baseline]
        return mne.Covariance(
            samples @ samples.T / n_samples,
            evoked.ch_names,
            bads=[],
            projs=evoked.info["projs"],
            nfree=n_samples,
        )
    if isinstance(noise_cov, bool) or not isinstance(noise_cov, (int, float, np.floating)):
        raise InputTypeError(
            "noise_cov must be an mne.Covariance or 'baseline' (or give noise_std=), got "
            f"{describe(noise_cov)}"
        )
    warnings.warn(
        "a number as noise_cov is a noise standard deviation: give it as noise_std= (the "
        "keyword of reconstruct and the command line); noise_cov=<float> goes in 0.4",
        FutureWarning,
        stacklevel=caller_stacklevel(),
    )
    return _noise_covariance(None, noise_cov, evoked)


def _common_channels(evoked, forward, covariance):
    mne = optional("mne", "mne", "apply_skf")

    eeg = [evoked.ch_names[i] for i in mne.pick_types(evoked.info, eeg=True, exclude="bads")]
    in_forward = set(forward["sol"]["row_names"]) - set(forward["info"]["bads"])
    in_covariance = set(covariance["names"]) - set(covariance["bads"])
    common = [name for name in eeg if name in in_forward and name in in_covariance]
    if not common:
        raise InputError(
            f"no EEG channel is common to the evoked ({len(eeg)} good EEG channels, e.g. "
            f"{eeg[:3]}), the forward ({len(in_forward)}, e.g. {sorted(in_forward)[:3]}) and "
            f"the noise covariance ({len(in_covariance)}, e.g. {sorted(in_covariance)[:3]})"
        )
    return common


def prepare(evoked, forward, noise_cov=None, *, noise_std=None):
    """Pick, reference and whiten MNE objects for the SKF (steps 1-3 of the module).

    Parameters
    ----------
    evoked : mne.Evoked
    forward : mne.Forward
    noise_cov : mne.Covariance or "baseline", optional
        A covariance (e.g. ``mne.compute_covariance(epochs, tmax=0)``) or ``"baseline"``:
        estimated from the evoked's samples at t <= 0, which must be at least as many as the
        channels. (A float here is read as ``noise_std``, with a ``FutureWarning``.)
    noise_std : float, optional
        Or: the noise standard deviation of every EEG channel in the evoked's units (V).
        Give exactly one of the two.

    Returns
    -------
    WhitenedProblem
    """
    mne = optional("mne", "mne", "apply_skf")
    from mne.cov import compute_whitener

    if not isinstance(evoked, mne.Evoked):
        raise InputTypeError(f"evoked must be an mne.Evoked, got {describe(evoked)}")
    if not isinstance(forward, mne.Forward):
        raise InputTypeError(f"forward must be an mne.Forward, got {describe(forward)}")
    covariance = _noise_covariance(noise_cov, noise_std, evoked)
    ch_names = _common_channels(evoked, forward, covariance)
    evoked = evoked.copy().pick(ch_names)
    check_array("evoked.data", evoked.data, (len(ch_names), "n_times"))
    evoked = _checked_reference(evoked)
    whitener, _, rank = compute_whitener(
        covariance, evoked.info, picks=ch_names, pca=True, return_rank=True, verbose=False
    )
    forward = mne.pick_channels_forward(forward, ch_names, ordered=True, verbose=False)
    fixed = mne.forward.is_fixed_orient(forward)
    if not fixed:  # MNE's x, y, z per position, head coordinates
        forward = mne.convert_forward_solution(
            forward, surf_ori=False, force_fixed=False, copy=True, verbose=False
        )
    L = np.asarray(forward["sol"]["data"], dtype=float)
    return WhitenedProblem(
        leadfield=whitener @ L,
        data=whitener @ evoked.data,
        ch_names=ch_names,
        rank=int(rank),
        forward=forward,
        n_components=1 if fixed else 3,
        tmin=float(evoked.times[0]),
        tstep=1.0 / evoked.info["sfreq"],
    )


def apply_skf(
    evoked,
    forward,
    noise_cov=None,
    *,
    noise_std=None,
    pm_snr_db=0.0,
    ep_snr_db=20.0,
    exponent=0.5,
    smoother=None,
    pick_ori=None,
    method="auto",
    return_reconstruction=False,
):
    """The standardized Kalman filter on MNE objects: an evoked in, a source estimate out.

    Channels are matched by name, the average reference is applied to data and lead field
    alike, and both are whitened with the noise covariance reduced to its rank (see the
    module docstring). Priors come from PM-SNR and EP-SNR on the whitened lead field, so
    they do not depend on units. Free-orientation forwards give the per-position norm
    (``pick_ori=None``) or the three components (``"vector"``); fixed orientation gives the
    signed estimate.

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
        EEG data; with an average-reference projector, or average referenced.
    forward : mne.Forward
        EEG forward solution; any channels it has beyond the evoked's are ignored.
    noise_cov : mne.Covariance or "baseline", optional
    noise_std : float, optional
        The noise: give exactly one (see :func:`prepare`).
    pm_snr_db, ep_snr_db : float or "auto"
        The priors' SNRs in dB (docs/model.md §4, "gain" convention, whitened lead field).
        ``"auto"``: chosen by the marginal likelihood of the data (:func:`skf_ref.method.tuning`,
        -20..40 dB); the reconstruction's ``tuning`` says what was chosen.
    exponent : float
        Standardization exponent alpha, >= 0.
    smoother : {None, "rts-standardized", "rts-state"}
    pick_ori : {None, "vector"}
        ``None``: per-position amplitude (free) or signed values (fixed); ``"vector"``: the
        three components of a free-orientation forward.
    method : {"auto", "filterpy", "dense", "spectral"}
    return_reconstruction : bool
        Also return the :class:`skf_ref.Reconstruction` (its arrays are in whitened units).

    Returns
    -------
    stc : mne.SourceEstimate or mne.VolSourceEstimate or mne.MixedSourceEstimate or vector kin
        Times, vertices and subject from the inputs.
    reconstruction : skf_ref.Reconstruction
        Only with ``return_reconstruction=True``.
    """
    check_choice("pick_ori", pick_ori, PICK_ORIS)
    smoother = check_smoother(smoother)
    check_choice("method", method, METHODS)
    problem = prepare(evoked, forward, noise_cov, noise_std=noise_std)
    if pick_ori == "vector" and problem.n_components == 1:
        raise InputError("pick_ori='vector' needs a free-orientation forward; this one is fixed")
    theta0, q, tuning = choose_priors(  # whitened: noise std 1
        problem.leadfield, problem.data, noise_std=1.0, pm_snr_db=pm_snr_db, ep_snr_db=ep_snr_db
    )
    rec = reconstruct(
        problem.leadfield,
        problem.data,
        noise_std=1.0,
        theta0=theta0,
        q=q,
        exponent=exponent,
        smoother=smoother,
        method=method,
    )
    rec = rec.with_tuning(tuning)
    stc = rec.to_stc(problem.forward["src"], problem.tmin, problem.tstep, pick_ori=pick_ori)
    return (stc, rec) if return_reconstruction else stc
