"""
A long recording, streamed to disk
==================================

A spectral reconstruction holds only r x T numbers (r = channels, T = steps) until an
output is asked for, and every row of an output depends on one row of the lead field's
singular vectors only. So :func:`skf_ref.io.to_zarr`
writes an output to a zarr store block of rows by block, never holding it whole
(:doc:`/scale`). Here a train of twenty P20/N20 responses, 4000 steps where the demo has
41, is reconstructed, streamed to disk, read back with zarr, and compared with the same
output computed in memory.
"""

import tempfile
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import zarr

import skf_ref
from skf_ref.io import to_zarr
from skf_ref.study import make_head_model, p20n20_scenario, region_mask, simulate

# %%
# The recording
# -------------
# The P20/N20 response of the spherical head (41 steps of 0.1 ms) every 20 ms, twenty
# times, with white noise at 20 dB throughout.

head = make_head_model(1000)
sim = simulate(head, p20n20_scenario(), snr_db=20, seed=0)
repetitions, period = 20, 200
one_period = np.zeros((head.n_channels, period))
one_period[:, : sim.Y_clean.shape[1]] = sim.Y_clean
Y_clean = np.tile(one_period, repetitions)
Y = Y_clean + sim.sigma * np.random.default_rng(1).standard_normal(Y_clean.shape)
print(f"{Y.shape[0]} channels x {Y.shape[1]} steps; the lead field {head.leadfield.shape}")

# %%
# The reconstruction holds r x T numbers
# --------------------------------------
# ``reconstruct`` prepares the spectral path (one SVD and the covariance recursion);
# nothing of size n_sources x n_times exists yet.

theta0, q = skf_ref.priors_from_snr(head.leadfield, sim.sigma, 0.0, 20.0, n_steps=Y.shape[1])
rec = skf_ref.reconstruct(head.leadfield, Y, noise_std=sim.sigma, theta0=theta0, q=q)
print(rec)
print("z computed:", rec.computed("z"))
size_mb = 8 * rec.n_sources * rec.n_times / 1e6
print(f"z would take {size_mb:.0f} MB in memory")

# %%
# Streamed to a zarr store
# ------------------------
# Blocks of 256 rows (8 MB each) are computed and written one after the other, the
# disk writing on a thread of its own meanwhile. The store appears under its name only when
# complete, and carries the reconstruction's settings as attributes.

folder = Path(tempfile.mkdtemp())
start = time.perf_counter()
store = to_zarr(rec, folder / "skf.zarr", arrays=("z",), chunks=256)
print(f"written in {time.perf_counter() - start:.1f} s:", store["z"].shape, store["z"].chunks)
print("z computed in memory meanwhile:", rec.computed("z"))
print("settings in the store:", {key: store.attrs[key] for key in ("path", "exponent")})

# %%
# Read back, and compared with the output in memory
# -------------------------------------------------
# Reading the store needs zarr only. The same output computed whole in memory equals it to
# rounding (its blocks are products of other shapes, which BLAS rounds differently).

z_disk = zarr.open_group(folder / "skf.zarr", mode="r")["z"]
z_memory = rec.z
difference = np.max(np.abs(z_disk[:] - z_memory)) / np.max(np.abs(z_memory))
print(f"largest difference from the in-memory z: {difference:.1e} of its largest value")

# %%
# A reader needs only the rows it uses: here the positions within 15 mm of each true
# source (their three orientations each). Left, the regions' maxima over the first three
# responses; right, averaged over all twenty, with the true waveforms dashed. The deep
# region also follows the superficial source, whose spread reaches it: the "echo" that
# the study measures against its controls (:doc:`/study`).

fig, axes = plt.subplots(1, 2, figsize=(9, 3.2), layout="constrained")
times_ms = np.arange(Y.shape[1]) / 10.0  # 10 kHz
for k, (name, colour) in enumerate((("deep", "tab:green"), ("superficial", "tab:red"))):
    positions = np.flatnonzero(region_mask(head.positions, sim.truth.positions[k]))
    rows = np.sort(np.concatenate([3 * positions + c for c in range(3)]))
    z_rows = z_disk.get_orthogonal_selection((rows, slice(None)))  # only these rows
    region = np.sqrt((z_rows.reshape(len(positions), 3, -1) ** 2).sum(axis=1)).max(axis=0)
    axes[0].plot(times_ms[: 3 * period], region[: 3 * period], color=colour, label=name)
    mean = region.reshape(repetitions, period)[:, : sim.times.size].mean(axis=0)
    axes[1].plot(sim.times * 1e3, mean / mean.max(), color=colour, label=f"{name} region")
    waveform = np.abs(sim.truth.waveforms[k])
    axes[1].plot(sim.times * 1e3, waveform / waveform.max(), "--", color=colour, lw=1)
axes[0].set(xlabel="time (ms)", ylabel="region maximum of z", title="The first three responses")
axes[1].set(xlabel="time in each response (ms)", ylabel="normalized", title="Mean of twenty")
axes[1].legend(fontsize="small")
