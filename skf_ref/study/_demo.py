"""The P20/N20 demo as a library function: what ``skf-ref demo`` runs, from data to figures.

One simulated data set of the paper's scenario (a deep thalamic and a superficial cortical
dipole, 2 ms apart) and its control, the same noise with the deep source left out, each
reconstructed three ways:

- the SKF at the chosen setting (default: the package's, which the evidence study v3's
  pre-registered rule chose, validation/reproduce/PREREGISTRATION.md: exponent 0.5 with
  the ``"rts-smoothed-weights"`` smoother, :data:`skf_ref.RECOMMENDED_SETTING`, each
  source position standardized as a whole, PM-SNR 0 dB and the stationary AR(1) evolution
  prior with its time constant chosen by the data's marginal likelihood at the
  simulation's 10 kHz; ``ep_snr_db`` runs the paper's random walk instead);
- the SKF at the paper's setting (exponent 1.25, ``"rts-standardized"``,
  :data:`skf_ref.PAPER_SETTING`) with the paper's priors for it, PM-SNR 0 dB and the random
  walk at EP-SNR 20 dB (when the first runs the walk with ``"auto"`` priors, the ones
  chosen for the first);
- MNE's sLORETA (``mne.minimum_norm``, lambda2 = 1/9, the same noise covariance).

The metrics say, for each, where the peaks are and whether the thalamus "detects" a source
with the deep source present and absent: its level at 1.5 ms above a threshold calibrated,
for that method, head and noise level, on simulated runs without a thalamic source (noise
alone; one cortical source at a random position), so that at most 5 % of them exceed it
(:mod:`skf_ref.study._detection`; cortex + thalamus source spaces only, the volume grid has
no thalamus). ``comparison.png`` shows it on one slide. One data set shows what one data set
shows: the rates over many are in the study's report. The head is the realistic one (a
three-layer BEM of MNE's "sample" subject) when MNE's testing dataset is at hand, the sphere
otherwise.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._utils.atomic_files import atomic_path
from .._utils.checks import InputError, check_choice, check_instance, check_int, check_path
from .._utils.log import logger, progress, verbosity
from ..method import PAPER_SETTING, RECOMMENDED_SETTING
from ..method._priors import DEFAULT_TIME_CONSTANT_MS
from ..method._search import check_one_evolution_prior, check_time_constant
from ..method._settings import STANDARDIZATIONS, check_smoother
from ._metrics import COLUMNS as _SUMMARY_COLUMNS
from ._sizes import DEFAULT_POSITIONS

if TYPE_CHECKING:
    import pandas as pd

    from ..method import Reconstruction, TuneResult
    from ._head import HeadModel
    from ._scenario import Simulation

__all__ = [
    "COLUMNS",
    "DATA",
    "DETECTION_COLUMNS",
    "HEADS",
    "OUTPUTS",
    "RENAMED",
    "Demo",
    "run_demo",
]

#: The two data sets: label -> the sources active in it (the same noise draws).
DATA = {"present": ("deep", "superficial"), "deep absent": ("superficial",)}
#: Which head: the realistic one if MNE's testing dataset is found, or either by name.
HEADS = ("auto", "realistic", "sphere")
#: The files a demo writes into its output folder.
OUTPUTS = (
    "comparison.png",
    "metrics.csv",
    "metrics_columns.csv",
    "projections_paper.png",
    "projections_skf.png",
    "reconstruction.npz",
    "settings.json",
    "time_courses_paper.png",
    "time_courses_skf.png",
)
_SLORETA_LAMBDA2 = 1.0 / 9.0
#: The paper's priors for its setting (PM-SNR, EP-SNR of the random walk, in dB), as the
#: study runs it.
_PAPER_PRIORS = (0.0, 20.0)
#: An SKF's priors: theta0, q and the transition (``A = transition I``; 1: the random walk).
_Priors = tuple[float, float, float]
_SUFFIX = {"present": "", "deep absent": "_deep_absent"}  # of the arrays' names
#: The summary's metrics the demo names otherwise (:func:`skf_ref.study._metrics.summarize` ->
#: metrics.csv): "within 6 dB of the global maximum" says where an estimate is largest, not
#: whether a source is there; a cortical source alone lifts the thalamus that high in most
#: estimates, so the deep region's reading holds without the deep source too. Only
#: ``deep_detected_calibrated`` answers whether the deep source was detected.
RENAMED = {"deep_detected": "deep_within_6db", "superficial_detected": "superficial_within_6db"}
_MEANINGS = {
    "deep_within_6db": "deep region within 6 dB of the global maximum at 1.5 ms (where the "
    "estimate is largest, not a detection: see deep_detected_calibrated)",
    "superficial_within_6db": "superficial region within 6 dB of the global maximum at 2.5 ms",
    "separation": "deep region within 6 dB of the global maximum at 1.5 ms, superficial "
    "region at 2.5 ms, and deep region not at 2.5 ms",
}
#: The demo's metrics (metrics.csv's rows, metrics_columns.csv's lines): the summary's
#: (:data:`skf_ref.study._metrics.COLUMNS`), the 6 dB readings named by :data:`RENAMED`.
COLUMNS = tuple(
    (new, _MEANINGS.get(new, meaning), unit, "n/a" if new == "deep_within_6db" else better)
    for new, meaning, unit, better in (
        (RENAMED.get(name, name), *rest) for name, *rest in _SUMMARY_COLUMNS
    )
)
#: The metrics of calibrated detection (cortex + thalamus heads), as :data:`COLUMNS`.
DETECTION_COLUMNS = (
    ("thalamic_level", "largest amplitude over the thalamus at 1.5 ms", "the method's", "n/a"),
    ("detection_threshold", "the method's threshold: at most 5 % of 50 simulated runs of "
     "noise alone, and of 50 with one cortical source at a random position and orientation, "
     "exceed it (the demo's head and noise level)", "the method's", "n/a"),
    ("deep_detected_calibrated", "`thalamic_level` above `detection_threshold`", "bool",
     "true with the deep source, false without"),
)  # fmt: skip


@dataclass(frozen=True, eq=False)
class Demo:
    """What :func:`run_demo` computed.

    Each parameter is an attribute of the same name.

    Parameters
    ----------
    head : HeadModel
        The head the data were simulated on and reconstructed in.
    simulations : dict
        :data:`DATA` label -> :class:`skf_ref.study._scenario.Simulation`.
    methods : dict
        Method key (``"skf"``, ``"paper"``, ``"sLORETA"``) -> its label in tables and figures.
    reconstructions : dict
        ``(key, data)`` -> :class:`skf_ref.Reconstruction` of the two SKF settings.
    estimates : dict
        ``(key, data)`` -> amplitude, ndarray shape (n_positions, n_times): the norm over
        the three orientations, every method.
    metrics : pandas.DataFrame
        Rows: :data:`COLUMNS`' metrics, then on a cortex + thalamus head
        :data:`DETECTION_COLUMNS`'; columns ``"<key>, <data>"``.
    settings : dict
        Everything that produced the results (JSON-ready).
    """

    head: HeadModel = field(repr=False)
    simulations: dict[str, Simulation] = field(repr=False)
    methods: dict[str, str]
    reconstructions: dict[tuple[str, str], Reconstruction] = field(repr=False)
    estimates: dict[tuple[str, str], np.ndarray] = field(repr=False)
    metrics: pd.DataFrame = field(repr=False)
    settings: dict[str, Any] = field(repr=False)


def run_demo(
    out: str | os.PathLike | None = None,
    *,
    snr_db: float = 30.0,
    seed: int = 0,
    head: str = "auto",
    source_space: str = "anatomical",
    montage: str = "biosemi64",
    n_positions: int | None = None,
    testing_data: str | os.PathLike | None = None,
    cache_dir: str | os.PathLike | None = None,
    pm_snr_db: float | str | tuple[float, float] = 0.0,
    ep_snr_db: float | str | tuple[float, float] | None = None,
    time_constant_ms: float | str | tuple[float, float] = DEFAULT_TIME_CONSTANT_MS,
    exponent: float = RECOMMENDED_SETTING["exponent"],
    smoother: str | None = RECOMMENDED_SETTING["smoother"],
    standardize: str = "position",
    overwrite: bool = False,
    verbose: bool | str | int | None = None,
) -> Demo:
    """Simulate the P20/N20 scenario and its control; reconstruct them three ways.

    Parameters
    ----------
    out : path-like or None
        Folder to write ``OUTPUTS`` into (created; checked before any computation);
        None: nothing is written.
    snr_db : float
        Peak SNR of the data (dB).
    seed : int
        Noise seed.
    head : {"auto", "realistic", "sphere"}
        "auto": realistic if MNE's testing dataset is found (never downloaded).
    source_space : {"anatomical", "volume"}
        Cortex + thalamus, or a grid filling the brain compartment.
    montage : str
        An MNE built-in montage.
    n_positions : int or None
        Positions of the sphere's volume grid (only there; default 3000).
    testing_data, cache_dir : path-like or None
        MNE's testing dataset folder, and where the realistic head's forwards are cached.
    pm_snr_db : float or "auto" or (float, float)
        The first SKF's PM-SNR (docs/model.md §4); "auto" or a range: chosen by the marginal
        likelihood of the data with both sources; the control and the null runs of the
        calibration reuse the priors chosen.
    ep_snr_db : float or "auto" or (float, float) or None
        Given: the first SKF runs the paper's random walk at this EP-SNR instead of the
        AR(1) prior (the package's default before the evidence study v3 was the walk at 0
        dB). If the walk's priors are chosen by the data ("auto"), the paper's setting runs
        at them too; otherwise at its own, PM-SNR 0 dB and the walk at EP-SNR 20 dB. None
        (default): the AR(1) prior.
    time_constant_ms : float or "auto" or (float, float)
        The first SKF's stationary AR(1) prior (:func:`skf_ref.ar1_priors`): its time
        constant in ms at the simulation's sampling rate, or chosen by the data's marginal
        likelihood ("auto", the default:
        1 to 1000 ms; or a range; None is the default too). Give another value or
        ``ep_snr_db``, not both. The paper's setting keeps its own priors.
    exponent : float
        Standardization exponent of the first SKF (the paper's setting is the second).
    smoother : {"rts-smoothed-weights", None, "rts-standardized", "rts-state"}
        Its smoother.
    standardize : {"position", "column"}
        Its standardization: each source position's three orientations as a whole (the
        default, the study's rule's) or each column on its own (the paper's, which the
        paper's setting keeps).
    overwrite : bool
        Replace files of ``out`` named like ``OUTPUTS``. False: such a file is refused
        before any computation (and one that appears meanwhile is never replaced).
    verbose : bool or str or int or None
        Progress on the ``"skf_ref"`` logger, as MNE's ``verbose``.

    Returns
    -------
    Demo
        The head, the data, every reconstruction and estimate, the metrics and the settings.
    """
    import pandas as pd

    from . import _metrics as metrics
    from ._detection import calibrate
    from ._head import find_testing_data, make_head
    from ._scenario import p20n20_scenario, simulate

    check_choice("head", head, HEADS)
    smoother = check_smoother(smoother)
    check_choice("standardize", standardize, STANDARDIZATIONS)
    seed = check_int("seed", seed, minimum=0)
    check_instance("overwrite", overwrite, bool, "True or False")
    default_tau = time_constant_ms is None or (
        isinstance(time_constant_ms, str) and time_constant_ms == DEFAULT_TIME_CONSTANT_MS
    )
    if ep_snr_db is not None and not default_tau:
        check_one_evolution_prior(ep_snr_db, time_constant_ms)  # both given: an error
    if ep_snr_db is not None:
        tau = None  # the paper's random walk
    else:  # the AR(1) prior
        tau = check_time_constant(DEFAULT_TIME_CONSTANT_MS if default_tau else time_constant_ms)
    folder = _output_folder(out, overwrite)
    with verbosity(verbose):
        testing = None if head == "sphere" else find_testing_data(testing_data)
        if head == "realistic" and testing is None:
            raise InputError(
                "head='realistic' needs MNE's testing dataset: give testing_data (the folder "
                "mne.datasets.testing.data_path() returns); MNE did not find it"
            )
        if n_positions is not None and (testing is not None or source_space != "volume"):
            raise InputError(
                "n_positions sizes the sphere's volume grid only (head='sphere', "
                "source_space='volume'); the other source spaces have fixed spacings"
            )
        if testing is None and source_space == "volume":
            _check_size(n_positions or DEFAULT_POSITIONS, montage)
        with progress("head model"):
            model = make_head(
                "sphere" if testing is None else "bem",
                source_space,
                n_positions=n_positions or DEFAULT_POSITIONS,
                montage=montage,
                testing_data=testing,
                cache_dir=cache_dir,
            )
        logger.info("head: %s", model.description)
        scenario = p20n20_scenario()
        sims = {
            data: simulate(model, scenario, snr_db, seed, sources=sources)
            for data, sources in DATA.items()
        }
        setting = {"exponent": exponent, "smoother": smoother, "standardize": standardize}
        setting["n_orient"] = 3 if standardize == "position" else None  # free orientation
        with progress("SKF and sLORETA"):
            present = sims["present"]
            priors, tuning = _priors(model, present, scenario.sfreq, pm_snr_db, ep_snr_db, tau)
            shared = tuning is not None and tau is None  # the walk's priors chosen by the data
            paper_priors = priors if shared else _priors(model, present, None, *_PAPER_PRIORS)[0]
            runs = {"skf": (priors, setting), "paper": (paper_priors, PAPER_SETTING)}
            reconstructions = _skf(model, sims, runs)
            estimates = {key: rec.amplitude(3) for key, rec in reconstructions.items()}
            sloreta = _sloreta_method(model, sims["present"])
            estimates.update({("sLORETA", data): sloreta(sim.Y) for data, sim in sims.items()})
        truth = sims["present"].truth
        table = pd.DataFrame(
            {
                f"{key}, {data}": metrics.summarize(a, model, truth)
                for (key, data), a in estimates.items()
            }
        ).rename(index=RENAMED)
        if source_space == "anatomical":
            with progress("thresholds calibrated on null runs"):
                methods_ = _methods(model, sims["present"], runs, sloreta)
                thresholds = calibrate(model, sims["present"], methods_, seed=seed)
            _detections(table, model, estimates, thresholds, truth.peak_indices[0])
        methods = {
            "skf": _label(setting),
            "paper": _label(PAPER_SETTING) + " (paper)",
            "sLORETA": "sLORETA (MNE), λ² = 1/9",
        }
        evolution = "random walk" if tau is None else "ar1"
        settings = _settings(model, present, setting, evolution, priors, tuning, snr_db, seed)
        settings.update(
            sfreq=scenario.sfreq,
            pm_snr_db=pm_snr_db,
            ep_snr_db=ep_snr_db,
            time_constant_ms=tau,
            positions_requested=n_positions,
            paper_pm_snr_db=tuning.pm_snr_db if shared and tuning else _PAPER_PRIORS[0],
            paper_ep_snr_db=tuning.ep_snr_db if shared and tuning else _PAPER_PRIORS[1],
            paper_theta0=paper_priors[0],
            paper_q=paper_priors[1],
        )
        demo = Demo(model, sims, methods, reconstructions, estimates, table, settings)
        if folder is not None:
            with progress("figures and files"):
                write(demo, folder, overwrite)
    return demo


def _check_size(n_positions: int, montage: str) -> None:
    """Refuse a sphere grid whose model and six outputs do not fit in memory, before work."""
    from .._utils import memory
    from ._head import check_size

    n = 3 * n_positions  # four SKF runs, each with its model and z and weights in memory
    outputs = 4 * memory.spectral_memory(n, 64, 41) + 8 * 8 * n * 41
    check_size(n_positions, montage, extra=outputs, name="n_positions")


def _output_folder(out: str | os.PathLike | None, overwrite: bool = True) -> Path | None:
    """``out`` as a Path, refused before any work if it cannot become a folder, or if it
    holds a file named like an output and ``overwrite`` is False."""
    if out is None:
        return None
    folder = check_path("out", out)
    existing = next(p for p in (folder, *folder.parents) if p.exists())
    if not existing.is_dir():
        raise InputError(f"out must be a folder, got {str(folder)!r}; {str(existing)!r} is a file")
    there = [name for name in OUTPUTS if os.path.lexists(folder / name)]
    if there and not overwrite:
        raise InputError(
            f"out={str(folder)!r} holds {', '.join(there)}: the demo writes files of these "
            "names; "
            "give overwrite=True to replace them, or another folder"
        )
    return folder


def _label(setting: Mapping[str, Any]) -> str:
    smoother = setting["smoother"] or "no smoother"
    standardize = f", {setting['standardize']}" if "standardize" in setting else ""
    return f"SKF, exponent {setting['exponent']:g}, {smoother}{standardize}"


def _priors(
    head: HeadModel,
    sim: Simulation,
    sfreq: float | None,
    pm_snr_db: Any,
    ep_snr_db: Any,
    time_constant_ms: Any = None,
) -> tuple[_Priors, TuneResult | None]:
    """theta0, q and the transition: the random walk at ``ep_snr_db``, or the AR(1) prior at
    ``time_constant_ms`` (at ``sfreq``); any of them ``"auto"`` is chosen by the data.

    A prior chosen on an end of its search range is logged and recorded (the settings'
    ``tuned_at_bound``), as the evidence study records it, instead of :func:`skf_ref.tune`'s
    warning to widen the range: the demo runs the default's range as the study's rule does.
    """
    import warnings

    from ..method._tuning import choose_priors

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "tune: .* lies on the .* bound", UserWarning)
        theta0, q, transition, tuning = choose_priors(
            head.leadfield,
            sim.Y,
            noise_std=sim.sigma,
            pm_snr_db=pm_snr_db,
            ep_snr_db=ep_snr_db,
            time_constant_ms=time_constant_ms,
            sfreq=None if time_constant_ms is None else sfreq,
        )
    if tuning is not None:
        logger.info("priors chosen by the data: %s", _describe_tuning(tuning))
    return (theta0, q, transition), tuning


def _describe_tuning(tuning: TuneResult) -> str:
    """The priors the data chose, in words: PM-SNR, the EP-SNR or the time constant (with
    its transition), the ends of their search ranges they lie on, the log-likelihood.

    Parameters
    ----------
    tuning : TuneResult
        What :func:`skf_ref.tune` chose.

    Returns
    -------
    str
    """
    if tuning.time_constant_ms is None:
        evolution = f"EP-SNR {tuning.ep_snr_db:.2f} dB"
    else:
        evolution = (
            f"time constant {tuning.time_constant_ms:.3g} ms (transition {tuning.transition:.4f})"
        )
    bounds = "".join(
        f"; {name} on the {end} end of its search range" for name, end in tuning.at_bound.items()
    )
    return (
        f"PM-SNR {tuning.pm_snr_db:.2f} dB, {evolution}{bounds} "
        f"(log-likelihood {tuning.log_likelihood:.6g})"
    )


def _skf(
    head: HeadModel,
    sims: Mapping[str, Simulation],
    runs: Mapping[str, tuple[_Priors, Mapping[str, Any]]],
) -> dict[tuple[str, str], Reconstruction]:
    from ..method import reconstruct

    out: dict[tuple[str, str], Reconstruction] = {}
    for key, ((theta0, q, transition), setting) in runs.items():
        for data, sim in sims.items():
            rec = reconstruct(
                head.leadfield,
                sim.Y,
                noise_std=sim.sigma,
                theta0=theta0,
                q=q,
                transition=transition,
                **setting,
            )
            _ = rec.z, rec.weights  # computed (and checked finite) before any file is written
            out[key, data] = rec
    return out


def _sloreta_method(head: HeadModel, sim: Simulation) -> Callable[[np.ndarray], np.ndarray]:
    """MNE's sLORETA (lambda2 1/9) with the noise covariance of ``sim``, for any data."""
    from dataclasses import replace

    from mne.minimum_norm import prepare_inverse_operator

    from ._baselines import apply_minimum_norm, inverse_operator

    inverse = prepare_inverse_operator(
        inverse_operator(head, sim), 1, _SLORETA_LAMBDA2, "sLORETA", verbose=False
    )

    def sloreta(Y: np.ndarray) -> np.ndarray:
        return apply_minimum_norm(
            head, replace(sim, Y=Y), inverse, "sLORETA", _SLORETA_LAMBDA2, prepared=True
        )

    return sloreta


def _methods(
    head: HeadModel,
    sim: Simulation,
    runs: Mapping[str, tuple[_Priors, Mapping[str, Any]]],
    sloreta: Callable[[np.ndarray], np.ndarray],
) -> dict[str, Callable[[np.ndarray], np.ndarray]]:
    """The demo's three methods as maps from data to position amplitudes (the priors fixed)."""
    from ..method import reconstruct

    def skf(priors: _Priors, options: Mapping[str, Any]) -> Callable[..., np.ndarray]:
        theta0, q, transition = priors

        def method(Y: np.ndarray) -> np.ndarray:
            rec = reconstruct(
                head.leadfield,
                Y,
                noise_std=sim.sigma,
                theta0=theta0,
                q=q,
                transition=transition,
                **options,
            )
            return rec.amplitude(3)

        return method

    return {**{key: skf(*run) for key, run in runs.items()}, "sLORETA": sloreta}


def _detections(
    table: pd.DataFrame,
    head: HeadModel,
    estimates: Mapping[tuple[str, str], np.ndarray],
    thresholds: Mapping[str, float],
    peak: int,
) -> None:
    """Add each column's thalamic level, its method's threshold and the verdict to ``table``."""
    from ._detection import thalamic_level
    from ._sources import position_structures

    thalamus = position_structures(head) == "thalamus"
    for (key, data), amplitude in estimates.items():
        level = float(thalamic_level(amplitude[:, peak], thalamus))
        column = f"{key}, {data}"
        table.loc["thalamic_level", column] = level
        table.loc["detection_threshold", column] = thresholds[key]
        table.loc["deep_detected_calibrated", column] = bool(level > thresholds[key])


def _settings(
    head: HeadModel,
    sim: Simulation,
    setting: Mapping[str, Any],
    evolution: str,
    priors: _Priors,
    tuning: TuneResult | None,
    snr_db: float,
    seed: int,
) -> dict[str, Any]:
    from .._utils.provenance import machine

    return {
        "snr_db": snr_db,
        "evolution_prior": evolution,
        "priors_chosen_by_the_data": tuning is not None,
        "tuned_pm_snr_db": None if tuning is None else tuning.pm_snr_db,
        "tuned_ep_snr_db": None if tuning is None else tuning.ep_snr_db,
        "tuned_time_constant_ms": None if tuning is None else tuning.time_constant_ms,
        "tuned_at_bound": {} if tuning is None else dict(tuning.at_bound),
        "exponent": setting["exponent"],
        "smoother": setting["smoother"],
        "standardize": setting["standardize"],
        "paper_setting": dict(PAPER_SETTING),
        "sloreta_lambda2": _SLORETA_LAMBDA2,
        "data": {label: list(sources) for label, sources in DATA.items()},
        "n_positions": head.n_positions,
        "montage": head.montage,
        "seed": seed,
        "sigma": sim.sigma,
        "theta0": priors[0],
        "q": priors[1],
        "transition": priors[2],
        "head": head.description,
        "head_kind": "realistic" if head.conductor_kind == "bem" else "sphere",
        "conductor": head.conductor_kind,
        "source_space": head.source_space,
        "sources_moved_mm": list(sim.truth.moved_mm),
        "machine": machine(),
    }


def write(demo: Demo, out: str | os.PathLike, overwrite: bool = True) -> None:
    """Write a demo's ``OUTPUTS`` into a folder, each file atomically.

    Parameters
    ----------
    demo : Demo
        What :func:`run_demo` returned.
    out : path-like
        The folder (created if needed).
    overwrite : bool
        Replace files of these names there. False: one there is refused before anything
        is written, and one that appears meanwhile stays as it is (an error).
    """
    import pandas as pd

    folder = Path(out)
    _output_folder(folder, overwrite)  # refused if it cannot become a folder
    folder.mkdir(parents=True, exist_ok=True)
    keep = dict(overwrite=overwrite)  # never replace a file that appeared meanwhile
    present = demo.simulations["present"]
    arrays = {}
    for (key, data), rec in demo.reconstructions.items():
        arrays[f"z_{key}{_SUFFIX[data]}"] = rec.z
    for data, sim in demo.simulations.items():
        arrays[f"amplitude_sloreta{_SUFFIX[data]}"] = demo.estimates["sLORETA", data]
        arrays[f"Y{_SUFFIX[data]}"] = sim.Y
    with atomic_path(folder / "reconstruction.npz", **keep) as tmp:
        np.savez_compressed(
            tmp,
            **arrays,
            weights=demo.reconstructions["skf", "present"].weights,
            positions=demo.head.positions,
            times=present.times,
            true_positions=present.truth.positions,
            true_waveforms=present.truth.waveforms,
        )
    with atomic_path(folder / "settings.json", **keep) as tmp:
        tmp.write_text(json.dumps(demo.settings, indent=1) + "\n")
    with atomic_path(folder / "metrics.csv", **keep) as tmp:
        demo.metrics.to_csv(tmp, index_label="metric")
    with atomic_path(folder / "metrics_columns.csv", **keep) as tmp:
        calibrated = "detection_threshold" in demo.metrics.index
        rows = [*COLUMNS, *(DETECTION_COLUMNS if calibrated else ())]
        columns = pd.DataFrame(rows, columns=["metric", "meaning", "unit", "better"])
        columns.to_csv(tmp, index=False)
    _figures(demo, folder, keep)


def _figures(demo: Demo, out: Path, keep: dict[str, bool]) -> None:
    from . import _plots as plots

    present = demo.simulations["present"]
    truth = present.truth
    estimates = {
        (demo.methods[key], data): amplitude for (key, data), amplitude in demo.estimates.items()
    }
    title = (
        f"Deep source present and absent, {present.snr_db:g} dB, seed "
        f"{demo.settings['seed']}: coronal MIP at 1.5 ms (the deep peak)"
    )
    thresholds = None
    if "detection_threshold" in demo.metrics.index:
        row = demo.metrics.loc["detection_threshold"]
        thresholds = {demo.methods[c.split(", ", 1)[0]]: float(v) for c, v in row.items()}
        title += "\ndetected: the thalamus above a threshold 5 % of null runs exceed"
    with atomic_path(out / "comparison.png", **keep) as tmp:
        plots.plot_comparison(
            estimates, demo.head, truth, absent={"deep absent": ("deep",)}, title=title,
            path=tmp, thresholds=thresholds,
        )  # fmt: skip
    for key in ("skf", "paper"):
        rec = demo.reconstructions[key, "present"]
        with atomic_path(out / f"time_courses_{key}.png", **keep) as tmp:
            plots.plot_time_courses(rec, demo.head, truth, title=demo.methods[key], path=tmp)
        with atomic_path(out / f"projections_{key}.png", **keep) as tmp:
            plots.plot_average_reconstruction(
                rec,
                demo.head,
                truth,
                title=f"{demo.methods[key]}, {present.snr_db:g} dB",
                path=tmp,
            )
