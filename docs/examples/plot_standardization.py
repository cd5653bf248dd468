"""
Standardizing a position as a whole, and a smoother standardized by its own variance
=====================================================================================

One dipole at a time, each of oblique orientation (not along any axis of the grid): a deep
thalamic source, then a superficial cortical one, at 30 dB. Each data set is reconstructed
by the SKF with each smoother and both standardizations (exponent 0.5), and by MNE's
sLORETA and eLORETA on the same head model, and each estimate's peak is compared with the
true position (docs/model.md §2, "Standardizing a position as a whole", and §3, "A smoother
standardized by its own variance").

- ``standardize="column"`` (the paper's) standardizes each of a position's three columns
  by its own weight: the estimate depends on the axes of the grid, and a dipole between
  them can move. ``standardize="position"`` standardizes each position by its 3 x 3 block,
  as sLORETA does in Pascual-Marqui's definition: it localizes a noise-free dipole of any
  orientation exactly at the first step.
- ``"rts-standardized"`` (the paper's smoother) runs the RTS gains of the unstandardized
  filter over the standardized sequence; ``"rts-state"`` standardizes the smoothed state
  with the filter's weights; ``"rts-smoothed-weights"`` divides the smoothed state by its
  own standard deviation.

The sample subject's realistic head is used when MNE's testing dataset is found, else the
spherical head; both with cortex + thalamus.
"""

import numpy as np
import pandas as pd

from skf_ref import priors_from_snr, reconstruct
from skf_ref.study import (
    apply_minimum_norm,
    find_testing_data,
    make_head,
    p20n20_scenario,
    peak_localization_error,
    plot_comparison,
    simulate,
)
from skf_ref.study._baselines import inverse_operator  # MNE's, as the study makes it

conductor = "bem" if find_testing_data() is not None else "sphere"
head = make_head(conductor, "anatomical")
print(head.description)

# Both pulses at the same time (peak 1.5 ms), each dipole oblique to the grid's axes; the
# superficial one is made tangential by the scenario.
scenario = p20n20_scenario(
    deep_orientation=(1.0, -1.0, 1.0),
    superficial_orientation=(1.0, 1.0, 1.0),
    superficial_onset_ms=0.0,
)
data = {
    name: simulate(head, scenario, snr_db=30.0, seed=0, sources=(name,))
    for name in ("deep", "superficial")
}
peak = int(np.argmin(np.abs(scenario.times - 1.5e-3)))

# %%
# Reconstructions
# ---------------
# The priors come from the paper's SNRs at 30 dB (PM-SNR 0 dB, EP-SNR 20 dB), the same for
# every setting. MNE's inverses are free orientation without depth weighting, lambda2 = 1/9.

SMOOTHERS = (None, "rts-standardized", "rts-state", "rts-smoothed-weights")
estimates, errors = {}, {}
for source, sim in data.items():
    theta0, q = priors_from_snr(head.leadfield, sim.sigma, 0.0, 20.0, len(scenario.times))
    true_position = sim.truth.positions[sim.truth.names.index(source)]
    for standardize in ("column", "position"):
        for smoother in SMOOTHERS:
            rec = reconstruct(
                head.leadfield,
                sim.Y,
                noise_std=sim.sigma,
                theta0=theta0,
                q=q,
                exponent=0.5,
                smoother=smoother,
                standardize=standardize,
                n_orient=3,
            )
            amplitude = rec.amplitude(3)
            label = smoother or "no smoother"
            estimates[label, f"{source}, {standardize}"] = amplitude
            errors[f"SKF {standardize}, {label}", source] = peak_localization_error(
                amplitude, head.positions, true_position, peak
            )
    inverse = inverse_operator(head, sim)
    for method in ("sLORETA", "eLORETA"):
        amplitude = apply_minimum_norm(head, sim, inverse, method)
        estimates[method, f"{source}, MNE"] = amplitude
        errors[method, source] = peak_localization_error(
            amplitude, head.positions, true_position, peak
        )

# %%
# Peak localization error
# -----------------------
# Distance in mm from each true dipole to the position of largest amplitude at its peak. A
# position grid cannot do better than the distance to its nearest position.

rows = list(dict.fromkeys(setting for setting, _ in errors))  # in the order computed
table = pd.Series(errors).unstack().reindex(rows)
table = table.rename(columns=lambda name: f"{name} alone (mm)")
print(table.round(1).to_string())

# %%
# The figure
# ----------
# Coronal maximum-intensity projections at the peak, in dB re. each panel's maximum (a 6 dB
# range). Rows: the standardization (and MNE's methods); columns: the smoother. The circle
# is the true dipole, the faint one the source left out; each panel gives the deep
# region's level, so a deep "detection" from the superficial dipole alone shows as a false
# one.

for source, other in (("deep", "superficial"), ("superficial", "deep")):
    shown = {key: value for key, value in estimates.items() if key[1].startswith(source)}
    fig = plot_comparison(
        shown,
        head,
        data[source].truth,
        absent={row: (other,) for _, row in shown},
        time_ms=1.5,
        title=f"The {source} dipole alone, 30 dB, exponent 0.5: coronal MIP at 1.5 ms",
    )
