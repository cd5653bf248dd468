"""The noise covariance of an average, from its own pre-stimulus samples, in MNE's convention.

Shared recordings are often averages without their single trials, so MNE's
``mne.compute_covariance(epochs, tmax=0)`` has no epochs to read. The samples of an average
before the stimulus are noise of the average: their covariance estimates ``C / nave``, where
``C`` is the noise covariance of one trial. MNE's inverse methods take ``C`` and divide it by
``evoked.nave`` themselves, so :func:`baseline_noise_cov` returns ``nave`` times the
baseline's covariance: the same whitening, whatever ``nave`` is (a wrong ``nave`` cancels
out, as long as the evoked carries the one used here).

Few samples, band-limited: a baseline of 80 ms at 1200 Hz, band-passed 20-250 Hz, has about
``2 x 230 Hz x 0.08 s = 37`` temporal degrees of freedom, and its empirical covariance of 73
channels has rank about 60, not 72. It is regularized as MNE regularizes an EEG covariance
(``mne.cov.regularize``: a fraction ``reg`` of the mean variance added on the diagonal), in
the complement of the projectors (``rank="full"``; with ``rank="info"`` MNE would load a
subspace chosen among the near-null eigenvectors of the rank-deficient estimate, which
changes with its scale, and so with ``nave``).
"""

from __future__ import annotations

import copy
import warnings
from typing import TYPE_CHECKING

import numpy as np

from .._utils.checks import InputError, InputTypeError, check_real, describe
from .._utils.extras import optional

if TYPE_CHECKING:
    import mne

__all__ = ["baseline_noise_cov"]


def baseline_noise_cov(
    evoked: mne.Evoked, tmin: float | None = None, tmax: float = 0.0, *, reg: float = 0.1
) -> mne.Covariance:
    """The noise covariance of one trial, from an average's pre-stimulus samples.

    Parameters
    ----------
    evoked : mne.Evoked
        An average (EEG), with its ``nave`` (the number of trials averaged) and an
        average-reference projector or average reference.
    tmin, tmax : float
        The window of noise, in seconds (``tmin=None``: from the first sample). It should
        end before the stimulus and its artifact; a zero-phase filter spreads both backwards
        in time.
    reg : float
        MNE's regularization (``mne.cov.regularize(..., eeg=reg)``): the fraction of the
        mean variance added on the diagonal; 0 for the empirical estimate alone.

    Returns
    -------
    mne.Covariance
        ``nave`` times the empirical covariance ``Y Y^T / n`` of the window's ``n`` samples
        (their mean taken as zero, the mean of noise after averaging), regularized;
        ``nfree`` is ``n``. MNE's ``apply_inverse`` divides it by ``evoked.nave`` again.

    Examples
    --------
    >>> import mne
    >>> info = mne.create_info(["a", "b", "c"], 1000.0, "eeg")
    >>> rng = np.random.default_rng(0)
    >>> evoked = mne.EvokedArray(rng.standard_normal((3, 200)) * 1e-6, info, tmin=-0.1,
    ...                          nave=100, verbose=False)
    >>> cov = baseline_noise_cov(evoked, tmax=0.0, reg=0.0)
    >>> baseline = evoked.data[:, evoked.times <= 0]
    >>> bool(np.allclose(cov.data, 100 * baseline @ baseline.T / baseline.shape[1]))
    True
    """
    mne = optional("mne", "mne", "baseline_noise_cov")
    if not isinstance(evoked, mne.Evoked):
        raise InputTypeError(f"evoked must be an mne.Evoked, got {describe(evoked)}")
    reg = check_real("reg", reg, nonnegative=True)
    first = evoked.times[0] if tmin is None else check_real("tmin", tmin)
    last = check_real("tmax", tmax)
    window = (evoked.times >= first - 1e-9) & (evoked.times <= last + 1e-9)
    picks = mne.pick_types(evoked.info, meg=False, eeg=True, exclude="bads")
    if window.sum() < 2 or len(picks) == 0:
        raise InputError(
            f"tmin, tmax must hold at least 2 samples of EEG channels, got {window.sum()} "
            f"samples in [{first}, {last}] s of an evoked from {evoked.times[0]:.4g} s"
        )
    samples = evoked.data[np.ix_(picks, np.flatnonzero(window))]
    names = [evoked.ch_names[i] for i in picks]
    cov = mne.Covariance(
        evoked.nave * (samples @ samples.T) / samples.shape[1],
        names,
        bads=[],
        projs=copy.deepcopy(evoked.info["projs"]),
        nfree=samples.shape[1],
        verbose=False,
    )
    if reg == 0:
        return cov
    info = mne.pick_info(evoked.info, picks)
    with warnings.catch_warnings():
        # MNE may warn of the empirical estimate's low rank: the reason for the
        # regularization (module docstring)
        warnings.filterwarnings("ignore", message=".*rank.*", category=RuntimeWarning)
        return mne.cov.regularize(cov, info, eeg=reg, rank="full", verbose=False)
