"""``skf-ref demo``: parses its options, calls :func:`skf_ref.study._demo.run_demo`, prints."""

from __future__ import annotations

import argparse
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .._utils.checks import InputError
from ..method import RECOMMENDED_SETTING
from ..method._priors import DEFAULT_TIME_CONSTANT_MS
from ..study._sizes import DEFAULT_POSITIONS, SCENARIO_MIN_POSITIONS
from ._args import Parser, add_skf_options, db, integer

if TYPE_CHECKING:
    from ..study._demo import Demo

__all__ = ["add_parser", "run"]

#: The metrics the demo prints (all are in metrics.csv): the thalamus' level against its
#: calibrated threshold on a cortex + thalamus head, the paper's 6 dB reading otherwise (where
#: the estimate is largest, not whether the deep source is there).
_PRINTED = (
    "thalamic_level",
    "detection_threshold",
    "deep_detected_calibrated",
    "deep_error_mm",
    "superficial_error_mm",
)
_PRINTED_6DB = (
    "deep_region_db",
    "deep_within_6db",
    "deep_error_mm",
    "superficial_error_mm",
    "separation",
)


def add_parser(subparsers: argparse._SubParsersAction[Parser]) -> None:
    """Add ``demo`` to the ``skf-ref`` subcommands.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``skf-ref``'s parser's ``add_subparsers`` returned.
    """
    demo = subparsers.add_parser(
        "demo",
        help="the paper's P20/N20 study: the SKF beside sLORETA, the deep source present "
        "and absent",
        description="Simulate the P20/N20 scenario (a deep thalamic and a superficial "
        "cortical dipole, 2 ms apart) and its control with the deep source left out (the "
        "same noise); reconstruct both with the SKF at the chosen setting (default: the "
        "package's, exponent 0.5 with the rts-smoothed-weights smoother, each position "
        "standardized as a whole, PM-SNR 0 dB and the stationary AR(1) prior with its time "
        "constant chosen by the data; --ep-snr-db runs the paper's random walk instead), "
        "with the SKF at the paper's setting (exponent 1.25, rts-standardized, at its priors: "
        "PM-SNR 0 dB, the random walk at EP-SNR 20 dB) and with MNE's sLORETA; print the "
        "metrics "
        "and write the side-by-side figure (comparison.png), time courses and projections "
        "(PNG), arrays (reconstruction.npz), the metrics (metrics.csv, explained in "
        "metrics_columns.csv) and everything that produced them (settings.json) to the "
        "output folder. The head is the realistic one (a three-layer BEM of MNE's 'sample' "
        "subject, cortex + thalamus source space) when MNE's testing dataset is at hand "
        "(--mne-testing-data DIR, or found by MNE without downloading), the spherical one "
        "otherwise; the demo says which.",
    )
    demo.add_argument("--out", type=Path, default=Path("skf-demo"), help="output folder")
    demo.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the files of --out named like the demo's outputs (metrics.csv, "
        "settings.json, ...)",
    )
    demo.add_argument("--snr-db", type=db(), default=30.0, help="data peak SNR (dB)")
    add_skf_options(
        demo,
        exponent=RECOMMENDED_SETTING["exponent"],
        smoother=RECOMMENDED_SETTING["smoother"] or "none",
        smoother_help="smoother of the first SKF (the second is the paper's setting)",
        time_constant=True,
    )
    # the evolution prior: the AR(1) prior with its time constant chosen by the data unless
    # --ep-snr-db is given (not given: None, which run() resolves)
    helps = {
        "ep_snr_db": "the first SKF runs the paper's random walk with this EP-SNR prior instead "
        "of the AR(1) prior (dB; or chosen by the data: auto (searched in -20..40 dB) or "
        "LOW,HIGH, e.g. -40,20; the paper's setting then runs at the priors chosen too) "
        "(default: not given: the AR(1) prior of --time-constant-ms)",
        "time_constant_ms": "the first SKF's stationary AR(1) prior: the sources' time "
        "constant in ms at the simulation's 10 kHz (rho = exp(-dt / tau), q = (1 - rho^2) "
        "theta0); or chosen by the data: auto (searched in 1..1000 ms) or LOW,HIGH (e.g. "
        "0.1,1000). Not with --ep-snr-db (default: auto, unless --ep-snr-db is given)",
    }
    for action in demo._actions:  # add_skf_options' words are the reconstruct command's
        action.help = helps.get(action.dest, action.help)
    demo.add_argument(
        "--standardize",
        choices=("position", "column"),
        default="position",
        help="standardization of the first SKF: each source position's orientations as a "
        "whole (the default) or each column on its own (the paper's)",
    )
    demo.add_argument(
        "--source-space",
        choices=("anatomical", "volume"),
        default="anatomical",
        help="'anatomical': cortex + thalamus; 'volume': a grid filling the brain compartment",
    )
    demo.add_argument(
        "--positions",
        type=integer(minimum=SCENARIO_MIN_POSITIONS),
        help="source positions requested of the sphere's volume grid, which holds the "
        f"nearest count it can (default: {DEFAULT_POSITIONS} with --source-space volume)",
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


def run(args: argparse.Namespace) -> Demo:
    """Run ``skf-ref demo``: the demo, its files, and its metrics printed.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    skf_ref.study._demo.Demo
        What :func:`skf_ref.study._demo.run_demo` computed.
    """
    from ..study._demo import run_demo
    from ..study._head import check_montage

    if args.head == "sphere" and args.mne_testing_data is not None:
        raise InputError("--mne-testing-data: not used with --head sphere; drop one")
    if args.ep_snr_db is not None and args.time_constant_ms is not None:
        raise InputError(
            "argument --time-constant-ms: give --ep-snr-db (the paper's random walk) or "
            "--time-constant-ms (the stationary AR(1) prior), not both"
        )
    if args.ep_snr_db is None and args.time_constant_ms is None:
        args.time_constant_ms = DEFAULT_TIME_CONSTANT_MS  # the AR(1) prior, chosen by the data
    try:
        check_montage(args.montage)  # before the first progress line
        demo = run_demo(
            args.out,
            snr_db=args.snr_db,
            seed=args.seed,
            head=args.head,
            source_space=args.source_space,
            montage=args.montage,
            n_positions=args.positions,
            testing_data=args.mne_testing_data,
            cache_dir=args.cache_dir,
            pm_snr_db=args.pm_snr_db,
            ep_snr_db=args.ep_snr_db,
            time_constant_ms=args.time_constant_ms,
            exponent=args.exponent,
            smoother=None if args.smoother == "none" else args.smoother,
            standardize=args.standardize,
            overwrite=args.overwrite,
            verbose=not args.quiet,
        )
    except (InputError, MemoryError) as err:
        raise type(err)(_as_flag(str(err))) from None
    print(f"head: {_head_line(demo, args)}")
    print(
        f"SNR {args.snr_db:g} dB; {_priors_line(demo)}; {demo.head.n_positions} positions "
        f"({demo.head.montage}); the deep source present and absent (the same noise):"
    )
    calibrated = "detection_threshold" in demo.metrics.index
    table = demo.metrics.loc[list(_PRINTED if calibrated else _PRINTED_6DB)].T
    table.index = [_row_label(demo, column) for column in table.index]
    # column by column (Series.map): DataFrame.map is pandas 2.1's
    print(table.apply(lambda column: column.map(_three_digits)).to_string())
    if calibrated:
        print(
            "detected: the thalamus' largest amplitude at 1.5 ms above the method's threshold, "
            "which at most 5 % of simulated runs without a thalamic source exceed (one data "
            "set: the rates over many are in the study's report)"
        )
    return demo


def _three_digits(value: object) -> object:
    return f"{value:.3g}" if isinstance(value, float) else value


def _prior(name: str, settings: dict[str, Any], unit: str) -> str:
    """A prior as run: the number given, or the one the data chose, its range and whether it
    lies on an end of it."""
    from ..method._search import AUTO_RANGE_DB, AUTO_TIME_CONSTANT_MS

    value = settings[name]
    if isinstance(value, (int, float)):
        return f"{value:g} {unit}"
    if value == "auto":
        value = AUTO_TIME_CONSTANT_MS if unit == "ms" else AUTO_RANGE_DB
    low, high = value
    end = settings["tuned_at_bound"].get(name)
    chosen = settings[f"tuned_{name}"]
    on_end = f": on its {end} end" if end else ""
    return f"{chosen:.3g} {unit} (chosen by the data in {low:g}..{high:g} {unit}{on_end})"


def _priors_line(demo: Demo) -> str:
    """Which priors each SKF ran: the first's PM-SNR and evolution prior, the paper's."""
    s = demo.settings
    if s["evolution_prior"] == "ar1":
        evolution = f"the AR(1) prior with time constant {_prior('time_constant_ms', s, 'ms')}"
    else:
        evolution = f"the random walk at EP-SNR {_prior('ep_snr_db', s, 'dB')}"
    paper = (
        f"PM-SNR {s['paper_pm_snr_db']:.3g} dB, the random walk at EP-SNR "
        f"{s['paper_ep_snr_db']:.3g} dB"
    )
    shared = s["priors_chosen_by_the_data"] and s["evolution_prior"] != "ar1"
    return (
        f"first SKF: PM-SNR {_prior('pm_snr_db', s, 'dB')}, {evolution}; the paper's setting "
        f"at {'the same priors' if shared else 'its own priors'}: {paper}"
    )


#: The library's parameter names and the flags that set them.
_FLAGS = {
    "testing_data": "--mne-testing-data",
    "n_positions": "--positions",
    "head": "--head",
    "out": "--out",
    "source_space": "--source-space",
    "montage": "--montage",
}


def _as_flag(message: str) -> str:
    """The library's error, prefixed with the flag of the parameter it names."""
    name = re.findall(r"^[a-z_]*", message)[0]
    message = message.replace("give overwrite=True", "give --overwrite")
    return f"{_FLAGS[name]}: {message}" if name in _FLAGS else message


def _row_label(demo: Demo, column: str) -> str:
    key, data = column.split(", ", 1)
    return f"{demo.methods[key]}, {data}"


def _head_line(demo: Demo, args: argparse.Namespace) -> str:
    if demo.head.conductor_kind == "bem":
        return f"realistic: {demo.head.description}"
    why = (
        ""
        if args.head == "sphere"
        else "; MNE's testing dataset not found: give --mne-testing-data DIR for the realistic "
        "head"
    )
    return f"sphere: {demo.head.description}{why}"
