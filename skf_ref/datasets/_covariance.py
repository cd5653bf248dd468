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

from typing import TYPE_CHECKING

from ..io._noise_cov import baseline_covariance

if TYPE_CHECKING:
    import mne

__all__ = ["baseline_noise_cov"]


def baseline_noise_cov(
    evoked: mne.Evoked, tmin: float | None = None, tmax: float = 0.0, *, reg: float = 0.1
) -> mne.Covariance:
    """The noise covariance of one trial, from an average's pre-stimulus samples.

    :func:`skf_ref.io.baseline_covariance` on the EEG channels, regularized by default.

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
    >>> import numpy as np
    >>> info = mne.create_info(["a", "b", "c"], 1000.0, "eeg")
    >>> rng = np.random.default_rng(0)
    >>> evoked = mne.EvokedArray(rng.standard_normal((3, 200)) * 1e-6, info, tmin=-0.1,
    ...                          nave=100, verbose=False)
    >>> cov = baseline_noise_cov(evoked, tmax=0.0, reg=0.0)
    >>> baseline = evoked.data[:, evoked.times <= 0]
    >>> bool(np.allclose(cov.data, 100 * baseline @ baseline.T / baseline.shape[1]))
    True
    """
    return baseline_covariance(evoked, tmin, tmax, reg=reg, meg=False, eeg=True)
