"""
Memory in milliseconds: the random walk and the stationary AR(1) prior
=======================================================================

The paper's evolution prior gives each step the variance ``q = kappa**2 theta0 / K``, ``K``
the number of samples: the longer the epoch, the slower the walk. The same evoked response
in an epoch of 300 samples or of 3000 (the same response followed by a longer stretch of
recording) gets a ten times slower walk in the longer one, and a different map where the
response is. The stationary AR(1) prior (:func:`skf_ref.ar1_priors`, :doc:`/model` §4) sets
the memory in milliseconds, ``rho = exp(-dt / tau)`` and ``q = (1 - rho**2) theta0``: nothing
in it depends on ``K``, and the filter is causal, so its estimate of the response is the same
whatever follows.

One evoked response on the sphere head: a deep (thalamic) bump peaking at 100 ms and a
cortical one at 130 ms, 80 ms each, sampled at 500 Hz, 20 dB peak SNR.
"""

import matplotlib.pyplot as plt
import numpy as np

import skf_ref
from skf_ref.study import make_head_model, p20n20_scenario, region_time_course, simulate

head = make_head_model(500)  # sphere head, biosemi64, a 480-position volume grid
L = head.leadfield
position = dict(standardize="position", n_orient=3)
sfreq, short, long = 500.0, 300, 3000
scenario = p20n20_scenario(
    pulse_ms=80.0, deep_onset_ms=60.0, superficial_onset_ms=90.0,
    sfreq=sfreq, duration_ms=(long - 1) / sfreq * 1e3,
)  # fmt: skip
sim = simulate(head, scenario, snr_db=20, seed=0)
Y, sigma, truth = sim.Y, sim.sigma, sim.truth
times_ms = 1e3 * truth.times[:short]
peak = int(np.argmin(np.abs(truth.times - truth.peak_times[0])))  # the deep peak, 100 ms

# %%
# Each prior on the epoch of 300 samples and on the epoch of 3000
# ---------------------------------------------------------------
# PM-SNR 0 dB for both; the walk at EP-SNR 0 dB (the package's default), the AR(1) at a time
# constant of 10 ms. The first 300 samples of the long epoch are the short epoch.

estimates = {}
for K in (short, long):
    walk = skf_ref.priors_from_snr(L, sigma, pm_snr_db=0, ep_snr_db=0, n_steps=K)
    theta0, q, rho = skf_ref.ar1_priors(L, sigma, 0, time_constant_ms=10, sfreq=sfreq)
    for name, priors in (("random walk", dict(zip(("theta0", "q"), walk, strict=True))),
                         ("AR(1), 10 ms", dict(theta0=theta0, q=q, transition=rho))):  # fmt: skip
        rec = skf_ref.reconstruct(L, Y[:, :K], noise_std=sigma, **priors, **position)
        estimates[name, K] = rec.amplitude(3)[:, :short]
    print(f"{K} samples: the walk's q / theta0 = {walk[1] / walk[0]:.1e}, "
          f"the AR(1)'s {q / theta0:.2f} (rho = {rho:.3f})")  # fmt: skip

for name in ("random walk", "AR(1), 10 ms"):
    a, b = estimates[name, short], estimates[name, long]
    change = np.max(np.abs(a - b)) / np.max(np.abs(a))
    found = [head.positions[np.argmax(e[:, peak])] for e in (a, b)]
    mm = [1e3 * np.linalg.norm(p - truth.positions[0]) for p in found]
    print(f"{name}: the estimate changes by {change:.0e} of its largest value; deep error at "
          f"100 ms {mm[0]:.0f} mm (300 samples), {mm[1]:.0f} mm (3000 samples)")  # fmt: skip

# %%
# The deep region's time course
# -----------------------------
# The largest amplitude within 15 mm of the thalamic source, over the response.

fig, axes = plt.subplots(1, 2, figsize=(9, 3.4), sharey=True, layout="constrained")
for ax, name in zip(axes, ("random walk", "AR(1), 10 ms"), strict=True):
    for K, style in ((short, "-"), (long, "--")):
        course = region_time_course(estimates[name, K], head.positions, truth.positions[0])
        ax.plot(times_ms, course / course.max(), style, label=f"epoch of {K} samples")
    wave = truth.waveforms[0, :short]
    ax.plot(times_ms, wave / wave.max(), "k:", label="truth")
    ax.set(title=name, xlabel="time (ms)", xlim=(0, 400))
axes[0].set_ylabel("deep region (normalized)")
axes[1].legend()
plt.show()

# %%
# The walk's estimate of the same response depends on how long the epoch around it is; the
# AR(1)'s does not, to rounding, since nothing in its ``A``, ``Q`` or ``P_0`` depends on the
# number of samples. (With a smoother, later samples do enter each estimate, by design.)
# :doc:`/choosing` gives the time courses' latency and correlation for each prior and
# smoother, over many noise draws.
