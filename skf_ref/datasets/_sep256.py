"""The 256-channel median-nerve SEP of ``spharapy`` (BSD-3), as an ``mne.EvokedArray``.

``spharapy.datasets.load_eeg_256_channel_study()`` (Graichen et al., PLoS ONE 2015, data set
S1): one subject, right median nerve at 3.7 Hz, 6000 stimuli, trials with artifacts removed
by hand and the rest averaged (how many is not published: ``nave`` is set to 6000, and it
does not change the whitening when the noise covariance comes from the average's own
baseline, :func:`skf_ref.datasets.baseline_noise_cov`); 2048 Hz, -50 ... 130 ms (369
samples, the first at -50 ms as spharapy's own examples plot them), high-pass 2 Hz, notch
50 Hz and harmonics; microvolts; reference not stated (the average over the channels is not
zero): an average-reference projector is added. Its global field power peaks at 13.5 ms
(P14), 19.3 ms (N20) and 29.6 ms.

**Positions.** An equidistant cap, mm, in the frame of spharapy's triangulation: x from the
back of the head to the front (the midline reaches down to the neck at -x and stops at the
forehead at +x), z up, and y to the left ear: the labels with an ``L`` (first or last
letter) lie at +y and those with an ``R`` at -y, and the frame is right-handed. They are
turned to MNE's head-frame axes (x right = -y, y front = x, z up) and to metres; without
fiducials the origin and the tilt are the cap's own. No MRI comes with the recording: a
sphere fitted to the cap (:func:`skf_ref.datasets.sphere_forward`) is the head model.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .._utils.extras import optional

if TYPE_CHECKING:
    import mne

__all__ = ["NAVE", "SFREQ", "TMIN", "load_sep256_evoked"]

#: Sampling frequency (Hz), first sample (s) and the stimuli averaged (an upper bound).
SFREQ, TMIN, NAVE = 2048.0, -0.05, 6000
_UV, _MM = 1e-6, 1e-3


def _mne_axes(positions_mm: np.ndarray) -> np.ndarray:
    """The cap's axes (x front, y left, z up), mm, to MNE's (x right, y front, z up), m."""
    x, y, z = np.asarray(positions_mm, dtype=float).T
    return np.column_stack([-y, x, z]) * _MM


def load_sep256_evoked(
    *, baseline: tuple[float | None, float | None] | None = (None, 0.0)
) -> mne.EvokedArray:
    """The 256-channel SEP as an ``mne.EvokedArray`` with its electrode positions.

    Parameters
    ----------
    baseline : tuple or None
        MNE's baseline correction (default: the mean over -50 ... 0 ms removed from each
        channel; the recording is high-passed at 2 Hz only, and its channels' offsets are as
        large as the noise). None: the data as spharapy gives them.

    Returns
    -------
    mne.EvokedArray
        Volts, 369 samples from -50 ms at 2048 Hz, ``nave`` 6000, an average-reference
        projector, positions in metres (module docstring).
    """
    mne = optional("mne", "mne", "load_sep256_evoked")
    datasets = optional("spharapy.datasets", "datasets", "load_sep256_evoked")
    study = datasets.load_eeg_256_channel_study()
    # spharapy 1.3 gives the labels as strings, 1.1 each in a list of one: ravel takes both
    labels = [str(label) for label in np.ravel(study["labellist"])]
    montage = mne.channels.make_dig_montage(
        dict(zip(labels, _mne_axes(study["vertlist"]), strict=True)), coord_frame="head"
    )
    info = mne.create_info(labels, SFREQ, "eeg")
    info.set_montage(montage)
    info["description"] = "spharapy 256-channel SEP: right median nerve, high-pass 2 Hz"
    evoked = mne.EvokedArray(
        np.asarray(study["eegdata"], dtype=float) * _UV,
        info,
        tmin=TMIN,
        nave=NAVE,
        comment="spharapy 256-channel SEP",
        verbose=False,
    )
    # MNE puts the first sample at a multiple of 1 / sfreq (-102 / 2048 s); spharapy's
    # times are -50 ms + n / 2048 Hz
    evoked.shift_time(TMIN, relative=False)
    if baseline is not None:
        evoked.apply_baseline(baseline, verbose=False)
    evoked.set_eeg_reference("average", projection=True, verbose=False)
    return evoked
