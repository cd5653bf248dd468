"""The noise covariance a prepared SKF whitens with: given, made, or estimated; checked.

The covariance whitens data and lead field (MNE's whitener, a block per channel type), so
the SKF sees unit-free data with noise covariance ``I`` (docs/model.md §1, §4). A matrix
that is not a covariance (not finite, out of range, not symmetric, with a negative
variance, or zero on the channels used once the projectors are applied) would give a
meaningless finite estimate: it is refused, in an error naming ``noise_cov``.
"""

import numpy as np

from .._utils.checks import InputError, InputTypeError, check_real, describe
from .._utils.extras import optional
from .._utils.precision import zero_tolerance
from .channels import channel_kind

__all__ = ["baseline_covariance", "check_noise_covariance", "noise_covariance"]

_STD_KEYS = ("eeg", "grad", "mag")


def noise_covariance(noise_cov, noise_std, info, meg=False):
    """An ``mne.Covariance``: the one given, or diagonal from noise standard deviations.

    Parameters
    ----------
    noise_cov : mne.Covariance or None
    noise_std : float or dict or None
        Give exactly one: see :func:`skf_ref.make_skf_operator`.
    info : mne.Info
    meg : bool or "mag" or "grad"
        Whether MEG is used (a float ``noise_std`` is EEG's only).

    Returns
    -------
    mne.Covariance
    """
    mne = optional("mne", "mne", "make_skf_operator")

    if (noise_cov is None) == (noise_std is None):
        raise InputError(
            "give exactly one of noise_cov (an mne.Covariance) and noise_std (a standard "
            f"deviation in the data's units), got noise_cov={describe(noise_cov)} and "
            f"noise_std={describe(noise_std)}"
        )
    if isinstance(noise_cov, str) and noise_cov == "baseline":
        raise InputError(
            "noise_cov='baseline' needs the data: make the covariance with "
            "skf_ref.io.baseline_covariance(evoked), or use apply_skf(evoked, forward, "
            "'baseline')"
        )
    if noise_cov is not None:
        if not isinstance(noise_cov, mne.Covariance):
            raise InputTypeError(
                f"noise_cov must be an mne.Covariance (or give noise_std=), got "
                f"{describe(noise_cov)}"
            )
        return noise_cov
    if not isinstance(noise_std, dict):
        if meg:
            raise InputError(
                "noise_std must be a dict {'eeg': V, 'grad': T/m, 'mag': T} when MEG is used "
                f"(meg={meg!r}), got {describe(noise_std)}"
            )
        noise_std = {"eeg": noise_std}
    unknown = sorted(set(noise_std) - set(_STD_KEYS))
    if unknown:
        raise InputError(f"noise_std's keys must be among {list(_STD_KEYS)}, got {unknown}")
    name = "noise_std" if list(noise_std) == ["eeg"] else "noise_std[{!r}]"
    std = {k: check_real(name.format(k), v, positive=True) for k, v in noise_std.items()}
    return mne.make_ad_hoc_cov(info, std=std, verbose=False)


def _block_matrix(covariance, names):
    """The covariance's (n, n) entries for ``names``, diagonal covariances made square."""
    index = [covariance["names"].index(name) for name in names]
    data = np.asarray(covariance["data"])
    if covariance["diag"] or data.ndim == 1:
        return np.diag(data[index])
    return data[np.ix_(index, index)]


def check_noise_covariance(covariance, info, names):
    """Refuse a noise covariance that is none, naming ``noise_cov``.

    Finite, in range, symmetric; positive semi-definite and nonzero per channel type once
    every projector of ``info`` and of the covariance is applied: the blocks MNE's whitener
    whitens (MEG, EEG).

    Parameters
    ----------
    covariance : mne.Covariance
    info : mne.Info
        Of the channels ``names``, with the projectors the whitener applies.
    names : list of str
        The channels used.
    """
    from mne.proj import make_projector

    C = _block_matrix(covariance, names)
    if not np.all(np.isfinite(C)):
        bad = sorted({names[i] for i in np.argwhere(~np.isfinite(C))[:, 0]})
        raise InputError(f"noise_cov contains NaN or Inf (channels {bad[:5]})")
    largest = np.max(np.abs(C))
    if largest > np.sqrt(np.finfo(float).max) / len(C) or (largest < 1e-150 and largest > 0):
        raise InputError(
            f"noise_cov is out of range: its largest entry is {largest:.3g}; give a covariance "
            "in the data's units (V^2, T^2, (T/m)^2)"
        )
    if np.max(np.abs(C - C.T)) > zero_tolerance(C) * largest:
        raise InputError(
            f"noise_cov must be symmetric, got entries that differ from their transposes by up "
            f"to {np.max(np.abs(C - C.T)) / largest:.2g} of the largest entry"
        )
    P = make_projector(info["projs"] + covariance["projs"], names)[0]
    projected = P @ C @ P.T
    for kind in ("meg", "eeg"):
        rows = [i for i, name in enumerate(names) if channel_kind(info, name) == kind]
        if not rows:
            continue
        eigenvalues = np.linalg.eigvalsh(projected[np.ix_(rows, rows)])
        label = f"the {len(rows)} {kind.upper()} channels used"
        if eigenvalues[0] < -zero_tolerance(C) * np.abs(eigenvalues).max():
            raise InputError(
                f"noise_cov must be positive semi-definite, got eigenvalues from "
                f"{eigenvalues[0]:.3g} to {eigenvalues[-1]:.3g} on {label} (after projection): "
                "a negative variance, so no covariance"
            )
        if not eigenvalues[-1] > 0:
            raise InputError(
                f"noise_cov is zero on {label} (after projection): there is no noise to "
                "whiten with"
            )


def baseline_covariance(evoked, *, meg=False, eeg=True):
    """The noise covariance of an evoked's pre-stimulus samples (t <= 0).

    Parameters
    ----------
    evoked : mne.Evoked
        With at least as many samples at t <= 0 as channels of the types picked.
    meg : bool or "mag" or "grad"
    eeg : bool
        The channels to estimate it for (as :func:`skf_ref.make_skf_operator` picks them).

    Returns
    -------
    mne.Covariance
        ``Y_0 Y_0^T / n`` over those samples (about 0, the mean of noise after averaging),
        with the evoked's projectors.
    """
    mne = optional("mne", "mne", "baseline_covariance")
    if not isinstance(evoked, mne.Evoked):
        raise InputTypeError(f"evoked must be an mne.Evoked, got {describe(evoked)}")
    picks = mne.pick_types(evoked.info, meg=meg, eeg=eeg, exclude="bads")
    baseline = evoked.times <= 0
    n_channels, n_samples = len(picks), int(baseline.sum())
    if n_samples < n_channels:
        raise InputError(
            f"noise_cov='baseline' needs at least as many pre-stimulus samples (t <= 0) as "
            f"channels, {n_channels}, got {n_samples}: give noise_cov as an mne.Covariance "
            "(e.g. mne.compute_covariance(epochs, tmax=0)) or a noise standard deviation"
        )
    samples = evoked.data[np.ix_(picks, np.flatnonzero(baseline))]
    return mne.Covariance(
        samples @ samples.T / n_samples,
        [evoked.ch_names[i] for i in picks],
        bads=[],
        projs=evoked.info["projs"],
        nfree=n_samples,
        verbose=False,
    )
