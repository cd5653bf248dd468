"""Time courses as users read them: peak latency and correlation of each dynamics and smoother.

``python -m validation.timecourses [--out DIR] [--seeds N] [--n-positions N]``

The filter is causal: a prior that remembers long makes it lag, and a smoother may take the
lag back. This measures, for the paper's random walk (EP-SNR 0 dB, ``q = theta0 / K``) and the
stationary AR(1) prior at fixed time constants and at the one the marginal likelihood chooses,
each with every smoother, on two timings of the P20/N20 pair (the sphere head, biosemi64, a
volume grid; data from the exact dipoles, white noise at 20 dB peak SNR):

- ``pulse``: the paper's, 3 ms Hann pulses peaking at 1.5 ms (deep) and 2.5 ms (cortical),
  10 kHz, 41 samples;
- ``erp``: an evoked response, 80 ms Hann bumps peaking 100 ms (deep) and 130 ms (cortical)
  after a stimulus, -50 ... 350 ms at 500 Hz (201 samples).

Every run uses exponent 0.5 and ``standardize="position"`` (the package's default). Each
source is simulated alone (the other's noise kept), so that what is measured is the dynamics'
lag, not the other source leaking into its region: the *peak latency error*, the time of its
region's largest amplitude (positions within 15 mm of the truth) minus the true peak time, in
ms; and the *time-course correlation*, the Pearson r of the region's largest amplitude over
time with the true waveform's magnitude.
Medians and interquartile ranges over ``--seeds`` noise draws (seeds 0, 1, ...). Results go to
``DIR/timecourses.md`` and ``DIR/timecourses.csv`` (default ``validation/timecourses``).
"""

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_info

import skf_ref
from skf_ref.study._head import make_head_model
from skf_ref.study._metrics import time_course_correlation
from skf_ref.study._regions import region_time_course
from skf_ref.study._scenario import p20n20_scenario, simulate

SNR_DB = 20.0
TIME_CONSTANTS_MS = (5.0, 10.0, 20.0)
SMOOTHERS = (None, "rts-standardized", "rts-state", "rts-smoothed-weights")
#: Where the ERP's stimulus sits in the simulated epoch (its times start at 0).
STIMULUS_MS = 50.0


def designs():
    """The two timings, by name: (scenario, the stimulus' time in the epoch in ms)."""
    pulse = p20n20_scenario()
    erp = p20n20_scenario(
        pulse_ms=80.0,
        deep_onset_ms=STIMULUS_MS + 100.0 - 40.0,
        superficial_onset_ms=STIMULUS_MS + 130.0 - 40.0,
        sfreq=500.0,
        duration_ms=400.0,
    )
    return {"pulse": pulse, "erp": erp}


def dynamics(L, Y, sigma, sfreq):
    """(name, theta0, q, transition, chosen time constant or NaN) of each prior."""
    T = Y.shape[1]
    theta0, q = skf_ref.priors_from_snr(L, sigma, pm_snr_db=0.0, ep_snr_db=0.0, n_steps=T)
    found = [("random walk, EP 0 dB", theta0, q, 1.0, np.nan)]
    for tau in TIME_CONSTANTS_MS:
        found.append((f"AR(1), {tau:g} ms", *skf_ref.ar1_priors(L, sigma, 0.0, tau, sfreq), tau))
    tuned = skf_ref.tune(L, Y, noise_std=sigma, time_constant_ms="auto", sfreq=sfreq)
    tau = tuned.time_constant_ms
    chosen = skf_ref.ar1_priors(L, sigma, tuned.pm_snr_db, tau, sfreq)
    found.append(("AR(1), chosen by the likelihood", *chosen, tau))
    return found


def measure(head, design, scenario, seed):
    """One noise draw of one design: a row per source (alone), prior and smoother."""
    rows = []
    for k, source in enumerate(("deep", "superficial")):
        sim = simulate(head, scenario, SNR_DB, seed, sources=(source,))
        L, Y, truth = head.leadfield, sim.Y, sim.truth
        times_ms = 1e3 * truth.times
        for name, theta0, q, transition, tau in dynamics(L, Y, sim.sigma, scenario.sfreq):
            for smoother in SMOOTHERS:
                rec = skf_ref.reconstruct(
                    L, Y, noise_std=sim.sigma, theta0=theta0, q=q, transition=transition,
                    smoother=smoother, standardize="position", n_orient=3,
                )  # fmt: skip
                amplitude = rec.amplitude(3)
                course = region_time_course(amplitude, head.positions, truth.positions[k])
                r = time_course_correlation(
                    amplitude, head.positions, truth.positions[k], truth.waveforms[k]
                )
                rows.append(
                    dict(
                        design=design, seed=seed, prior=name, time_constant_ms=tau,
                        smoother=smoother or "none", source=source,
                        latency_error_ms=times_ms[np.argmax(course)] - 1e3 * truth.peak_times[k],
                        correlation=r,
                    )
                )  # fmt: skip
    return rows


def _median_iqr(values):
    q1, median, q3 = np.nanpercentile(values, [25, 50, 75])
    return f"{median:+.1f} [{q1:+.1f}, {q3:+.1f}]", f"{median:.2f} [{q1:.2f}, {q3:.2f}]"


def table(results):
    """The markdown table: a row per design, prior and smoother; both sources side by side."""
    lines = [
        "| design | prior | smoother | deep alone: latency error, ms | r "
        "| cortical alone: latency error, ms | r |",
        "|---|---|---|---|---|---|---|",
    ]
    keys = ["design", "prior", "smoother"]
    for (design, prior, smoother), group in results.groupby(keys, sort=False):
        cells = []
        for source in ("deep", "superficial"):
            rows = group[group.source == source]
            cells += [
                _median_iqr(rows.latency_error_ms)[0],
                _median_iqr(rows.correlation)[1],
            ]
        lines.append(f"| {design} | {prior} | {smoother} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=Path("validation/timecourses"))
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--n-positions", type=int, default=500)
    args = parser.parse_args(argv)
    start, cpu, load = time.perf_counter(), time.process_time(), os.getloadavg()[0]
    head = make_head_model(args.n_positions)
    rows = [
        row
        for design, scenario in designs().items()
        for seed in range(args.seeds)
        for row in measure(head, design, scenario, seed)
    ]
    results = pd.DataFrame(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    results.to_csv(args.out / "timecourses.csv", index=False, float_format="%.6g")
    blas = ", ".join(f"{i['internal_api']} {i['num_threads']} threads" for i in threadpool_info())
    chosen = results[results.prior.str.contains("chosen")].groupby("design").time_constant_ms
    header = (
        f"skf_ref {skf_ref.__version__}; sphere head, biosemi64, {head.positions.shape[0]} "
        f"positions; {SNR_DB:g} dB white noise; seeds 0-{args.seeds - 1}; exponent 0.5, "
        f"standardize='position'. Median [IQR] over seeds. Time constants chosen by the "
        f"likelihood (median ms): "
        + ", ".join(f"{d} {v:.1f}" for d, v in chosen.median().items())
        + f".\n\nRun: {time.perf_counter() - start:.0f} s wall, "
        f"{time.process_time() - cpu:.0f} s CPU, load {load:.1f} before and "
        f"{os.getloadavg()[0]:.1f} after; BLAS: {blas}.\n\n"
    )
    (args.out / "timecourses.md").write_text(header + table(results) + "\n", encoding="utf-8")
    print(header + table(results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
