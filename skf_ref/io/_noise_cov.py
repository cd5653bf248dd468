"""The noise covariance a prepared SKF whitens with: given, made, or estimated; checked.

The covariance whitens data and lead field (MNE's whitener, a block per channel type), so
the SKF sees unit-free data with noise covariance ``I`` (docs/model.md §1, §4). It is the
covariance of one trial (``mne.compute_covariance(epochs)``), as MNE's inverse operators
take it: an evoked averaged over ``nave`` trials is whitened with it divided by ``nave``
(:meth:`skf_ref.SKFOperator.reconstruct`). A matrix that is not a covariance (not finite,
out of range, not symmetric, with a negative variance, or zero on the channels used once
the projectors are applied) would give a meaningless finite estimate: it is refused, in an
error naming ``noise_cov``.
"""

from __future__ import annotations

import copy
import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils.checks import InputError, InputTypeError, check_real, describe
from .._utils.extras import optional
from .._utils.precision import zero_tolerance
from ._channels import MODELLED_TYPES, channel_kind

__all__ = [
    "ad_hoc_covariance",
    "baseline_covariance",
    "baseline_matrix",
    "check_noise_covariance",
    "given_covariance",
]


def given_covariance(noise_cov: Any, noise_std: Any) -> Any | None:
    """The ``mne.Covariance`` given, checked; None when ``noise_std`` is given instead.

    Parameters
    ----------
    noise_cov : mne.Covariance or None
    noise_std : float or dict or None
        Give exactly one: see :func:`skf_ref.make_skf_operator`.

    Returns
    -------
    mne.Covariance or None
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
    if noise_cov is not None and not isinstance(noise_cov, mne.Covariance):
        raise InputTypeError(
            f"noise_cov must be an mne.Covariance (or give noise_std=), got {describe(noise_cov)}"
        )
    return noise_cov


def ad_hoc_covariance(noise_std: Any, info: Any) -> Any:
    """A diagonal ``mne.Covariance`` from noise standard deviations, one per channel type.

    Parameters
    ----------
    noise_std : float or dict
        One number when the channels used are of one type; else a dict naming every type
        in use, e.g. ``{"eeg": V, "grad": T/m, "mag": T}`` (keys of types not in use are
        ignored). No type gets MNE's ad hoc default silently.
    info : mne.Info
        Of the channels used.

    Returns
    -------
    mne.Covariance
    """
    mne = optional("mne", "mne", "make_skf_operator")
    in_use = sorted(set(info.get_channel_types()), key=MODELLED_TYPES.index)
    if not isinstance(noise_std, dict):
        if len(in_use) > 1:
            raise InputError(
                f"noise_std must be a dict naming each channel type in use ({in_use}), e.g. "
                "{'eeg': V, 'grad': T/m, 'mag': T}: one number cannot whiten channels of "
                f"several units; got {describe(noise_std)}"
            )
        noise_std = {in_use[0]: noise_std}
    unknown = sorted(set(noise_std) - set(MODELLED_TYPES))
    if unknown:
        raise InputError(f"noise_std's keys must be among {list(MODELLED_TYPES)}, got {unknown}")
    missing = [kind for kind in in_use if kind not in noise_std]
    if missing:
        raise InputError(
            f"noise_std must name every channel type in use, {in_use}: it lacks {missing} "
            "(no type is given a default)"
        )
    name = "noise_std" if len(noise_std) == 1 else "noise_std[{!r}]"
    std = {k: check_real(name.format(k), v, positive=True) for k, v in noise_std.items()}
    return mne.make_ad_hoc_cov(info, std=std, verbose=False)


def _block_matrix(covariance: Any, names: list[str]) -> np.ndarray:
    """The covariance's (n, n) entries for ``names``, diagonal covariances made square."""
    index = [covariance["names"].index(name) for name in names]
    data = np.asarray(covariance["data"])
    if covariance["diag"] or data.ndim == 1:
        return np.diag(data[index])
    return data[np.ix_(index, index)]


def check_noise_covariance(covariance: Any, info: Any, names: list[str]) -> None:
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


def baseline_matrix(
    data: ArrayLike,
    times: ArrayLike,
    name: str = "noise_cov='baseline'",
    instead: str = "give noise_cov as an mne.Covariance (e.g. mne.compute_covariance("
    "epochs, tmax=0)) or noise_std",
) -> NDArray[np.float64]:
    """The covariance of data's pre-stimulus samples (t <= 0): ``Y_0 Y_0^T / n``.

    About 0 is the mean of noise after averaging, so it is not subtracted.

    Parameters
    ----------
    data : array_like, shape (n_channels, n_times)
    times : array_like, shape (n_times,)
        Seconds.
    name : str
        What asked for it, for the message (``"--baseline"``).
    instead : str
        What to do instead when there are fewer samples than channels.

    Returns
    -------
    ndarray, shape (n_channels, n_channels)

    Examples
    --------
    >>> baseline_matrix([[1.0, -1.0, 5.0], [2.0, 0.0, 5.0]], [-0.002, 0.0, 0.001])
    array([[1., 1.],
           [1., 2.]])
    """
    data = np.asarray(data, dtype=float)
    baseline = np.asarray(times) <= 0
    n_channels, n_samples = len(data), int(baseline.sum())
    if n_samples < n_channels:
        raise InputError(
            f"{name} needs at least as many pre-stimulus samples (t <= 0) as channels, "
            f"{n_channels}, got {n_samples}: {instead}"
        )
    samples = data[:, baseline]
    return samples @ samples.T / n_samples


def baseline_covariance(
    evoked: Any,
    tmin: float | None = None,
    tmax: float = 0.0,
    *,
    reg: float = 0.0,
    meg: bool | str | None = None,
    eeg: bool | None = None,
) -> Any:
    """The noise covariance of one trial, from an evoked's samples in a window of noise.

    The samples of an average give the covariance *of the average*: with ``evoked.nave``
    trials averaged, that of one trial is ``nave`` times larger. The covariance returned is
    that of one trial, as ``mne.compute_covariance(epochs)`` gives it (MNE's convention),
    so that the operator's division by ``nave`` (:meth:`skf_ref.SKFOperator.reconstruct`)
    and MNE's ``apply_inverse`` whiten this evoked with the covariance of its own baseline,
    whatever its ``nave``. About 0 is the mean of noise after averaging, so it is not
    subtracted.

    Parameters
    ----------
    evoked : mne.Evoked
    tmin, tmax : float
        The window of noise, in seconds (``tmin=None``: from the first sample; default
        every sample at t <= 0). It should end before the stimulus and its artifact; a
        zero-phase filter spreads both backwards in time.
    reg : float
        MNE's regularization (``mne.cov.regularize`` with this fraction for every channel
        type, in the complement of the projectors, ``rank="full"``): the fraction of the
        mean variance added on the diagonal; 0 (default) for the empirical estimate alone,
        which then needs at least as many samples as channels.
    meg : None or bool or "mag" or "grad"
    eeg : None or bool
        The channels to estimate it for (as :func:`skf_ref.make_skf_operator` picks them;
        None: every MEG or EEG channel).

    Returns
    -------
    mne.Covariance
        ``nave Y Y^T / n`` over the window's ``n`` samples, regularized if asked, with the
        evoked's projectors; ``nfree`` is ``n``.

    Raises
    ------
    skf_ref.InputError
        The window holds fewer than 2 samples, or no channel is picked, or (``reg=0``)
        fewer samples than channels.
    """
    mne = optional("mne", "mne", "baseline_covariance")
    if not isinstance(evoked, mne.Evoked):
        raise InputTypeError(f"evoked must be an mne.Evoked, got {describe(evoked)}")
    reg = check_real("reg", reg, nonnegative=True)
    first = evoked.times[0] if tmin is None else check_real("tmin", tmin)
    last = check_real("tmax", tmax)
    window = (evoked.times >= first - 1e-9) & (evoked.times <= last + 1e-9)
    meg = True if meg is None else meg
    eeg = True if eeg is None else eeg
    picks = mne.pick_types(evoked.info, meg=meg, eeg=eeg, exclude="bads")
    n = int(window.sum())
    if n < 2 or len(picks) == 0:
        raise InputError(
            f"tmin, tmax must hold at least 2 samples of the channels picked, got {n} samples "
            f"in [{first}, {last}] s of an evoked from {evoked.times[0]:.4g} s, and "
            f"{len(picks)} channels"
        )
    if reg == 0 and n < len(picks):
        raise InputError(
            "a baseline covariance without regularization needs at least as many "
            f"pre-stimulus samples (in [{first:.4g}, {last:.4g}] s) as channels, {len(picks)}, "
            f"got {n}: give noise_cov as an mne.Covariance (e.g. mne.compute_covariance("
            "epochs, tmax=0)) or noise_std"
        )
    samples = evoked.data[np.ix_(picks, np.flatnonzero(window))]
    cov = mne.Covariance(
        evoked.nave * (samples @ samples.T / n),
        [evoked.ch_names[i] for i in picks],
        bads=[],
        projs=copy.deepcopy(evoked.info["projs"]),
        nfree=n,
        verbose=False,
    )
    if reg == 0:
        return cov
    info = mne.pick_info(evoked.info, picks)
    with warnings.catch_warnings():
        # MNE may warn of the empirical estimate's low rank: the reason for the
        # regularization
        warnings.filterwarnings("ignore", message=".*rank.*", category=RuntimeWarning)
        return mne.cov.regularize(
            cov, info, mag=reg, grad=reg, eeg=reg, rank="full", verbose=False
        )
