"""``skf-ref reconstruct``: your own EEG in, a source estimate (or arrays) out."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .._utils.checks import InputError
from ..method import RECOMMENDED_SETTING
from ._args import add_skf_options, positive, report_tuning


class _Renamed(argparse.Action):
    """``--method``, the computational path's flag until 0.6.0: an error naming ``--path``."""

    def __call__(self, parser: Any, namespace: Any, values: Any, option: Any = None) -> None:
        raise InputError(
            "--method was renamed --path in skf-ref 0.6.0: it chooses the computational path "
            "(auto, spectral, dense, filterpy), not an inverse method as MNE's method= does"
        )


if TYPE_CHECKING:
    from ..method import Reconstruction

__all__ = ["add_parser", "run"]

_EXAMPLES = """\
examples:
  skf-ref reconstruct --forward sample-fwd.fif --evoked sample-ave.fif --condition 0 \\
      --noise-cov sample-cov.fif --out sample-skf-vl.stc --plot sample-skf.png
  skf-ref reconstruct --leadfield L.npy --data Y.csv --noise-std 1e-6 --out skf.npz

The MNE route (--forward/--evoked) takes every MEG and EEG channel the evoked, the
forward and the noise covariance share (--no-meg, --no-eeg leave a type out), matched by
name and type; gives data and lead field the average reference (the evoked's projector,
or its average-referenced data); whitens with the noise covariance of one trial divided
by the evoked's nave (an epochs file is averaged first, and says so), reduced to its
rank; and writes an MNE source estimate (.stc, .h5) or arrays (.npz). The array route
(--leadfield/--data) runs skf_ref.reconstruct on the arrays as they are (rows matched by
name when both files name them) and writes .npz. The priors are numbers in dB, or chosen
by the data: auto, or a range to search, e.g. --pm-snr-db -40,20. The evolution prior is
the stationary AR(1) prior with its time constant chosen by the data (--time-constant-ms
auto, the default where the sampling rate is known: the MNE route, or --sfreq), or a time
constant in ms; --ep-snr-db runs the paper's random walk instead (the array route's
default without --sfreq, at 0 dB). The smoother defaults to rts-smoothed-weights (the
evidence study v3's rule). Beside the output,
NAME.json records every setting, the nave, the channels used and left out, and the
package versions.
"""

_OUTPUTS = (".npz", ".stc", ".h5")


def _output(text: str) -> Path:
    path = Path(text)
    if path.suffix not in _OUTPUTS:
        raise argparse.ArgumentTypeError(f"must end in .npz, .stc or .h5, got {text!r}")
    return path


def add_parser(subparsers: Any) -> None:
    """Add ``reconstruct`` to the ``skf-ref`` subcommands.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``skf-ref``'s parser's ``add_subparsers`` returned.
    """
    parser = subparsers.add_parser(
        "reconstruct",
        help="the SKF on your own data: MNE files or arrays in, a source estimate out",
        description="Reconstruct EEG sources with the standardized Kalman filter.",
        epilog=_EXAMPLES,
    )
    inputs = parser.add_argument_group("inputs: --forward and --evoked, or --leadfield and --data")
    inputs.add_argument("--forward", type=Path, help="MNE forward solution (-fwd.fif)")
    inputs.add_argument(
        "--evoked",
        type=Path,
        help="MNE evoked (-ave.fif), epochs (-epo.fif: averaged) or a recording (as "
        "skf_ref.apply_skf_raw: its bad segments skipped, no estimate there)",
    )
    inputs.add_argument("--condition", help="the evoked's condition (name or index)")
    inputs.add_argument("--leadfield", type=Path, help="lead field: .npy, .npz, .mat, -fwd.fif")
    inputs.add_argument("--data", type=Path, help="data: .npy, .npz, .mat, .csv, MNE formats")
    inputs.add_argument("--key", help="variable name in .npz/.mat files (data and lead field)")
    noise = parser.add_argument_group("noise: one of")
    noise.add_argument("--noise-cov", type=Path, help="MNE noise covariance (-cov.fif)")
    noise.add_argument("--noise-std", type=positive(), help="noise standard deviation (V)")
    noise.add_argument(
        "--baseline",
        action="store_true",
        help="estimate the noise from the samples at t <= 0 (an evoked's own baseline: the "
        "data are whitened with it, whatever their nave)",
    )
    model = parser.add_argument_group("the SKF")
    add_skf_options(
        model,
        exponent=RECOMMENDED_SETTING["exponent"],
        smoother=RECOMMENDED_SETTING["smoother"] or "none",
        smoother_help="RTS smoother (the paper's setting: --exponent 1.25 --smoother "
        "rts-standardized)",
        time_constant=True,
    )
    model.add_argument(
        "--sfreq",
        type=positive(),
        help="array route: the data's sampling rate in Hz, for --time-constant-ms (default: "
        "the data file's, when it is MNE's); the MNE route takes the evoked's",
    )
    model.add_argument(
        "--standardize",
        choices=("column", "position"),
        help="standardize each source position's orientations as a whole, as sLORETA "
        "(docs/model.md section 2; default on the MNE route with EEG, which takes the "
        "orientations from the forward), or each column of the lead field on its own (the "
        "paper's; default on the array route, where an array does not say which columns "
        "form a position, and for MEG alone)",
    )
    model.add_argument(
        "--n-orient",
        type=int,
        choices=(1, 3),
        help="array route: columns per source position (default: from the lead field's "
        "positions when it has them); the MNE route takes it from the forward",
    )
    model.add_argument(
        "--path",
        default="auto",
        choices=("auto", "spectral", "dense", "filterpy"),
        help="computational path (--method before 0.6.0)",
    )
    model.add_argument("--method", action=_Renamed, help=argparse.SUPPRESS)
    model.add_argument(
        "--pick-ori",
        default="none",
        choices=("none", "vector"),
        help="free orientation: per-position norm ('none') or the three components",
    )
    model.add_argument(
        "--meg",
        action=argparse.BooleanOptionalAction,
        help="MNE route: use the MEG channels (an error if there are none), or leave them "
        "out; default: when the evoked, the forward and the noise covariance share them",
    )
    model.add_argument(
        "--eeg",
        action=argparse.BooleanOptionalAction,
        help="MNE route: use the EEG channels, or leave them out; default as --meg",
    )
    model.add_argument(
        "--average-reference",
        action="store_true",
        help="array route: subtract the channel mean from data and lead field first",
    )
    parser.add_argument("--out", type=_output, required=True, metavar="FILE", help="output")
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace existing output files (the output, its settings, the figure)",
    )
    parser.add_argument(
        "--plot", type=Path, metavar="FILE", help="also draw the estimate (.png, .pdf, .svg ...)"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress messages")
    parser.set_defaults(run=run)


def _route(args):
    mne_route = args.forward is not None or args.evoked is not None
    array_route = args.leadfield is not None or args.data is not None
    if mne_route == array_route:
        raise InputError("give --forward and --evoked, or --leadfield and --data")
    if mne_route and (args.forward is None or args.evoked is None):
        raise InputError("the MNE route needs both --forward and --evoked")
    if array_route and (args.leadfield is None or args.data is None):
        raise InputError("the array route needs both --leadfield and --data")
    given = [args.noise_cov is not None, args.noise_std is not None, args.baseline]
    if sum(given) != 1:
        raise InputError("give exactly one of --noise-cov, --noise-std or --baseline")
    if array_route and args.out.suffix != ".npz":
        raise InputError("argument --out: the array route writes .npz (no source space)")
    for flag in ("meg", "eeg"):
        if getattr(args, flag) is not None and not mne_route:
            raise InputError(f"argument --{flag}: channel types are picked on the MNE route only")
    if args.sfreq is not None and mne_route:
        raise InputError(
            "argument --sfreq: the MNE route takes the sampling rate from the evoked's info; "
            "--sfreq is for the array route (--leadfield/--data)"
        )
    if args.ep_snr_db is not None and args.time_constant_ms is not None:
        raise InputError(
            "argument --time-constant-ms: give --ep-snr-db (the paper's random walk) or "
            "--time-constant-ms (the stationary AR(1) prior), not both"
        )
    if args.time_constant_ms is None and args.ep_snr_db is None:
        from ..method._priors import DEFAULT_EP_SNR_DB, DEFAULT_TIME_CONSTANT_MS

        if mne_route or args.sfreq is not None:  # the AR(1) prior, chosen by the data
            args.time_constant_ms = DEFAULT_TIME_CONSTANT_MS
        else:  # an array without its rate: the paper's random walk, at 0 dB
            args.ep_snr_db = DEFAULT_EP_SNR_DB
    _check_route_options(args, mne_route)
    _check_outputs(args)
    args.standardize_given = args.standardize is not None
    if args.standardize is None and not mne_route:  # an array does not say which columns
        args.standardize = "column"  # form a position; the MNE route's operator decides
    return "mne" if mne_route else "arrays"


def _check_route_options(args: argparse.Namespace, mne_route: bool) -> None:
    """Refuse an option the route (or the file it is for) would leave unused, and an input
    that is no file (a named pipe would block a reader), before any work."""
    from ..io._files import takes_option
    from ..io._variables import existing_file

    for flag in ("--forward", "--evoked", "--leadfield", "--data", "--noise-cov"):
        given = getattr(args, flag[2:].replace("-", "_"))
        try:
            if given is not None:
                existing_file(given)
        except InputError as err:
            raise InputError(f"argument {flag}: {err}") from None

    if mne_route:
        only = {"--key": args.key is not None, "--average-reference": args.average_reference}
        used = [flag for flag, given in only.items() if given]
        if used:
            raise InputError(
                f"argument {used[0]}: the array route's (--leadfield/--data); the MNE route "
                "reads MNE files, and gives them the average reference itself"
            )
    elif args.pick_ori != "none":
        raise InputError(
            "argument --pick-ori: the MNE route's (--forward/--evoked); the array route "
            "writes every column of the estimate (.npz)"
        )
    data = args.evoked if mne_route else args.data
    if args.condition is not None and not takes_option(data, "condition"):
        raise InputError(
            f"argument --condition: {data} is not an MNE -ave.fif: it holds one recording, "
            "no conditions to choose"
        )
    if args.key is not None and not any(takes_option(f, "key") for f in (args.leadfield, data)):
        raise InputError(
            "argument --key: names a variable of .npz and .mat files, and neither --leadfield "
            "nor --data is one"
        )


def _outputs(args: argparse.Namespace) -> dict[str, list[Path]]:
    """Every file the command writes, by the flag that names it."""
    from ..io._files import stc_files

    if args.out.suffix == ".npz":
        written = [args.out]
    elif args.out.suffix == ".h5":
        written = stc_files(args.out, "VolSourceEstimate")
    elif args.pick_ori == "vector":
        raise InputError(
            f"argument --out: {args.out}: MNE writes a vector source estimate (--pick-ori "
            "vector) to .h5 only: give a name ending in .h5, or .npz"
        )
    else:  # which of them depends on the source space: see _check_stc_format
        written = [*stc_files(args.out, "SourceEstimate")]
        written += stc_files(args.out, "VolSourceEstimate")
    outputs = {"--out": written, "--out's settings": [args.out.with_name(args.out.name + ".json")]}
    if args.plot is not None:
        outputs["--plot"] = [args.plot]
    return outputs


def _check_outputs(args: argparse.Namespace) -> None:
    """Every file to write can be written, is no input and replaces nothing unless
    --overwrite: checked before any work."""
    from .._utils.atomic_files import check_output_path, same_file

    inputs = {
        flag: getattr(args, flag[2:].replace("-", "_"))
        for flag in ("--forward", "--evoked", "--leadfield", "--data", "--noise-cov")
    }
    if args.plot is not None:
        from matplotlib.backend_bases import FigureCanvasBase

        formats = FigureCanvasBase.get_supported_filetypes()
        if args.plot.suffix.lstrip(".").lower() not in formats:
            raise InputError(
                f"argument --plot: {args.plot}: a figure is written to "
                f"{', '.join('.' + f for f in sorted(formats))}, got {args.plot.suffix!r}"
            )
    seen: list[tuple[str, Path]] = []
    for flag, paths in _outputs(args).items():
        for path in paths:
            name = "argument --out" if flag == "--out's settings" else f"argument {flag}"
            check_output_path(
                path,
                name=name,
                inputs=inputs,
                overwrite=args.overwrite,
                overwrite_hint="give --overwrite to replace it",
            )
            other = next((f for f, p in seen if same_file(p, path)), None)
            if other is not None:
                raise InputError(f"{name}: {path} is also written as {other}")
            seen.append((flag, path))
    if args.out.suffix == ".stc" and args.forward is not None:
        _check_stc_format(args)


def _check_stc_format(args: argparse.Namespace) -> None:
    """MNE writes .stc for one surface or one volume only: a mixed source space, or
    several volumes, go to .h5 (read off the forward's source space, not its gain)."""
    import mne

    try:
        src = mne.read_source_spaces(args.forward, verbose=False)
    except Exception:  # MNE's reader raises several types; the forward is read again later
        return
    volumes = len(src) if src.kind in ("volume", "discrete") else 1
    if src.kind == "mixed" or volumes > 1:
        what = "a mixed source space" if src.kind == "mixed" else f"{volumes} volumes"
        raise InputError(
            f"argument --out: {args.out}: MNE writes the estimate on {what} to .h5 only (.stc "
            "holds one surface or one volume): give a name ending in .h5, or .npz"
        )


def _settings(args, route, extra):
    from .._utils.provenance import machine

    keys = (
        *("pm_snr_db", "ep_snr_db", "time_constant_ms", "sfreq"),
        *("exponent", "smoother", "standardize", "n_orient", "path", "pick_ori", "meg", "eeg"),
    )
    files = ("forward", "evoked", "condition", "leadfield", "data", "key", "noise_cov")
    return {
        "route": route,
        **{k: getattr(args, k) for k in keys},
        **{k: str(getattr(args, k)) for k in files if getattr(args, k) is not None},
        "noise_std": args.noise_std,
        "baseline": args.baseline,
        "nave": getattr(args, "nave", None),
        "priors_searched": getattr(args, "searched", None),
        **({"standardized": args.standardized} if hasattr(args, "standardized") else {}),
        **({"bad_samples": args.bad_samples} if hasattr(args, "bad_samples") else {}),
        **extra,
        "machine": machine(),
    }


def _read_cov(path):
    import warnings

    import mne

    from ..io._variables import existing_file

    try:
        existing_file(path)  # a named pipe would block MNE's reader
    except InputError as err:
        raise InputError(f"argument --noise-cov: {err}") from None
    try:
        with warnings.catch_warnings():  # MNE's advice on file names: we read any name
            warnings.filterwarnings("ignore", "This filename .* does not conform to MNE")
            return mne.read_cov(path, verbose=False)
    except Exception as err:  # MNE's reader raises several types for a bad file
        raise InputError(f"argument --noise-cov: {path}: {err}") from err


def _about_noise_cov(args, err):
    """An error about the noise or the channel types, named by its flag (and file)."""
    text = str(err)
    if args.noise_cov is not None and text.startswith("noise_cov"):
        return InputError(f"argument --noise-cov: {args.noise_cov}: {text}")
    if text.startswith(("meg=", "eeg=")):  # a type asked for and absent
        flag, rest = text[:3], text.split(" ", 1)[1]
        return InputError(
            f"argument --{flag}: {rest.replace(f'leave {flag}=None', f'drop --{flag}')}"
        )
    if args.noise_std is not None and text.startswith("noise_std must be a dict"):
        return InputError(
            "argument --noise-std: one standard deviation cannot whiten channels of several "
            "types (MEG and EEG, or magnetometers and gradiometers): give --noise-cov or "
            "--baseline, or leave a type out (--no-meg, --no-eeg)"
        )
    return err


_EPOCHS = ("-epo.fif", "_epo.fif", "-epo.fif.gz")


def _mne_route(args):
    from ..io._apply import apply_skf
    from ..io._files import read_data, read_leadfield
    from ..io._make_operator import make_skf_operator
    from ..io._noise_cov import baseline_covariance

    recording = read_data(args.evoked, condition=args.condition)
    if recording.evoked is None:
        raise InputError(f"argument --evoked: {args.evoked} is not an MNE format")
    forward = read_leadfield(args.forward).forward
    if forward is None:
        raise InputError(f"argument --forward: {args.forward} is not an MNE -fwd.fif")
    evoked, types = recording.evoked, dict(meg=args.meg, eeg=args.eeg)
    args.nave = evoked.nave
    if recording.raw is not None and args.baseline:
        raise InputError(
            f"argument --baseline: {args.evoked} is a continuous recording, with no "
            "pre-stimulus samples (t <= 0) to estimate the noise from: give --noise-cov "
            "(e.g. from the recording's rest) or --noise-std"
        )
    if args.evoked.name.lower().endswith(_EPOCHS) and not args.quiet:
        print(
            f"--evoked {args.evoked}: epochs, averaged: {evoked.nave} epochs, so the noise "
            f"covariance is divided by nave = {evoked.nave}",
            file=sys.stderr,
        )
    try:
        if args.noise_cov is not None:
            noise_cov = _read_cov(args.noise_cov)
        else:
            noise_cov = baseline_covariance(evoked, **types) if args.baseline else None
        operator = make_skf_operator(
            evoked.info,
            forward,
            noise_cov,
            noise_std=args.noise_std,
            pm_snr_db=args.pm_snr_db,
            ep_snr_db=args.ep_snr_db,
            time_constant_ms=args.time_constant_ms,
            **types,
            verbose=False,
        )
    except InputError as err:
        raise _about_noise_cov(args, err) from err
    if args.n_orient is not None and args.n_orient != operator.n_components:
        raise InputError(
            f"argument --n-orient: the forward has {operator.n_components} column(s) per "
            f"position, got {args.n_orient} (the MNE route takes it from the forward)"
        )
    settings = dict(
        exponent=args.exponent,
        smoother=args.smoother,
        standardize=args.standardize,
        pick_ori=None if args.pick_ori == "none" else args.pick_ori,
        path=args.path,
        return_reconstruction=True,
        verbose=False,
    )
    if recording.raw is None:
        stc, rec = apply_skf(evoked, operator, **settings)
    else:  # one route for a recording: its bad segments are missing observations
        stc, rec = _recording(args, recording.raw, operator, settings)
    report_tuning(args, rec.tuning)
    if args.time_constant_ms is not None:
        args.sfreq = evoked.info["sfreq"]  # what the time constant was taken at
    args.standardize = rec.settings["standardize"]  # the operator's default, if not given
    args.channels = {"used": operator.ch_names, "left_out": operator.dropped}
    if not args.quiet:
        left_out = "".join(f"; {k}: {', '.join(v)}" for k, v in operator.dropped.items())
        print(f"{len(operator.ch_names)} channels used{left_out}", file=sys.stderr)
    positions = [s["rr"][s["vertno"]] for s in forward["src"]]
    return rec, stc, recording.times, positions


def _recording(args, raw, operator, settings):
    """A continuous recording through :func:`skf_ref.apply_skf_raw`, as the Python route
    takes it: the samples inside its bad segments (``BAD_`` annotations) are missing
    observations, with no estimate there (NaN); a recording all bad is refused."""
    import numpy as np

    from ..io._raw import apply_skf_raw

    try:
        stc, rec = apply_skf_raw(raw, operator, **settings)
    except InputError as err:
        text = str(err).replace("from start to stop", "of the recording")
        text = text.replace("; give reject_by_annotation=False to use them", "")
        text = text.replace(", or reject_by_annotation=False", "")
        text = text.replace("smoother='rts-state'", "--smoother rts-state")
        raise InputError(f"argument --evoked: {args.evoked}: {text}") from None
    missing = np.isnan(stc.data.reshape(-1, stc.data.shape[-1])).all(axis=0)
    args.bad_samples = int(np.count_nonzero(missing))
    if not args.quiet:
        print(
            f"--evoked {args.evoked}: a continuous recording: {args.bad_samples} of "
            f"{missing.size} samples inside bad segments (BAD_ annotations), skipped as "
            "missing observations: no estimate there (NaN)",
            file=sys.stderr,
        )
    return stc, rec


def _array_route(args):

    from ..io._files import read_data, read_leadfield, takes_option
    from ..method import reconstruct
    from ..method._tuning import choose_priors
    from ..method._units import units_cause, units_mismatch, warn_units

    key = {
        path: args.key if takes_option(path, "key") else None
        for path in (args.leadfield, args.data)
    }
    leadfield = read_leadfield(args.leadfield, key=key[args.leadfield])
    recording = read_data(args.data, key=key[args.data], condition=args.condition)
    L, Y = leadfield.data, recording.data
    if recording.raw is not None:  # a recording: its bad segments are missing observations,
        Y = _recording_samples(args, recording.raw)  # as apply_skf_raw has them
    if leadfield.ch_names is not None and recording.ch_names is not None:
        missing = [name for name in recording.ch_names if name not in leadfield.ch_names]
        if missing:
            raise InputError(
                f"argument --leadfield: {args.leadfield} has no row for the channels {missing[:5]}"
                f" of {args.data}"
            )
        L = L[[leadfield.ch_names.index(name) for name in recording.ch_names]]
    elif L.shape[0] != Y.shape[0]:
        raise InputError(
            f"argument --leadfield: {L.shape[0]} rows, but --data has {Y.shape[0]} channels"
        )
    if args.average_reference:
        L, Y = L - L.mean(axis=0), Y - Y.mean(axis=0)
    noise = _array_noise(args, recording, Y)
    if args.time_constant_ms is not None:
        args.sfreq = _array_sfreq(args, recording)
    whitened = _whitened(Y, noise)
    baseline = None if recording.times is None else recording.times <= 0
    units = None if whitened is None else units_mismatch(whitened, baseline)
    warn_units(units)
    try:
        with units_cause(units):
            theta0, q, transition, tuning = choose_priors(
                L,
                Y,
                **noise,
                pm_snr_db=args.pm_snr_db,
                ep_snr_db=args.ep_snr_db,
                time_constant_ms=args.time_constant_ms,
                sfreq=args.sfreq,
            )
    except InputError as err:
        raise _about_noise_cov(args, err) from err
    report_tuning(args, tuning)
    n_orient = _n_orient(args, L, leadfield.positions)
    rec = reconstruct(
        L,
        Y,
        **noise,
        theta0=theta0,
        q=q,
        transition=transition,
        exponent=args.exponent,
        smoother=None if args.smoother == "none" else args.smoother,
        path=args.path,
        standardize=args.standardize,
        n_orient=n_orient,
    )
    args.n_orient = n_orient  # as used: given, or from the lead field's positions
    args.standardized = _standardized(args, L.shape[1], n_orient)
    if not args.quiet:
        print(args.standardized, file=sys.stderr)
    args.channels = {"used": recording.ch_names or L.shape[0]}
    return rec, None, recording.times, leadfield.positions


def _recording_samples(args, raw):
    """A recording's samples, NaN inside its BAD_ annotations (MNE's rejection by annotation)."""
    import numpy as np

    Y = raw.get_data(reject_by_annotation="NaN", verbose=False)
    bad = np.isnan(Y).any(axis=0)
    if bad.all():
        raise InputError(
            f"argument --data: {args.data} is bad throughout (BAD_ annotations cover every "
            "sample): nothing to reconstruct"
        )
    if bad.any() and not args.quiet:
        print(
            f"{int(bad.sum())} of {bad.size} samples inside bad segments (BAD_ annotations): "
            "missing observations, no estimate there",
            file=sys.stderr,
        )
    args.bad_samples = int(bad.sum())
    return Y


def _standardized(args, n_columns, n_orient):
    """How the array route standardized the columns, in words, and, when a free-orientation
    lead field is likely and nothing said which columns form a position, what to pass."""
    if args.standardize == "position":
        return (
            f"standardized per source position: {n_orient} columns of the lead field's "
            f"{n_columns} as a whole (--standardize position --n-orient {n_orient})"
        )
    how = "given" if args.standardize_given else "the default on arrays"
    said = f"standardized column by column (--standardize column, {how})"
    if args.standardize_given or n_columns % 3 or n_orient == 1:
        return said
    if n_orient == 3:  # the positions say 3 columns each
        return (
            f"{said}; the lead field has 3 columns per position (from its positions): pass "
            "--standardize position to standardize each position as a whole (sLORETA's, the "
            "study's rule; docs/model.md section 2)"
        )
    return (
        f"{said}; its {n_columns} columns could be {n_columns // 3} positions x 3 "
        "orientations: for a free-orientation lead field (x, y, z per position) pass "
        "--standardize position --n-orient 3 (the study's rule; column by column misplaces "
        "sources of oblique orientation, docs/model.md section 2), or --n-orient 1 to say "
        "each column is a position"
    )


def _whitened(Y, noise):
    """The data whitened with the noise given (over the covariance's range), for the
    units check; NaN samples stay NaN; None for a covariance its checks will refuse."""
    import numpy as np

    if "noise_std" in noise:
        return Y / noise["noise_std"]
    cov = np.asarray(noise["noise_cov"], dtype=float)
    if cov.shape != (len(Y), len(Y)) or not np.all(np.isfinite(cov)):
        return None  # refused by the reconstruction's own checks, with its message
    values, vectors = np.linalg.eigh(cov)
    kept = values > max(values.max(), 0) * 1e-10
    if not kept.any():
        return None
    return (vectors[:, kept] / np.sqrt(values[kept])).T @ Y


def _array_sfreq(args, recording):
    """The sampling rate of the array route's data: --sfreq, else the MNE file's."""
    if args.sfreq is not None:
        return args.sfreq
    if recording.evoked is not None:
        return float(recording.evoked.info["sfreq"])
    raise InputError(
        f"argument --time-constant-ms: needs the data's sampling rate, and {args.data} does "
        "not say it: give --sfreq (Hz)"
    )


def _n_orient(args, L, positions):
    """The columns per position of an array lead field: --n-orient, else from its positions."""
    if args.n_orient is not None or positions is None:
        if args.standardize == "position" and args.n_orient is None:
            raise InputError(
                f"argument --n-orient: --standardize position needs the columns per source "
                f"position, and {args.leadfield} has no positions to tell them (1 or 3)"
            )
        return args.n_orient
    components, left = divmod(L.shape[1], max(len(positions), 1))
    return components if not left and components in (1, 3) else None


def _array_noise(args, recording, Y):
    import numpy as np

    from ..io._noise_cov import baseline_matrix

    if args.noise_std is not None:
        return {"noise_std": args.noise_std}
    if args.baseline:
        if recording.times is None:
            raise InputError(f"--baseline needs the times of the samples; {args.data} has none")
        instead = "give --noise-cov or --noise-std"
        return {"noise_cov": baseline_matrix(Y, recording.times, "--baseline", instead)}
    if recording.ch_names is None:
        raise InputError("--noise-cov needs channel names in --data to match the covariance's")
    cov = _read_cov(args.noise_cov)
    missing = [name for name in recording.ch_names if name not in cov["names"]]
    if missing:
        raise InputError(f"argument --noise-cov: no entry for the channels {missing[:5]}")
    index = [cov["names"].index(name) for name in recording.ch_names]
    return {"noise_cov": cov.data[np.ix_(index, index)]}


def run(args: argparse.Namespace) -> Reconstruction:
    """Run ``skf-ref reconstruct``: read the inputs, reconstruct, write the outputs.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    skf_ref.Reconstruction
        The reconstruction.
    """
    import numpy as np

    route = _route(args)
    rec, stc, times, positions = (_mne_route if route == "mne" else _array_route)(args)
    if positions is not None and not isinstance(positions, np.ndarray):
        positions = np.concatenate(positions)
    try:
        written = _write(args, route, rec, stc, times, positions)
    except InputError as err:  # a file that appeared since the check: the flag to replace it
        raise InputError(str(err).replace("give overwrite=True", "give --overwrite")) from None
    if not args.quiet:
        names = ", ".join(str(path) for path in written)
        print(f"wrote {names}", file=sys.stderr)
    return rec


def _write(
    args: argparse.Namespace, route: str, rec: Any, stc: Any, times: Any, positions: Any
) -> list[Path]:
    """The estimate, its settings beside it and the figure; each file whole or absent."""

    from .._utils.atomic_files import atomic_path
    from ..io._files import write_reconstruction, write_stc

    # columns per position: from the positions, else as given (--n-orient 3 on arrays)
    components = rec.n_sources // len(positions) if positions is not None else args.n_orient or 1
    extra = {"log_likelihood": rec.log_likelihood, "theta0": rec.theta0, "q": rec.q}
    extra["channels"] = args.channels
    # without --overwrite, a file that appeared since the check (a second run of the same
    # command) is never replaced: each is published only where nothing is
    keep = dict(overwrite=args.overwrite)
    if args.out.suffix == ".npz":
        written = [write_reconstruction(args.out, rec, times=times, positions=positions, **keep)]
    else:
        written = write_stc(args.out, stc, **keep)
    with atomic_path(args.out.with_name(args.out.name + ".json"), **keep) as tmp:
        tmp.write_text(json.dumps(_settings(args, route, extra), indent=1, default=str) + "\n")
    if args.plot is not None:
        from ..study._plots import plot_estimate
        from ..study._plots.style import finish

        figure = plot_estimate(
            rec.amplitude(components if components in (1, 3) else 1),
            times,  # None: the axis counts samples
            positions if components in (1, 3) else None,
            title=f"SKF, exponent {args.exponent:g}, "
            + ("no smoothing" if args.smoother == "none" else args.smoother),
        )
        finish(figure, args.plot, **keep)  # written whole or not at all (atomic_path)
    return written
