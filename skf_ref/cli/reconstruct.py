"""``skf-ref reconstruct``: your own EEG in, a source estimate (or arrays) out."""

import argparse
import json
import sys
from pathlib import Path

from .._utils.checks import InputError
from ..method.settings import RECOMMENDED_SETTING
from ._args import add_skf_options, positive, report_tuning

__all__ = ["add_parser", "run"]

_EXAMPLES = """\
examples:
  skf-ref reconstruct --forward sample-fwd.fif --evoked sample-ave.fif --condition 0 \\
      --noise-cov sample-cov.fif --out sample-skf-vl.stc --plot sample-skf.png
  skf-ref reconstruct --leadfield L.npy --data Y.csv --noise-std 1e-6 --out skf.npz

The MNE route (--forward/--evoked) matches channels by name, applies the evoked's
average-reference projector to data and lead field, whitens with the noise covariance
reduced to its rank and writes an MNE source estimate (.stc, .h5) or arrays (.npz). The
array route (--leadfield/--data) runs skf_ref.reconstruct on the arrays as they are (rows
matched by name when both files name them) and writes .npz. Beside the output, NAME.json
records every setting and the package versions.
"""

_OUTPUTS = (".npz", ".stc", ".h5")


def _output(text):
    path = Path(text)
    if path.suffix not in _OUTPUTS:
        raise argparse.ArgumentTypeError(f"must end in .npz, .stc or .h5, got {text!r}")
    return path


def add_parser(subparsers):
    """Add ``reconstruct`` to the ``skf-ref`` subcommands."""
    parser = subparsers.add_parser(
        "reconstruct",
        help="the SKF on your own data: MNE files or arrays in, a source estimate out",
        description="Reconstruct EEG sources with the standardized Kalman filter.",
        epilog=_EXAMPLES,
    )
    inputs = parser.add_argument_group("inputs: --forward and --evoked, or --leadfield and --data")
    inputs.add_argument("--forward", type=Path, help="MNE forward solution (-fwd.fif)")
    inputs.add_argument("--evoked", type=Path, help="MNE evoked (-ave.fif) or a recording")
    inputs.add_argument("--condition", help="the evoked's condition (name or index)")
    inputs.add_argument("--leadfield", type=Path, help="lead field: .npy, .npz, .mat, -fwd.fif")
    inputs.add_argument("--data", type=Path, help="data: .npy, .npz, .mat, .csv, MNE formats")
    inputs.add_argument("--key", help="variable name in .npz/.mat files (data and lead field)")
    noise = parser.add_argument_group("noise: one of")
    noise.add_argument("--noise-cov", type=Path, help="MNE noise covariance (-cov.fif)")
    noise.add_argument("--noise-std", type=positive(), help="noise standard deviation (V)")
    noise.add_argument(
        "--baseline", action="store_true", help="estimate the noise from the samples at t <= 0"
    )
    model = parser.add_argument_group("the SKF")
    add_skf_options(
        model,
        exponent=RECOMMENDED_SETTING["exponent"],
        smoother=RECOMMENDED_SETTING["smoother"] or "none",
        smoother_help="RTS smoother (the paper's setting: --exponent 1.25 --smoother "
        "rts-standardized)",
    )
    model.add_argument(
        "--method",
        default="auto",
        choices=("auto", "spectral", "dense", "filterpy"),
        help="computational path",
    )
    model.add_argument(
        "--pick-ori",
        default="none",
        choices=("none", "vector"),
        help="free orientation: per-position norm ('none') or the three components",
    )
    model.add_argument(
        "--average-reference",
        action="store_true",
        help="array route: subtract the channel mean from data and lead field first",
    )
    parser.add_argument("--out", type=_output, required=True, metavar="FILE", help="output")
    parser.add_argument("--plot", type=Path, metavar="FILE", help="also draw the estimate (PNG)")
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
    return "mne" if mne_route else "arrays"


def _settings(args, route, extra):
    from .._utils.provenance import machine

    keys = ("pm_snr_db", "ep_snr_db", "exponent", "smoother", "method", "pick_ori")
    files = ("forward", "evoked", "condition", "leadfield", "data", "key", "noise_cov")
    return {
        "route": route,
        **{k: getattr(args, k) for k in keys},
        **{k: str(getattr(args, k)) for k in files if getattr(args, k) is not None},
        "noise_std": args.noise_std,
        "baseline": args.baseline,
        **extra,
        "machine": machine(),
    }


def _mne_route(args):
    import mne

    from ..io.apply import apply_skf
    from ..io.files import read_data, read_leadfield

    recording = read_data(args.evoked, condition=args.condition)
    if recording.evoked is None:
        raise InputError(f"argument --evoked: {args.evoked} is not an MNE format")
    forward = read_leadfield(args.forward).forward
    if forward is None:
        raise InputError(f"argument --forward: {args.forward} is not an MNE -fwd.fif")
    if args.noise_cov is not None:
        try:
            noise_cov = mne.read_cov(args.noise_cov, verbose=False)
        except Exception as err:  # MNE's reader raises several types for a bad file
            raise InputError(f"argument --noise-cov: {args.noise_cov}: {err}") from err
    else:
        noise_cov = "baseline" if args.baseline else None
    stc, rec = apply_skf(
        recording.evoked,
        forward,
        noise_cov,
        noise_std=args.noise_std,
        pm_snr_db=args.pm_snr_db,
        ep_snr_db=args.ep_snr_db,
        exponent=args.exponent,
        smoother=args.smoother,
        pick_ori=None if args.pick_ori == "none" else args.pick_ori,
        method=args.method,
        return_reconstruction=True,
    )
    report_tuning(args, rec.tuning)
    positions = [s["rr"][s["vertno"]] for s in forward["src"]]
    return rec, stc, recording.times, positions


def _array_route(args):

    from ..io.files import read_data, read_leadfield
    from ..method.reconstruct import reconstruct
    from ..method.tuning import choose_priors

    leadfield = read_leadfield(args.leadfield, key=args.key)
    recording = read_data(args.data, key=args.key, condition=args.condition)
    L, Y = leadfield.data, recording.data
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
    noise = _array_noise(args, recording, Y, L.shape[0])
    theta0, q, tuning = choose_priors(
        L, Y, **noise, pm_snr_db=args.pm_snr_db, ep_snr_db=args.ep_snr_db
    )
    report_tuning(args, tuning)
    rec = reconstruct(
        L,
        Y,
        **noise,
        theta0=theta0,
        q=q,
        exponent=args.exponent,
        smoother=None if args.smoother == "none" else args.smoother,
        method=args.method,
    )
    return rec, None, recording.times, leadfield.positions


def _array_noise(args, recording, Y, n_channels):
    import mne
    import numpy as np

    if args.noise_std is not None:
        return {"noise_std": args.noise_std}
    if args.baseline:
        if recording.times is None:
            raise InputError(f"--baseline needs the times of the samples; {args.data} has none")
        baseline = Y[:, recording.times <= 0]
        if baseline.shape[1] < n_channels:
            raise InputError(
                f"--baseline needs at least {n_channels} samples at t <= 0 (one per channel), "
                f"got {baseline.shape[1]}"
            )
        return {"noise_cov": baseline @ baseline.T / baseline.shape[1]}
    if recording.ch_names is None:
        raise InputError("--noise-cov needs channel names in --data to match the covariance's")
    try:
        cov = mne.read_cov(args.noise_cov, verbose=False)
    except Exception as err:  # MNE's reader raises several types for a bad file
        raise InputError(f"argument --noise-cov: {args.noise_cov}: {err}") from err
    missing = [name for name in recording.ch_names if name not in cov["names"]]
    if missing:
        raise InputError(f"argument --noise-cov: no entry for the channels {missing[:5]}")
    index = [cov["names"].index(name) for name in recording.ch_names]
    return {"noise_cov": cov.data[np.ix_(index, index)]}


def run(args):
    """Run ``skf-ref reconstruct``; returns the reconstruction."""
    import numpy as np

    from .._utils.atomic_files import atomic_path
    from ..io.files import write_reconstruction, write_stc

    route = _route(args)
    rec, stc, times, positions = (_mne_route if route == "mne" else _array_route)(args)
    if positions is not None and not isinstance(positions, np.ndarray):
        positions = np.concatenate(positions)
    components = rec.n_sources // len(positions) if positions is not None else 1
    amplitude = rec.amplitude(components if components in (1, 3) else 1)
    extra = {"log_likelihood": rec.log_likelihood, "theta0": rec.theta0, "q": rec.q}
    if args.out.suffix == ".npz":
        written = [write_reconstruction(args.out, rec, times=times, positions=positions)]
    else:
        written = write_stc(args.out, stc)
    with atomic_path(args.out.with_name(args.out.name + ".json")) as tmp:
        tmp.write_text(json.dumps(_settings(args, route, extra), indent=1, default=str) + "\n")
    if args.plot is not None:
        from ..study.plots import plot_estimate

        with atomic_path(args.plot) as tmp:
            plot_estimate(
                amplitude,
                times if times is not None else np.arange(rec.n_times),
                positions if components in (1, 3) else None,
                title=f"SKF, exponent {args.exponent:g}, "
                + ("no smoothing" if args.smoother == "none" else args.smoother),
                path=tmp,
            )
    if not args.quiet:
        names = ", ".join(str(path) for path in written)
        print(f"wrote {names}", file=sys.stderr)
    return rec
