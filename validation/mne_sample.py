"""Validation on the sample subject's real sensors: MEG and EEG together, as MNE handles them.

``python -m validation.mne_sample --mne-testing-data DIR [--out DIR] [--dipoles N]``

``DIR`` is the folder ``mne.datasets.testing.data_path()`` returns (nothing is
downloaded). From it: the 306 MEG sensors and 60 EEG electrodes of
``SSS/sample_audvis_trunc_raw_sss.fif`` (with its average-reference projector), the noise
covariance ``MEG/sample/sample_audvis_trunc-cov.fif`` (it marks one MEG and one EEG
channel bad), the sample subject's three-layer BEM and head-MRI transform, and a 15 mm
volume grid inside the inner skull. Simulated evokeds, one dipole each (random position
and orientation, seeded) with noise drawn from that covariance, test:

1. **Whitening of mixed units.** Noise alone, whitened by the operator, has covariance
   ``I``: the mean whitened variance per channel type is 1 (to sampling error).
2. **The reference on EEG only.** The whitener's EEG columns sum to zero (the average
   reference), its MEG columns do not; EEG data referenced as MNE does by default
   (``projection=False``), saved to a FIF file and read back (float32), give the estimate
   of the projector route to 1e-6.
3. **Channels left out** are listed: the covariance's bad channels.
4. **Localization**, MEG + EEG against each alone and against MNE's sLORETA on the same
   inputs: the distance from the simulated dipole to the estimate's peak at the pulse's
   maximum, median (IQR) over the dipoles.

Results go to ``OUT/mne_sample.md`` and ``OUT/mne_sample.csv``.
"""

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from skf_ref._utils.atomic_files import atomic_path

RAW = "SSS/sample_audvis_trunc_raw_sss.fif"
COV = "MEG/sample/sample_audvis_trunc-cov.fif"
TRANS = "MEG/sample/sample_audvis_trunc-trans.fif"
BEM = "subjects/sample/bem/sample-1280-1280-1280-bem.fif"
#: The MEG data are Maxwell filtered (SSS): their rank is the info's, not the number of
#: channels, and the covariance's smallest eigenvalues are rounding (MNE's advice).
RANK = "info"
#: Whitened signal over whitened noise at the pulse's peak, root mean square over the
#: whitened channels: 2 is 6 dB, a clear but noisy evoked.
PEAK_SNR = 2.0
#: Routes that should give the same estimate differ by float32 storage of the data.
REFERENCE_RTOL = 1e-6
CHANNEL_SETS = {"MEG+EEG": dict(meg=True, eeg=True), "EEG": {}, "MEG": dict(meg=True, eeg=False)}


def load(folder):
    """The sample subject's info, noise covariance and MEG + EEG forward (15 mm grid)."""
    import mne

    folder = Path(folder)
    info = mne.io.read_info(folder / RAW, verbose=False)
    info = mne.pick_info(info, mne.pick_types(info, meg=True, eeg=True, exclude=[]))
    cov = mne.read_cov(folder / COV, verbose=False)
    bem = mne.make_bem_solution(folder / BEM, verbose=False)
    src = mne.setup_volume_source_space(
        "sample", pos=15.0, bem=bem, subjects_dir=folder / "subjects", verbose=False
    )
    forward = mne.make_forward_solution(info, folder / TRANS, src, bem, verbose=False)
    return info, cov, forward


def _noise(cov, info, n_times, rng):
    """Samples (n_channels, n_times) of N(0, C) on the info's channels (zero where C has none)."""
    names = [name for name in info.ch_names if name in cov["names"]]
    index = [cov["names"].index(name) for name in names]
    values, vectors = np.linalg.eigh(cov.data[np.ix_(index, index)])
    root = vectors * np.sqrt(np.clip(values, 0, None))
    noise = np.zeros((len(info.ch_names), n_times))
    noise[[info.ch_names.index(n) for n in names]] = root @ rng.standard_normal(
        (len(names), n_times)
    )
    return noise


def simulate(info, cov, forward, whiten, seed, n_times=60):
    """An evoked of one dipole and its true position: at the pulse's peak the whitened
    signal's root mean square is :data:`PEAK_SNR` times the whitened noise's (1)."""
    import mne

    rng = np.random.default_rng(seed)
    sfreq = info["sfreq"]
    times = np.arange(n_times) / sfreq - 20 / sfreq
    pulse = np.where(times > 0, np.sin(np.pi * np.clip(times * sfreq / 30, 0, 1)), 0.0)
    position = int(rng.integers(forward["nsource"]))
    orientation = rng.standard_normal(3)
    orientation /= np.linalg.norm(orientation)
    forward_xyz = mne.convert_forward_solution(forward, force_fixed=False, verbose=False)
    gain = forward_xyz["sol"]["data"][:, 3 * position : 3 * position + 3] @ orientation
    names = forward["sol"]["row_names"]
    field = np.array([gain[names.index(n)] if n in names else 0.0 for n in info.ch_names])
    noise = _noise(cov, info, n_times, rng)
    scale = PEAK_SNR / np.sqrt(np.mean(whiten(field[:, None]) ** 2))
    evoked = mne.EvokedArray(
        np.outer(field * scale, pulse) + noise, info, tmin=times[0], nave=1, verbose=False
    )
    rr = forward["source_rr"][position]
    return evoked, rr, int(np.argmax(pulse))


def _peak_error_mm(stc, forward, rr, peak):
    best = np.argmax(np.abs(stc.data[:, peak]))  # positions in the forward's order
    return 1e3 * np.linalg.norm(forward["source_rr"][best] - rr)


def _sloreta(info, forward, cov, types):
    """MNE's sLORETA on the channels of ``types``, as a function of an evoked."""
    import mne
    from mne.minimum_norm import apply_inverse, make_inverse_operator

    picks = mne.pick_types(info, meg=types.get("meg", False), eeg=types.get("eeg", True))
    names = [info.ch_names[i] for i in picks]
    inverse = make_inverse_operator(
        mne.pick_info(info, picks), forward, cov, loose=1.0, depth=None, rank=RANK,
        verbose=False,
    )  # fmt: skip
    return lambda evoked: apply_inverse(
        evoked.copy().pick(names), inverse, 1 / 9, "sLORETA", verbose=False
    )


def check_whitening(operator, cov, info, rng):
    """Mean whitened variance of noise alone, per channel type of the rows' channels."""
    noise = _noise(cov, info, 20000, rng)
    data = operator.select(info, noise, "noise")
    whitened = operator.whitener @ data
    variances = np.mean(whitened**2, axis=1)
    eeg = np.array([name in operator.eeg_names for name in operator.ch_names])
    # rows of MNE's whitener belong to one channel type each
    rows_eeg = np.abs(operator.whitener[:, ~eeg]).sum(axis=1) == 0
    return {
        "whitened variance, EEG rows": float(np.mean(variances[rows_eeg])),
        "whitened variance, MEG rows": float(np.mean(variances[~rows_eeg])),
        "EEG column sums / largest entry (the average reference)": float(
            np.abs(operator.whitener[:, eeg].sum(axis=1)).max()
            / np.abs(operator.whitener[:, eeg]).max()
        ),
        "MEG column sums / largest entry (not projected)": float(
            np.abs(operator.whitener[:, ~eeg].sum(axis=1)).max()
            / np.abs(operator.whitener[:, ~eeg]).max()
        ),
    }


def check_reference(evoked, forward, cov):
    """The projector route against MNE's default reference, saved and read back."""
    import mne

    import skf_ref

    operator = skf_ref.make_skf_operator(evoked.info, forward, cov, rank=RANK, verbose=False)
    by_projector = skf_ref.apply_skf(evoked, operator, verbose=False).data
    default = evoked.copy().del_proj().set_eeg_reference("average", verbose=False)
    with tempfile.TemporaryDirectory() as folder:
        mne.write_evokeds(Path(folder) / "d-ave.fif", default, verbose=False)
        read = mne.read_evokeds(Path(folder) / "d-ave.fif", proj=False, verbose=False)[0]
    stc = skf_ref.apply_skf(read, operator, verbose=False).data
    return float(np.max(np.abs(stc - by_projector)) / np.max(np.abs(by_projector)))


def run(folder, n_dipoles=20):
    """Every check; returns the rows of the localization table and the other numbers."""
    import skf_ref

    info, cov, forward = load(folder)
    operator = skf_ref.make_skf_operator(info, forward, cov, meg=True, rank=RANK, verbose=False)
    numbers = check_whitening(operator, cov, info, np.random.default_rng(100))
    numbers["channels used"] = len(operator.ch_names)
    numbers["rank"] = operator.rank
    numbers["left out"] = operator.dropped

    def whiten(data):
        return operator.whitener @ operator.select(info, data, "simulation")

    evoked, rr, peak = simulate(info, cov, forward, whiten, seed=0)
    numbers["reference routes, largest relative difference"] = check_reference(
        evoked, forward, cov
    )
    methods = {}
    for name, types in CHANNEL_SETS.items():
        skf = skf_ref.make_skf_operator(info, forward, cov, rank=RANK, verbose=False, **types)
        methods[name, "SKF"] = lambda evoked, skf=skf: skf_ref.apply_skf(evoked, skf)
        methods[name, "sLORETA"] = _sloreta(info, forward, cov, types)
    rows = []
    for seed in range(n_dipoles):
        evoked, rr, peak = simulate(info, cov, forward, whiten, seed)
        for (name, method), apply in methods.items():
            error = _peak_error_mm(apply(evoked), forward, rr, peak)
            rows.append(dict(seed=seed, channels=name, method=method, error_mm=error))
    return pd.DataFrame(rows), numbers


def report(table, numbers, n_dipoles):
    """The markdown file."""
    lines = [
        "Sample subject, real sensors (306 MEG, 60 EEG), three-layer BEM, 15 mm volume grid;",
        f"{n_dipoles} simulated dipoles (seeds 0..{n_dipoles - 1}), noise from the sample "
        f"noise covariance, whitened signal {PEAK_SNR:g} times the whitened noise at the "
        f"peak (RMS); covariance rank {RANK!r} (SSS data). SKF: exponent 0.5, no smoothing; "
        "sLORETA: MNE's, loose=1, no depth weighting, lambda2 1/9.",
        "",
    ]
    lines += [
        f"- {key}: {value:.4g}" if isinstance(value, float) else f"- {key}: {value}"
        for key, value in numbers.items()
    ]
    lines += [
        "",
        "Peak localization error at the pulse's maximum (mm), median (IQR) over the dipoles:",
        "",
        "| channels | SKF | sLORETA |",
        "|---|---:|---:|",
    ]
    for name in CHANNEL_SETS:
        cells = []
        for method in ("SKF", "sLORETA"):
            errors = table[(table.channels == name) & (table.method == method)].error_mm
            q1, median, q3 = np.percentile(errors, [25, 50, 75])
            cells.append(f"{median:.0f} ({q3 - q1:.0f})")
        lines.append(f"| {name} | {cells[0]} | {cells[1]} |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    """Command line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(prog="python -m validation.mne_sample")
    parser.add_argument("--mne-testing-data", type=Path, required=True, metavar="DIR")
    parser.add_argument("--out", type=Path, default=Path("validation/bench"))
    parser.add_argument("--dipoles", type=int, default=20)
    args = parser.parse_args(argv)
    if not (args.mne_testing_data / RAW).is_file():
        print(f"mne_sample: {args.mne_testing_data / RAW}: no such file", file=sys.stderr)
        return 2
    table, numbers = run(args.mne_testing_data, args.dipoles)
    text = report(table, numbers, args.dipoles)
    args.out.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.out / "mne_sample.csv") as tmp:
        table.to_csv(tmp, index=False)
    with atomic_path(args.out / "mne_sample.md") as tmp:
        tmp.write_text(text)
    print(text)
    ok = numbers["reference routes, largest relative difference"] < REFERENCE_RTOL
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
