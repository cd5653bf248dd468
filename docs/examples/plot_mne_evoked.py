"""
The SKF on an MNE evoked response
=================================

One dipole, simulated with MNE-Python's own forward model, recovered by
:func:`skf_ref.apply_skf` as an MNE source estimate, beside MNE's sLORETA on the same
data; then the same SKF prepared once as an operator and applied to every epoch
(:func:`skf_ref.apply_skf_epochs`), with the one-call route's numbers. First in MNE's
spherical head, then in the realistic head of MNE's "sample" subject when MNE's testing
dataset is at hand.

:func:`~skf_ref.apply_skf` works like ``mne.minimum_norm.apply_inverse``: channels are matched
by name, the average reference is applied to data and lead field alike, both are whitened
with the noise covariance (divided by the evoked's ``nave``), and the priors are taken on
the whitened lead field, so PM-SNR and EP-SNR do not depend on units
(:doc:`/getting_started`).
"""

import os
from time import perf_counter

import matplotlib.pyplot as plt
import mne
import numpy as np

import skf_ref
from skf_ref.study import find_testing_data, make_realistic_head, plot_estimate
from skf_ref.study._scenario import SUPERFICIAL_MNI_MM  # the paper's cortical site

mne.set_log_level("warning")  # MNE's progress messages off

# %%
# A spherical head, made with MNE
# -------------------------------
# 64 electrodes (BioSemi), MNE's four-shell sphere fitted to them, and a volume source
# space: a 10 mm grid filling the brain, three dipole orientations at each of its 2117
# positions.

montage = mne.channels.make_standard_montage("biosemi64")
info = mne.create_info(montage.ch_names, 1000.0, "eeg").set_montage(montage)
sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
src = mne.setup_volume_source_space(sphere=sphere, pos=10.0, verbose=False)
forward = mne.make_forward_solution(info, None, src, sphere, meg=False, verbose=False)
print(forward)

# %%
# Thirty epochs of one dipole
# ---------------------------
# A radial dipole of 50 nA·m under the left parietal electrodes, a 30 ms half-sine pulse,
# and 5 µV of white noise on every channel of every epoch. The noise covariance comes from
# the 20 ms before the pulse, as it would in a recording.


def epochs_of_one_dipole(forward, info, where, orientation, moment, seed=0):
    """Thirty noisy epochs, 60 ms each, of one dipole of the forward's source space."""
    pulse = np.sin(np.pi * np.clip(np.arange(60) - 20, 0, 30) / 30)  # 0 to 30 ms
    field = forward["sol"]["data"][:, 3 * where : 3 * where + 3] @ orientation * moment
    noise = 5e-6 * np.random.default_rng(seed).standard_normal((30, len(info.ch_names), 60))
    epochs = mne.EpochsArray(
        field[:, None] * pulse + noise, info, tmin=-0.02, baseline=(None, 0), verbose=False
    )
    epochs.set_eeg_reference("average", projection=True, verbose=False)
    return epochs


where = int(np.argmin(np.linalg.norm(forward["source_rr"] - [-0.06, -0.03, 0.06], axis=1)))
dipole = forward["source_rr"][where]
radial = (dipole - sphere["r0"]) / np.linalg.norm(dipole - sphere["r0"])
epochs = epochs_of_one_dipole(forward, info, where, radial, 50e-9)
evoked = epochs.average()
noise_cov = mne.compute_covariance(epochs, tmax=0, verbose=False)
fig_evoked = evoked.plot_joint(times=[0.015], show=False)

# %%
# The SKF, and MNE's sLORETA
# --------------------------
# The SKF at the package's default setting (exponent 0.5, no smoother, PM-SNR 0 dB,
# EP-SNR 20 dB); sLORETA with MNE's usual regularization for evoked data, free orientation
# and no depth weighting, as the study runs it (:mod:`skf_ref.study`). Both
# whiten the evoked, an average of 30 epochs, with the noise covariance of one trial
# divided by its ``nave`` (30), as the log says.


def peak_error_mm(stc, src, dipole):
    """Distance from the dipole to the estimate's maximum, and the time of the maximum."""
    vertex, time = stc.get_peak()
    return 1e3 * np.linalg.norm(src[0]["rr"][vertex] - dipole), time


stc = skf_ref.apply_skf(evoked, forward, noise_cov)
print(stc)
inverse = mne.minimum_norm.make_inverse_operator(
    evoked.info, forward, noise_cov, loose=1.0, depth=None, verbose=False
)
stc_sloreta = mne.minimum_norm.apply_inverse(evoked, inverse, 1 / 9, "sLORETA", verbose=False)
for name, estimate in (("SKF", stc), ("sLORETA", stc_sloreta)):
    error, time = peak_error_mm(estimate, src, dipole)
    print(f"{name:8s} maximum at {1e3 * time:.0f} ms, {error:.0f} mm from the dipole")

# %%
# The maximum lies one grid step (10 mm) from the dipole. The SKF's estimate keeps its
# maximum on the dipole's neighbourhood for the whole pulse: the five strongest positions
# over time, and the maximum-intensity projections at the time of the global maximum,
# every position a dot coloured in dB re. that maximum.

positions = src[0]["rr"][stc.vertices[0]]
fig_skf = plot_estimate(stc.data, stc.times, positions, title="SKF, sphere")

# %%
# How far off the maximum lies depends on where the dipole is and how it points: free
# orientation standardizes each of a position's three columns on its own
# (:doc:`/model` §1), which is not rotation invariant, and at mid depths it misplaces a
# dipole by a grid step or two even without noise (:func:`skf_ref.apply_skf` gives the
# numbers measured over a column of dipoles). The SKF's source estimate is an MNE object
# like any other:

print(type(stc).__name__, stc.data.shape, f"{stc.tmin * 1e3:.0f} to {stc.times[-1] * 1e3:.0f} ms")

# %%
# An operator prepared once, applied to every epoch
# -------------------------------------------------
# ``apply_skf(evoked, forward, noise_cov)`` is the one-call route: it prepares the SKF from
# the evoked's info (channels, reference, whitening, the SVD of the whitened lead field)
# and applies it. :func:`skf_ref.make_skf_operator` does that preparation once, as MNE's
# ``make_inverse_operator`` does, for :func:`skf_ref.apply_skf`,
# :func:`skf_ref.apply_skf_epochs` (each epoch, as ``apply_inverse_epochs``) and
# :func:`skf_ref.apply_skf_raw` (a continuous recording) (:doc:`/mne`). The numbers are the
# one-call route's: here on the evoked, and on each of the first five epochs, made an evoked
# of its own (``epochs[k].average()``) for the one-call route.

operator = skf_ref.make_skf_operator(epochs.info, forward, noise_cov)
print(operator)
print("evoked, same numbers:", np.array_equal(skf_ref.apply_skf(evoked, operator).data, stc.data))

start = perf_counter()
per_epoch = skf_ref.apply_skf_epochs(epochs, operator)
prepared = perf_counter() - start
start = perf_counter()
one_call = [
    skf_ref.apply_skf(epochs[k].average(), forward, noise_cov, verbose=False) for k in range(5)
]
each = (perf_counter() - start) / len(one_call)
same = all(np.array_equal(a.data, b.data) for a, b in zip(per_epoch[:5], one_call, strict=True))
print("first five epochs, same numbers as the one-call route:", same)
print(
    f"seconds per epoch: {prepared / len(per_epoch):.3f} through the operator, "
    f"{each:.3f} one call each (on this build's machine)"
)

# %%
# Each epoch's estimate at the dipole's position, and the evoked's. A single epoch's noise
# is not averaged down: sqrt(30), about 5.5 times the evoked's, so single trials scatter
# widely. The amplitude is the norm of a position's three components, never negative, so
# noise alone lifts a single trial above the evoked before the pulse.

fig_epochs, ax = plt.subplots(figsize=(6, 3), layout="constrained")
milliseconds = 1e3 * stc.times
for estimate in per_epoch:
    ax.plot(milliseconds, estimate.data[where], color="0.75", linewidth=0.7)
ax.plot(milliseconds, stc.data[where], color="k", label="evoked (30 epochs averaged)")
ax.plot([], [], color="0.75", label="each epoch")
ax.set(xlabel="time (ms)", ylabel="SKF amplitude", title="At the dipole's position")
ax.legend(loc="upper left", fontsize="small")

# %%
# The realistic head
# ------------------
# MNE's "sample" subject: a three-layer boundary-element model and a 10 mm grid filling
# its inner skull (:func:`skf_ref.study.make_realistic_head`; its forward model is
# cached on disk after the first run). It needs MNE's testing dataset, which is never
# downloaded: MNE's own lookup finds it, or the environment variable
# ``SKF_REF_TESTING_DATA`` names its folder. The dipole now sits where the study puts the
# N20's cortical source, normal to the inner skull.

testing_data = find_testing_data(os.environ.get("SKF_REF_TESTING_DATA"))
if testing_data is None:
    print(
        "MNE's testing dataset was not found (MNE's lookup, without downloading, found "
        "nothing and SKF_REF_TESTING_DATA is not set): the realistic head is skipped"
    )
else:
    head = make_realistic_head(testing_data, "volume", spacing_mm=10.0)
    print(head.description)
    head_info = mne.create_info(head.info.ch_names, 1000.0, "eeg")
    target, _ = head.anatomy.place(np.array(SUPERFICIAL_MNI_MM) * 1e-3)
    where = int(np.argmin(np.linalg.norm(head.fwd["source_rr"] - target, axis=1)))
    dipole = head.fwd["source_rr"][where]
    normal = head.anatomy.radial(dipole)
    epochs = epochs_of_one_dipole(head.fwd, head_info, where, normal, 50e-9)
    noise_cov = mne.compute_covariance(epochs, tmax=0, verbose=False)
    stc_head = skf_ref.apply_skf(epochs.average(), head.fwd, noise_cov)
    error, time = peak_error_mm(stc_head, head.fwd["src"], dipole)
    print(f"SKF      maximum at {1e3 * time:.0f} ms, {error:.0f} mm from the dipole")
    positions = head.fwd["src"][0]["rr"][stc_head.vertices[0]]
    fig_head = plot_estimate(stc_head.data, stc_head.times, positions, title="SKF, sample")
