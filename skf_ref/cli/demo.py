"""``skf-ref demo``: the paper's P20/N20 study at one setting, from simulation to figures."""

import json
import sys
from pathlib import Path

import numpy as np

from .. import memory
from ..checks import InputError
from ..files import atomic_path
from ._args import add_skf_options, db, integer, progress, report_tuning

__all__ = ["add_parser", "run"]

OUTPUTS = ("reconstruction.npz", "settings.json", "metrics.csv", "metrics_columns.csv")


def add_parser(subparsers):
    """Add ``demo`` to the ``skf-ref`` subcommands."""
    demo = subparsers.add_parser(
        "demo",
        help="the paper's P20/N20 study at one setting: metrics, figures and arrays",
        description="Simulate the P20/N20 scenario (a deep thalamic and a superficial "
        "cortical dipole, 2 ms apart), reconstruct it with the SKF without and with "
        "smoothing, print the metrics and write figures (PNG), arrays (reconstruction.npz), "
        "the metrics (metrics.csv, explained in metrics_columns.csv) and everything that "
        "produced them (settings.json) to the output folder. The head is the realistic one "
        "(a three-layer BEM of MNE's 'sample' subject, cortex + thalamus source space) when "
        "MNE's testing dataset is at hand (--mne-testing-data DIR, or found by MNE without "
        "downloading), the spherical one otherwise; the demo says which. The source space is "
        "cortex + thalamus by default, in both heads, like the paper's.",
    )
    demo.add_argument("--out", type=Path, default=Path("skf-demo"), help="output folder")
    demo.add_argument("--snr-db", type=db(), default=30.0, help="data peak SNR (dB)")
    add_skf_options(
        demo,
        exponent=1.25,
        smoother="rts-standardized",
        smoother_help="smoother of the second reconstruction ('none': the filter only)",
    )
    demo.add_argument(
        "--source-space",
        choices=("anatomical", "volume"),
        default="anatomical",
        help="'anatomical': cortex + thalamus; 'volume': a grid filling the brain compartment",
    )
    demo.add_argument(
        "--positions",
        type=integer(minimum=420),
        help="source positions requested of the sphere's volume grid, which holds the "
        "nearest count it can (default: 3000 with --source-space volume)",
    )
    demo.add_argument(
        "--head",
        choices=("auto", "realistic", "sphere"),
        default="auto",
        help="'realistic' needs MNE's testing dataset; 'auto': realistic if the dataset is "
        "found, else the sphere",
    )
    demo.add_argument(
        "--mne-testing-data",
        type=Path,
        metavar="DIR",
        help="MNE's testing dataset folder (default: MNE's own lookup, never downloading)",
    )
    demo.add_argument(
        "--cache-dir",
        type=Path,
        metavar="DIR",
        help="where the realistic head's forward models are cached (default: "
        "$SKF_REF_CACHE_DIR or the user's cache folder)",
    )
    demo.add_argument("--montage", default="biosemi64", help="MNE built-in montage")
    demo.add_argument("--seed", type=integer(minimum=0), default=0, help="noise seed")
    demo.add_argument("--quiet", action="store_true", help="no progress messages")
    demo.set_defaults(run=run)


def _reconstructions(args, head, sim):
    from ..inverse import reconstruct
    from ..tune import choose_priors

    theta0, q, tuning = choose_priors(
        head.leadfield,
        sim.Y,
        noise_std=sim.sigma,
        pm_snr_db=args.pm_snr_db,
        ep_snr_db=args.ep_snr_db,
    )
    report_tuning(args, tuning)
    smoothers = {"filtered": None}
    if args.smoother != "none":
        smoothers["smoothed"] = args.smoother
    runs = {}
    for label, smoother in smoothers.items():
        rec = reconstruct(
            head.leadfield,
            sim.Y,
            noise_std=sim.sigma,
            theta0=theta0,
            q=q,
            exponent=args.exponent,
            smoother=smoother,
        )
        _ = rec.z, rec.weights  # computed (and checked finite) before any file is written
        runs[label] = rec
    return runs, theta0, q


def _settings(args, head, sim, theta0, q):
    from ..provenance import machine

    return {
        "snr_db": args.snr_db,
        "priors_chosen_by_the_data": getattr(args, "tuned", False),
        "pm_snr_db": args.pm_snr_db,
        "ep_snr_db": args.ep_snr_db,
        "exponent": args.exponent,
        "smoother": None if args.smoother == "none" else args.smoother,
        "positions_requested": args.positions,
        "n_positions": head.n_positions,
        "montage": args.montage,
        "seed": args.seed,
        "sigma": sim.sigma,
        "theta0": theta0,
        "q": q,
        "head": head.description,
        "head_kind": "realistic" if head.conductor_kind == "bem" else "sphere",
        "conductor": head.conductor_kind,
        "source_space": head.source_space,
        "sources_moved_mm": list(sim.truth.moved_mm),
        "machine": machine(),
    }


def _setting_line(args):
    return (
        f"SNR {args.snr_db:g} dB, EP-SNR {args.ep_snr_db:g} dB, PM-SNR {args.pm_snr_db:g} dB, "
        f"exponent {args.exponent:g}"
    )


def _testing_data(args):
    """MNE's testing dataset for the realistic head, or None for the sphere."""
    from ..head import find_testing_data

    if args.head == "sphere":
        if args.mne_testing_data is not None:
            raise InputError("--mne-testing-data: not used with --head sphere; drop one")
        return None
    try:
        found = find_testing_data(args.mne_testing_data)
    except InputError as err:
        raise InputError(f"--mne-testing-data: {str(err).split(', got ', 1)[0]}") from None
    if found is None and args.head == "realistic":
        raise InputError(
            "--head realistic needs MNE's testing dataset: give --mne-testing-data DIR (the "
            "folder mne.datasets.testing.data_path() returns); MNE did not find it"
        )
    return found


def _head_line(head, testing, args):
    if testing is not None:
        return f"realistic: {head.description}"
    why = (
        ""
        if args.head == "sphere"
        else (
            "; MNE's testing dataset not found: give --mne-testing-data DIR for the realistic head"
        )
    )
    return f"sphere: {head.description}{why}"


def run(args):
    """Run ``skf-ref demo``; returns the metrics as a pandas DataFrame."""
    import pandas as pd

    from .. import head as head_model
    from .. import metrics, simulate

    head_model.check_montage(args.montage)
    testing = _testing_data(args)
    if testing is None and args.source_space == "volume":
        args.positions = 3000 if args.positions is None else args.positions
        n = 3 * args.positions  # two runs, each with its model and z and weights in memory
        outputs = 2 * memory.spectral_memory(n, 64, 41) + 4 * 8 * n * 41
        head_model.check_size(args.positions, args.montage, extra=outputs, name="--positions")
    elif args.positions is not None:
        raise InputError(
            "--positions: sizes the sphere's volume grid only (--head sphere --source-space "
            "volume); the other source spaces have fixed spacings"
        )
    with progress(args, "head model"):
        head = head_model.make_head(
            "sphere" if testing is None else "bem",
            args.source_space,
            n_positions=args.positions or 3000,
            montage=args.montage,
            testing_data=testing,
            cache_dir=args.cache_dir,
        )
    print(f"head: {_head_line(head, testing, args)}")
    scenario = simulate.p20n20_scenario()
    sim = simulate.simulate(head, scenario, args.snr_db, args.seed)
    with progress(args, "SKF"):
        runs, theta0, q = _reconstructions(args, head, sim)
        table = pd.DataFrame({k: metrics.summarize(r, head, sim.truth) for k, r in runs.items()})
    print(f"SKF on {head.n_positions} positions ({args.montage}), {_setting_line(args)}")
    print(table.to_string())
    settings = _settings(args, head, sim, theta0, q)
    args.out.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.out / "reconstruction.npz") as tmp:
        arrays = {f"z_{label}": rec.z for label, rec in runs.items()}
        scalars = {k: v for k, v in settings.items() if isinstance(v, (int, float, str))}
        scalars["smoother"] = str(settings["smoother"])
        np.savez_compressed(
            tmp,
            **arrays,
            weights=runs["filtered"].weights,
            positions=head.positions,
            times=sim.times,
            Y=sim.Y,
            true_positions=sim.truth.positions,
            true_waveforms=sim.truth.waveforms,
            **{k: np.asarray(v) for k, v in scalars.items()},
            skf_ref_version=settings["machine"]["versions"]["skf_ref"],
        )
    with atomic_path(args.out / "settings.json") as tmp:
        tmp.write_text(json.dumps(settings, indent=1) + "\n")
    with atomic_path(args.out / "metrics.csv") as tmp:
        table.to_csv(tmp, index_label="metric")
    with atomic_path(args.out / "metrics_columns.csv") as tmp:
        pd.DataFrame(metrics.COLUMNS, columns=["metric", "meaning", "unit", "better"]).to_csv(
            tmp, index=False
        )
    with progress(args, "figures"):
        _figures(args, head, sim, runs)
    if not args.quiet:
        print(f"wrote figures, metrics and arrays to {args.out}", file=sys.stderr)
    return table


def _figures(args, head, sim, runs):
    from .. import plots

    for label, rec in runs.items():
        name = "filter only" if label == "filtered" else args.smoother
        title = f"SKF, {name}:\n{_setting_line(args)}"
        with atomic_path(args.out / f"time_courses_{label}.png") as tmp:
            plots.plot_time_courses(rec, head, sim.truth, title=title, path=tmp)
        with atomic_path(args.out / f"projections_{label}.png") as tmp:
            plots.plot_average_reconstruction(
                rec,
                head,
                sim.truth,
                title=f"{title}, one noise realization (seed {args.seed})",
                path=tmp,
            )
