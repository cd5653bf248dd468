"""Benchmark: the SKF on epochs, MEG and EEG, against MNE's ``apply_inverse_epochs``.

``python -m validation.epochs_bench --mne-testing-data DIR [--out DIR] [--repeats N]``
``[--epochs N] [--spacing MM] [--blas-threads N] [--profile]``

``DIR`` is the folder ``mne.datasets.testing.data_path()`` returns (nothing is
downloaded). The sample subject's 306 MEG sensors and 60 EEG electrodes
(``SSS/sample_audvis_trunc_raw_sss.fif``, its average-reference projector, the two
channels the noise covariance marks bad left out), the noise covariance
``MEG/sample/sample_audvis_trunc-cov.fif``, the three-layer BEM and head-MRI transform, and
a volume grid inside the inner skull at ``--spacing`` mm (7.8 mm: about 3000 positions,
free orientation). ``--epochs`` epochs (40) of 0.5 s at the recording's 300 Hz (151
samples, 0.1 s before the stimulus), each noise drawn from the covariance plus one dipole
(seeded). Both operators use the covariance's rank from the info (``rank="info"``: the MEG
is Maxwell filtered) and are made beforehand:

- ``mne-sloreta``: ``mne.minimum_norm.apply_inverse_epochs(epochs, inverse, 1/9,
  "sLORETA", prepared=True)`` on an operator made (``make_inverse_operator``, ``loose=1``,
  no depth weighting) and prepared (``prepare_inverse_operator``, nave 1): MNE's fastest
  route; a list of source estimates (the per-position norm, as the SKF's);
- ``skf``: ``skf_ref.apply_skf_epochs(epochs, operator)`` on an operator of
  ``skf_ref.make_skf_operator``, at the package's default setting (exponent 0.5, no
  smoothing, fixed priors); its covariance recursion for the epochs' length is computed
  when the operator is first applied (before the timed rounds), as MNE's kernel is.

The runs are interleaved (one of each per round, the order alternating), and each round
gives one ratio, SKF over MNE: the table reports medians and interquartile ranges over the
rounds of wall time, process CPU time (both cores' work) and the ratio, beside the BLAS
threads (threadpoolctl) and the load average before and after. The target: a ratio of at
most 1.5. ``--profile`` adds where the SKF's time goes per epoch. Results go to
``DIR/epochs.md`` and ``DIR/epochs.csv`` (``epochs-blasN.*`` with ``--blas-threads N``).
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from validation.mne_sample import BEM, COV, RANK, RAW, TRANS
from validation.operator_bench import (
    blas_limited,
    profile,
    report_table,
    summarize,
    timed_rounds,
    write_results,
)

#: Grid spacing (mm) of the volume source space: about 3000 positions in the inner skull.
SPACING_MM = 7.8
N_EPOCHS = 40
TMIN, TMAX = -0.1, 0.4
PATHS = ("mne-sloreta", "skf")
#: The issue's target: the SKF's time over MNE's, at most.
TARGETS = {"skf": 1.5}
LAMBDA2 = 1 / 9


def make_inputs(folder, spacing_mm=SPACING_MM, n_epochs=N_EPOCHS, seed=0):
    """The sample subject's MEG + EEG epochs, their forward and the noise covariance.

    Returns
    -------
    epochs : mne.EpochsArray
    forward : mne.Forward
    noise_cov : mne.Covariance
    """
    import mne

    folder = Path(folder)
    info = mne.io.read_info(folder / RAW, verbose=False)
    info = mne.pick_info(info, mne.pick_types(info, meg=True, eeg=True, exclude=[]))
    cov = mne.read_cov(folder / COV, verbose=False)
    info["bads"] = list(cov["bads"])
    bem = mne.make_bem_solution(folder / BEM, verbose=False)
    src = mne.setup_volume_source_space(
        "sample", pos=spacing_mm, bem=bem, subjects_dir=folder / "subjects", verbose=False
    )
    forward = mne.make_forward_solution(info, folder / TRANS, src, bem, verbose=False)
    rng = np.random.default_rng(seed)
    n_times = int(round((TMAX - TMIN) * info["sfreq"])) + 1
    names = [name for name in info.ch_names if name in cov["names"]]
    index = [cov["names"].index(name) for name in names]
    values, vectors = np.linalg.eigh(cov.data[np.ix_(index, index)])
    root = vectors * np.sqrt(np.clip(values, 0, None))
    rows = [info.ch_names.index(name) for name in names]
    times = TMIN + np.arange(n_times) / info["sfreq"]
    column = int(rng.integers(forward["sol"]["data"].shape[1]))
    gain = np.zeros(len(info.ch_names))
    gain[[info.ch_names.index(n) for n in forward["sol"]["row_names"]]] = forward["sol"]["data"][
        :, column
    ]
    pulse = np.where(times > 0, np.sin(np.pi * np.clip(times, 0, 0.1) / 0.1), 0.0)
    data = np.zeros((n_epochs, len(info.ch_names), n_times))
    for k in range(n_epochs):
        data[k][rows] = root @ rng.standard_normal((len(names), n_times))
    data += 30e-9 * np.outer(gain, pulse)[None]
    epochs = mne.EpochsArray(data, info, tmin=TMIN, verbose=False)
    return epochs, forward, cov


def make_runners(epochs, forward, noise_cov):
    """Both paths as calls with no arguments, their operators made (and timed) first.

    Returns
    -------
    runners : dict
        ``{path: callable}``.
    made : dict
        Seconds each operator took to make (and prepare, or its first application).
    """
    import mne
    from mne.minimum_norm import (
        apply_inverse_epochs,
        make_inverse_operator,
        prepare_inverse_operator,
    )

    import skf_ref

    made = {}
    start = time.perf_counter()
    inverse = make_inverse_operator(
        epochs.info, forward, noise_cov, loose=1.0, depth=None, rank=RANK, verbose=False
    )
    inverse = prepare_inverse_operator(inverse, 1, LAMBDA2, "sLORETA", verbose=False)
    made["mne-sloreta"] = time.perf_counter() - start
    start = time.perf_counter()
    operator = skf_ref.make_skf_operator(epochs.info, forward, noise_cov, rank=RANK, verbose=False)
    skf_ref.apply_skf_epochs(epochs[:1], operator)  # the recursion of this length, kept
    made["skf"] = time.perf_counter() - start

    def mne_run():
        return apply_inverse_epochs(
            epochs, inverse, LAMBDA2, "sLORETA", prepared=True, verbose=False
        )

    def skf_run():
        return skf_ref.apply_skf_epochs(epochs, operator)

    skf_run.operator = operator
    mne.set_log_level("WARNING")
    return {"mne-sloreta": mne_run, "skf": skf_run}, made


def stages(epochs, operator, repeats=3):
    """Median wall seconds per epoch of each stage of ``apply_skf_epochs``.

    ``info``: the epochs' info checked, once for all; ``select``: each epoch's channels;
    ``filter``: whitening and the spectral model's recursions; ``z``: the standardized
    estimate; ``stc``: its per-position norm and the source estimate around it.
    """
    times = {name: [] for name in ("info", "select", "filter", "z", "stc")}
    tmin, tstep = epochs.times[0], 1 / epochs.info["sfreq"]
    data = epochs.get_data()
    for _ in range(repeats):
        start = time.perf_counter()
        check = operator.check_info(epochs.info, "epochs")
        times["info"].append((time.perf_counter() - start) / len(data))
        spent = dict.fromkeys(("select", "filter", "z", "stc"), 0.0)
        for k, epoch in enumerate(data):
            marks = [time.perf_counter()]
            picked = operator.select(epochs.info, epoch, f"epochs[{k}]", check=check)
            marks.append(time.perf_counter())
            rec = operator.reconstruct(picked)
            marks.append(time.perf_counter())
            rec.z  # noqa: B018 (computed on first access)
            marks.append(time.perf_counter())
            operator.to_stc(rec, tmin, tstep)
            marks.append(time.perf_counter())
            for name, a, b in zip(spent, marks[:-1], marks[1:], strict=True):
                spent[name] += (b - a) / len(data)
        for name, value in spent.items():
            times[name].append(value)
    return {name: float(np.median(values)) for name, values in times.items()}


def report(table, profiles=None, stage_times=None):
    """The markdown file: machine, BLAS, load, the table, the target and any profile."""
    first = table.iloc[0]
    what = (
        f"The sample subject's sensors: {first.n_channels} channels (MEG and EEG), "
        f"{first.n_positions} positions x 3 ({first.spacing_mm:g} mm volume grid), "
        f"{first.n_epochs} epochs of {first.n_times} samples"
    )
    lines = report_table(table, what, digits=3)
    if stage_times:
        lines += [
            "",
            "Where the SKF's time goes, per epoch (median wall milliseconds; `info` is checked "
            "once for all epochs, shown per epoch):",
            "",
            "| " + " | ".join(stage_times) + " |",
            "|" + "---:|" * len(stage_times),
            "| " + " | ".join(f"{1e3 * v:.2f}" for v in stage_times.values()) + " |",
        ]
    for path, text in (profiles or {}).items():
        lines += ["", f"Profile of one `{path}` run (cumulative seconds):", "", "```"]
        lines += [text.rstrip(), "```"]
    return "\n".join(lines) + "\n"


def run(
    folder,
    spacing_mm=SPACING_MM,
    n_epochs=N_EPOCHS,
    repeats=9,
    blas_limit=None,
    with_profile=False,
):
    """The whole benchmark.

    Returns
    -------
    table : pandas.DataFrame
        One row per path (:func:`validation.operator_bench.summarize`).
    profiles : dict
    stage_times : dict
    """
    epochs, forward, noise_cov = make_inputs(folder, spacing_mm, n_epochs)
    with blas_limited(blas_limit):
        runners, made = make_runners(epochs, forward, noise_cov)
        rounds, load_before, load_after = timed_rounds(runners, repeats)
        operator = runners["skf"].operator
        size = dict(
            n_channels=len(operator.ch_names),
            n_positions=operator.n_sources // 3,
            spacing_mm=spacing_mm,
            n_epochs=len(epochs),
            n_times=len(epochs.times),
        )
        table = summarize(rounds, size, made, load_before, load_after, blas_limit, targets=TARGETS)
        profiles, stage_times = {}, {}
        if with_profile:
            profiles = {path: profile(call, top=25) for path, call in runners.items()}
            stage_times = stages(epochs, operator)
    return table, profiles, stage_times


def main(argv=None):
    """Command line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(prog="python -m validation.epochs_bench")
    parser.add_argument("--mne-testing-data", type=Path, required=True, metavar="DIR")
    parser.add_argument("--out", type=Path, default=Path("validation/bench"))
    parser.add_argument("--repeats", type=int, default=9)
    parser.add_argument("--epochs", type=int, default=N_EPOCHS)
    parser.add_argument("--spacing", type=float, default=SPACING_MM, metavar="MM")
    parser.add_argument("--blas-threads", type=int, metavar="N")
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args(argv)
    table, profiles, stage_times = run(
        args.mne_testing_data,
        args.spacing,
        args.epochs,
        args.repeats,
        args.blas_threads,
        args.profile,
    )
    stem = "epochs" if args.blas_threads is None else f"epochs-blas{args.blas_threads}"
    write_results(args.out, stem, table, report(table, profiles, stage_times))
    return 0


if __name__ == "__main__":
    sys.exit(main())
