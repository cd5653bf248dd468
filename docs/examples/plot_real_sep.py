"""
Real somatosensory evoked potentials
====================================

Median-nerve somatosensory evoked potentials (SEPs) recorded from real subjects, the
paradigm of the paper's simulated study, through the SKF and MNE-Python's inverse methods.
It is written as a recipe for your own recording: an evoked with its electrode positions
(from MNE, or a FieldTrip average), a forward model (a lead field of your own head model,
or a sphere fitted to the electrodes), a noise covariance from the pre-stimulus samples,
then the SKF and MNE's methods, and where each puts the N20.

Two recordings: a 256-channel average of about 6000 stimuli that ships with the package
``spharapy`` (from the source tree, ``python -m pip install ".[datasets]"``), with a sphere
fitted to the cap; and subject A0206 of the feCNN repository with its own finite-element (FEM)
lead field, when its files are found (:func:`skf_ref.datasets.data_path`). The report
``validation/report/real/REAL.md`` runs every method at several priors against criteria
written before the numbers (:doc:`/real_data`); this page shows the recipe.
"""

import warnings

import matplotlib.pyplot as plt
import mne
import numpy as np

import skf_ref
from skf_ref import datasets

mne.set_log_level("warning")

# %%
# 1. An evoked with its electrodes
# --------------------------------
# Right median nerve, 2048 Hz, -50 ... 130 ms, electrode positions in metres in MNE's
# head-frame axes, an average-reference projector, the baseline removed. Yours would come
# from ``mne.read_evokeds("sub-01-ave.fif")[0]``, or from a FieldTrip timelock average with
# ``mne.read_evoked_fieldtrip(path, info, data_name=...)`` (give it an info with your
# montage; set its times and ``nave``, as :func:`skf_ref.datasets.load_fecnn_evoked` does).
# ``nave`` matters: MNE's inverses divide the noise covariance by it.

evoked = datasets.load_sep256_evoked()
print(evoked)
fig_evoked = evoked.plot_joint(times=[0.0135, 0.0193, 0.0296], show=False)

# %%
# The global field power peaks at 13.5 ms (P14, subcortical), 19.3 ms (N20, the cortex of
# the left hand area) and 29.6 ms. The cap reaches down over the neck, whose electrodes
# carry the largest deflections at 13.5 ms.

N20 = 0.0193

# %%
# 2. A forward model
# ------------------
# No MRI comes with this recording: a three-shell sphere fitted to the electrodes and a
# 10 mm volume grid inside it (:func:`skf_ref.datasets.sphere_forward`). With a head model
# of your own computed by another program (duneuro, Zeffiro, SimNIBS, OpenMEEG), make the
# forward from its lead field, positions and orientations with
# :func:`skf_ref.datasets.forward_from_leadfield` (section 6 does, for A0206).

forward, sphere = datasets.sphere_forward(evoked.info, spacing_mm=10.0)
print(forward)

# %%
# 3. A noise covariance from the baseline
# ---------------------------------------
# Only the average is shared, not the trials, so ``mne.compute_covariance(epochs)`` has
# nothing to read. The pre-stimulus samples of an average are noise of the average, whose
# covariance is the trials' divided by ``nave``;
# :func:`skf_ref.datasets.baseline_noise_cov` returns ``nave`` times it (MNE's convention),
# regularized as MNE regularizes EEG: 103 samples cannot estimate 256 channels' covariance.

noise_cov = datasets.baseline_noise_cov(evoked, tmax=0.0)
print(noise_cov)

# %%
# 4. The SKF and MNE's methods
# ----------------------------
# The SKF at the package's default (EP-SNR 0 dB) and at the paper's setting with the paper's
# priors (``**skf_ref.PAPER_SETTING``, EP-SNR 20 dB; the forward has fixed orientations, so
# the two standardizations are one), and
# MNE's sLORETA and dSPM at lambda2 = 1/9, without depth weighting (MNE refuses it on a
# fixed-orientation forward that was never free, as section 6's). ``apply_skf`` of this
# The SKF gets, as MxNE and LCMV do, the average's own covariance and an evoked whose
# ``nave`` is 1: the same whitening as the trials' covariance with ``nave``, which
# ``apply_skf`` divides by as ``apply_inverse`` does.


def of_average(evoked, noise_cov):
    """The evoked with nave 1 and the covariance of the average: the same whitening."""
    average = evoked.copy()
    average.nave = 1
    covariance = noise_cov.copy()
    covariance["data"] = noise_cov["data"] / evoked.nave
    return average, covariance


def estimates(evoked, forward, noise_cov):
    """The SKF at two settings, sLORETA and dSPM: MNE source estimates."""
    average, covariance = of_average(evoked, noise_cov)
    stcs = {
        "SKF, recommended": skf_ref.apply_skf(average, forward, covariance, verbose=False),
        "SKF, paper's": skf_ref.apply_skf(
            average, forward, covariance, **skf_ref.PAPER_SETTING, ep_snr_db=20.0, verbose=False
        ),
    }
    fixed = mne.forward.is_fixed_orient(forward)
    inverse = mne.minimum_norm.make_inverse_operator(
        evoked.info, forward, noise_cov, loose=0.0 if fixed else 1.0, depth=None
    )
    for method in ("sLORETA", "dSPM"):
        stcs[method] = mne.minimum_norm.apply_inverse(evoked, inverse, 1 / 9, method)
    return stcs


stcs = estimates(evoked, forward, noise_cov)

# %%
# 5. Where each puts the N20
# --------------------------
# The position of each estimate's largest amplitude at the N20, its hemisphere, and its
# distance from the centre of the sphere fitted to the electrodes (deep: under 40 mm).


def maxima(stcs, forward, time, centre):
    """Each estimate's maximum at ``time``: position (mm), side, distance from the centre."""
    src = forward["src"][0]
    for name, stc in stcs.items():
        sample = int(np.argmin(np.abs(stc.times - time)))
        k = int(np.argmax(np.abs(stc.data[:, sample])))
        position = src["rr"][stc.vertices[0][k]]
        side = "left" if position[0] < centre[0] else "right"
        depth = np.linalg.norm(position - centre)
        print(
            f"{name:17s} {np.round(position * 1e3)} mm, {side:5s}, "
            f"{depth * 1e3:3.0f} mm from the centre"
        )


def projections(stcs, forward, time, title):
    """Each estimate at ``time``, seen from behind and from above (brightest on top)."""
    positions = forward["src"][0]["rr"] * 1e3
    fig, axes = plt.subplots(2, len(stcs), figsize=(3 * len(stcs), 5.6), layout="constrained")
    for column, (name, stc) in enumerate(stcs.items()):
        sample = int(np.argmin(np.abs(stc.times - time)))
        value = np.abs(stc.data[:, sample]) / np.abs(stc.data[:, sample]).max()
        where = positions[stc.vertices[0]]
        order = np.argsort(value)
        for row, (i, j, view) in enumerate(((0, 2, "from behind"), (0, 1, "from above"))):
            ax = axes[row, column]
            ax.scatter(where[order, i], where[order, j], c=value[order], s=8, cmap="hot_r")
            ax.set(title=f"{name}, {view}", aspect="equal", xticks=[], yticks=[])
            ax.set_xlabel("left — right", fontsize=8)
    fig.suptitle(title)
    return fig


maxima(stcs, forward, N20, sphere["r0"])
fig_sphere = projections(stcs, forward, N20, "256 channels, sphere: the N20 (19.3 ms)")

# %%
# On this sphere no method puts the N20 under the left central scalp. The SKF at the default
# (each position standardized as a whole, EP-SNR 0 dB) puts it in the left hemisphere, high
# and posterior, 45 mm from the centre; at the paper's setting it lies in the right
# hemisphere, low and frontal; sLORETA's lies low at the back of the grid, under the neck
# electrodes that still carry the largest amplitudes at 19.3 ms; dSPM's lies 21 mm from the
# centre, in the deep region. The sphere fills the space below the brain with sources, and
# every method shares its misfit. The report has every method, priors chosen by the data,
# and the P14 and P16 latencies.
#
# 6. Your own head model: subject A0206 and its FEM lead field
# -------------------------------------------------------------
# duneuro's FEM lead field of A0206 (5046 sources, one orientation each, 73 electrodes),
# made an ``mne.Forward`` by :func:`skf_ref.datasets.forward_from_leadfield` in the lead
# field's own frame (:func:`skf_ref.datasets.load_fecnn_forward` does it; with yours:
# ``datasets.forward_from_leadfield(evoked.info, L, positions, orientations)``). The files
# are found in a folder (``SKF_REF_DATA``, or ``shared/real-data`` beside the source
# checkout), or downloaded once with ``skf_ref.datasets.data_path(download=True)``.

try:
    folder = datasets.data_path()
except FileNotFoundError as err:
    print(f"A0206 is skipped: {err}")
else:
    evoked = datasets.load_fecnn_evoked("A0206", folder)
    forward = datasets.load_fecnn_forward(folder)
    noise_cov = datasets.baseline_noise_cov(evoked, tmax=-0.020)  # the preprocessing's
    print(evoked)
    print(forward)
    stcs = estimates(evoked, forward, noise_cov)
    with warnings.catch_warnings():  # the FEM's frame has its origin far from the head
        warnings.simplefilter("ignore", RuntimeWarning)
        head_centre = mne.bem.fit_sphere_to_headshape(
            evoked.info, dig_kinds=("eeg",), units="m", verbose=False
        )[1]
    maxima(stcs, forward, 0.0258, head_centre)
    fig_fem = projections(stcs, forward, 0.0258, "A0206, its FEM: the N20 (25.8 ms)")

# %%
# With its own head model the SKF at both settings and sLORETA put the N20 in the left
# hemisphere, 61-71 mm from the head's centre, under C3 and CP3 (the report measures it: 6
# mm from the point 25 mm under the scalp there for sLORETA, 13-14 mm for the SKF); dSPM's
# maximum lies 17 mm from the centre, deep. On these recordings the SKF does no better than
# MNE's methods (the report's verdict, :doc:`/real_data`).
