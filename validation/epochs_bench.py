"""The benchmark of record: the SKF against MNE's sLORETA on the sample subject, MEG + EEG.

``python -m validation.epochs_bench --mne-testing-data DIR [--out DIR] [--repeats N]``
``[--epochs N] [--spacing MM] [--blas-threads N] [--first-runs N] [--profile]``

``DIR`` is the folder ``mne.datasets.testing.data_path()`` returns (nothing is
downloaded). The sample subject's 306 MEG sensors and 60 EEG electrodes
(``SSS/sample_audvis_trunc_raw_sss.fif``, its average-reference projector, the two
channels the noise covariance marks bad left out), the noise covariance
``MEG/sample/sample_audvis_trunc-cov.fif``, the three-layer BEM and head-MRI transform, and
a volume grid inside the inner skull at ``--spacing`` mm (7.8 mm: about 3000 positions,
free orientation). ``--epochs`` epochs (40) of 0.5 s at the recording's 300 Hz (151
samples, 0.1 s before the stimulus), each noise drawn from the covariance plus one dipole
(seeded); the raw recording is the same samples end to end (40 x 151 = 6040 samples,
20 s; the testing data's own recording is 1 s long). Both operators use the covariance's
rank from the info (``rank="info"``: the MEG is Maxwell filtered), the same forward and
covariance, and are made beforehand (their time is reported, not compared):

- MNE: ``make_inverse_operator`` (``loose=1``, no depth weighting) and
  ``prepare_inverse_operator`` (nave 1, lambda2 1/9, sLORETA): MNE's fastest route,
  ``apply_inverse_epochs(epochs, inverse, 1/9, "sLORETA", prepared=True)`` (a list of
  source estimates, the per-position norm) and ``apply_inverse_raw(raw, ...)`` likewise;
- SKF: ``skf_ref.make_skf_operator`` with its priors fixed in the operator
  (:data:`PRIORS`: PM-SNR 0 dB, the package's default, and the AR(1) prior at 20 ms), as
  MNE's operator fixes lambda2, then ``apply_skf_epochs(epochs, operator)`` and
  ``apply_skf_raw(raw, operator)`` at the package's default setting (exponent 0.5,
  ``"rts-smoothed-weights"``, each position standardized as a whole). The operator's
  covariance recursion for each length is computed at its first use, before the timed
  rounds (MNE's kernel is assembled on each call; the SKF's recursion is kept, as an
  operator applied to data of one length does). The package's default priors are chosen
  by the data of each data set (``time_constant_ms="auto"``): not MNE's case, and not
  timed here but for the first application below.

Epochs and raw are timed in interleaved rounds (one of each path per round, the order
alternating), and each round gives one ratio, SKF over MNE: the table reports medians and
interquartile ranges over the rounds of wall time, process CPU time (both cores' work) and
the ratio, beside the BLAS threads (threadpoolctl) and the load average before and after.
The targets (issue 46): epochs at most 1.5x MNE, raw at most 2x.

**The first application** of a prepared operator is timed in fresh processes
(``--first-runs``, 3): each reads the inputs, makes the operators (untimed), then times
the first ``apply_skf(evoked, operator)`` on the epochs' average (everything a first call
pays: the covariance recursion, the weights, the source estimate), beside MNE's first
``apply_inverse`` and, for information, the SKF's first application with the default
priors chosen by the data (``"auto"``). The target: the SKF's under 2 s.

``--profile`` adds where the SKF's time goes per epoch. Results go to ``DIR/epochs.md``,
``DIR/epochs.csv`` (the rounds' table) and ``DIR/epochs.json`` (everything, with the
versions) (``epochs-blasN.*`` with ``--blas-threads N``).
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from skf_ref._utils.atomic_files import atomic_path
from skf_ref._utils.provenance import machine
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
PATHS = ("mne-sloreta", "skf", "mne-sloreta-raw", "skf-raw")
#: The issue's targets: the SKF's time over MNE's, at most (epochs, raw).
TARGETS = {"skf": 1.5, "skf-raw": 2.0}
#: The issue's target for the first application of a prepared operator, seconds.
FIRST_TARGET_SECONDS = 2.0
LAMBDA2 = 1 / 9
#: The SKF's priors, fixed in the operator as MNE's operator fixes lambda2.
PRIORS = dict(pm_snr_db=0.0, time_constant_ms=20.0)


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


def make_raw(epochs):
    """The epochs' samples end to end as one recording (``mne.io.RawArray``)."""
    import mne

    data = np.concatenate(list(epochs.get_data()), axis=1)
    return mne.io.RawArray(data, epochs.info, verbose=False)


def make_runners(epochs, forward, noise_cov):
    """Every path as a call with no arguments, their operators made (and timed) first.

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
        apply_inverse_raw,
        make_inverse_operator,
        prepare_inverse_operator,
    )

    import skf_ref

    raw = make_raw(epochs)
    made = {}
    start = time.perf_counter()
    inverse = make_inverse_operator(
        epochs.info, forward, noise_cov, loose=1.0, depth=None, rank=RANK, verbose=False
    )
    inverse = prepare_inverse_operator(inverse, 1, LAMBDA2, "sLORETA", verbose=False)
    made["mne-sloreta"] = time.perf_counter() - start
    start = time.perf_counter()
    operator = skf_ref.make_skf_operator(
        epochs.info, forward, noise_cov, rank=RANK, **PRIORS, verbose=False
    )
    skf_ref.apply_skf_epochs(epochs[:1], operator)  # the recursion of this length, kept
    made["skf"] = time.perf_counter() - start
    made["mne-sloreta-raw"], made["skf-raw"] = made["mne-sloreta"], made["skf"]

    def mne_run():
        return apply_inverse_epochs(
            epochs, inverse, LAMBDA2, "sLORETA", prepared=True, verbose=False
        )

    def skf_run():
        return skf_ref.apply_skf_epochs(epochs, operator)

    def mne_raw():
        return apply_inverse_raw(raw, inverse, LAMBDA2, "sLORETA", prepared=True, verbose=False)

    def skf_raw():
        return skf_ref.apply_skf_raw(raw, operator)

    skf_run.operator = operator
    mne.set_log_level("WARNING")
    epochs_runners = {"mne-sloreta": mne_run, "skf": skf_run}
    return epochs_runners, {"mne-sloreta-raw": mne_raw, "skf-raw": skf_raw}, made


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


def first_application(folder):
    """In this (fresh) process: the operators made from the inputs :func:`save_inputs`
    wrote to ``folder``, then each one's first application to the epochs' average, timed.

    Returns
    -------
    dict
        ``{path: {"seconds", "cpu_seconds", "made_seconds"}}`` for ``mne-sloreta``, ``skf``
        (:data:`PRIORS`) and ``skf-auto`` (the default priors, chosen by the data).
    """
    import mne
    from mne.minimum_norm import apply_inverse, make_inverse_operator, prepare_inverse_operator

    import skf_ref

    folder = Path(folder)
    epochs = mne.read_epochs(folder / "bench-epo.fif", verbose=False)
    forward = mne.read_forward_solution(folder / "bench-fwd.fif", verbose=False)
    noise_cov = mne.read_cov(folder / "bench-cov.fif", verbose=False)
    evoked = epochs.average()

    def timed(make, apply):
        start = time.perf_counter()
        operator = make()
        made = time.perf_counter() - start
        cpu, wall = time.process_time(), time.perf_counter()
        apply(operator)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        return dict(seconds=wall, cpu_seconds=cpu, made_seconds=made)

    def skf(**priors):
        return lambda: skf_ref.make_skf_operator(
            evoked.info, forward, noise_cov, rank=RANK, **priors, verbose=False
        )

    def mne_inverse():
        inverse = make_inverse_operator(
            evoked.info, forward, noise_cov, loose=1.0, depth=None, rank=RANK, verbose=False
        )
        return prepare_inverse_operator(inverse, evoked.nave, LAMBDA2, "sLORETA", verbose=False)

    results = {
        "mne-sloreta": timed(
            mne_inverse,
            lambda op: apply_inverse(evoked, op, LAMBDA2, "sLORETA", prepared=True, verbose=False),
        ),
        "skf": timed(skf(**PRIORS), lambda op: skf_ref.apply_skf(evoked, op, verbose=False)),
    }
    with mne.utils.use_log_level("error"):  # the choice on a bound of its range warns
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            results["skf-auto"] = timed(
                skf(), lambda op: skf_ref.apply_skf(evoked, op, verbose="error")
            )
    return results


def save_inputs(folder, epochs, forward, noise_cov):
    """The inputs as files a fresh process reads (:func:`first_application`)."""
    import mne

    folder = Path(folder)
    epochs.save(folder / "bench-epo.fif", fmt="double", overwrite=True, verbose=False)
    mne.write_forward_solution(folder / "bench-fwd.fif", forward, overwrite=True, verbose=False)
    noise_cov.save(folder / "bench-cov.fif", overwrite=True, verbose=False)


def first_applications(epochs, forward, noise_cov, runs, blas_limit=None):
    """:func:`first_application` in ``runs`` fresh processes, one after another.

    Returns
    -------
    dict
        ``{path: {"seconds": [...], "cpu_seconds": [...], "made_seconds": [...]}}`` and
        ``load_before``, ``load_after``.
    """
    results: dict = {}
    environment = dict(os.environ)
    if blas_limit is not None:
        environment["OPENBLAS_NUM_THREADS"] = str(blas_limit)
    with tempfile.TemporaryDirectory() as folder:
        save_inputs(folder, epochs, forward, noise_cov)
        load_before = os.getloadavg()
        for _ in range(runs):
            answer = subprocess.run(
                [sys.executable, "-m", "validation.epochs_bench", "--first-application", folder],
                capture_output=True,
                text=True,
                check=True,
                env=environment,
            )
            for path, values in json.loads(answer.stdout.splitlines()[-1]).items():
                for key, value in values.items():
                    results.setdefault(path, {}).setdefault(key, []).append(value)
        load_after = os.getloadavg()
    return dict(paths=results, load_before=load_before, load_after=load_after)


def _loads(values):
    return " ".join(f"{x:.2f}" for x in values)


def report(table, profiles=None, stage_times=None, first=None):
    """The markdown file: machine, BLAS, load, the tables, the targets and any profile."""
    epochs_rows = table[~table.path.str.endswith("-raw")]
    raw_rows = table[table.path.str.endswith("-raw")]
    top = epochs_rows.iloc[0]
    what = (
        f"The sample subject's sensors: {top.n_channels} channels (MEG and EEG), "
        f"{top.n_positions} positions x 3 ({top.spacing_mm:g} mm volume grid), "
        f"{top.n_epochs} epochs of {top.n_times} samples"
    )
    lines = report_table(epochs_rows, what, digits=3)
    if len(raw_rows):
        raw = raw_rows.iloc[0]
        lines += [
            "",
            f"A raw recording of {raw.n_times} samples (the epochs end to end), "
            f"{raw.rounds} interleaved rounds (load before: {raw.load_before}; after: "
            f"{raw.load_after}); the ratio is each round's time over `mne-sloreta-raw`'s:",
            "",
        ]
        lines += report_table(raw_rows, what, digits=3)[4:]
    if first:
        runs = len(first["paths"]["skf"]["seconds"])
        lines += [
            "",
            f"The first application of a prepared operator, in {runs} fresh processes "
            f"(medians; load before: {_loads(first['load_before'])}; after: "
            f"{_loads(first['load_after'])}): the evoked of the epochs' average, the "
            "operator made beforehand (its time beside):",
            "",
            "| path | wall (s) | CPU (s) | target | operator made (s) |",
            "|---|---:|---:|---:|---:|",
        ]
        for path, values in first["paths"].items():
            target = f"< {FIRST_TARGET_SECONDS:g} s" if path == "skf" else ""
            lines.append(
                f"| {path} | {np.median(values['seconds']):.3f} | "
                f"{np.median(values['cpu_seconds']):.3f} | {target} | "
                f"{np.median(values['made_seconds']):.3f} |"
            )
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
    first_runs=3,
):
    """The whole benchmark.

    Returns
    -------
    table : pandas.DataFrame
        One row per path (:func:`validation.operator_bench.summarize`).
    profiles : dict
    stage_times : dict
    first : dict or None
        :func:`first_applications`'s (None with ``first_runs`` 0).
    """
    import pandas as pd

    epochs, forward, noise_cov = make_inputs(folder, spacing_mm, n_epochs)
    first = None
    if first_runs:
        first = first_applications(epochs, forward, noise_cov, first_runs, blas_limit)
    with blas_limited(blas_limit):
        runners, raw_runners, made = make_runners(epochs, forward, noise_cov)
        operator = runners["skf"].operator
        size = dict(
            n_channels=len(operator.ch_names),
            n_positions=operator.n_sources // 3,
            spacing_mm=spacing_mm,
            n_epochs=len(epochs),
        )
        tables = []
        for calls, reference, n_times in (
            (runners, "mne-sloreta", len(epochs.times)),
            (raw_runners, "mne-sloreta-raw", len(epochs) * len(epochs.times)),
        ):
            rounds, load_before, load_after = timed_rounds(calls, repeats)
            tables.append(
                summarize(
                    rounds,
                    size | dict(n_times=n_times),
                    made,
                    load_before,
                    load_after,
                    blas_limit,
                    targets=TARGETS,
                    reference=reference,
                )
            )
        table = pd.concat(tables, ignore_index=True)
        profiles, stage_times = {}, {}
        if with_profile:
            profiles = {
                path: profile(call, top=25) for path, call in (runners | raw_runners).items()
            }
            stage_times = stages(epochs, operator)
    return table, profiles, stage_times, first


def write_json(path, table, first, blas_limit):
    """Everything measured, with the machine and versions, as one JSON file."""
    info = machine()
    record = dict(
        machine=info,
        blas_limit=blas_limit,
        priors=PRIORS,
        targets=dict(ratio=TARGETS, first_application_seconds=FIRST_TARGET_SECONDS),
        rounds=json.loads(table.to_json(orient="records")),
        first_application=first,
    )
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(record, indent=1, default=str) + "\n")


def main(argv=None):
    """Command line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(prog="python -m validation.epochs_bench")
    parser.add_argument("--mne-testing-data", type=Path, metavar="DIR")
    parser.add_argument("--out", type=Path, default=Path("validation/bench"))
    parser.add_argument("--repeats", type=int, default=9)
    parser.add_argument("--epochs", type=int, default=N_EPOCHS)
    parser.add_argument("--spacing", type=float, default=SPACING_MM, metavar="MM")
    parser.add_argument("--blas-threads", type=int, metavar="N")
    parser.add_argument("--first-runs", type=int, default=3, metavar="N")
    parser.add_argument("--profile", action="store_true")
    parser.add_argument("--first-application", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.first_application is not None:  # a fresh process's part (first_applications)
        print(json.dumps(first_application(args.first_application)))
        return 0
    if args.mne_testing_data is None:
        parser.error("--mne-testing-data is required")
    table, profiles, stage_times, first = run(
        args.mne_testing_data,
        args.spacing,
        args.epochs,
        args.repeats,
        args.blas_threads,
        args.profile,
        args.first_runs,
    )
    stem = "epochs" if args.blas_threads is None else f"epochs-blas{args.blas_threads}"
    write_results(args.out, stem, table, report(table, profiles, stage_times, first))
    write_json(Path(args.out) / f"{stem}.json", table, first, args.blas_threads)
    return 0


if __name__ == "__main__":
    sys.exit(main())
