"""The SKF beside MNE's inverse methods, on identical simulations, with the sources absent.

Every condition (a cell of the 2 x 2 design with white noise, and the real-noise condition)
runs, at each noise level and seed, three data sets with the same noise draws: both
sources, the deep source alone and the superficial source alone. Each data set goes through

- the twelve SKF settings (exponent 0.5, 1, 1.25, 1.5; no smoother, ``rts-standardized``,
  ``rts-state``) at the paper's tuned priors (EP 20 / PM 0 dB), the way the sweeps run
  them (one spectral model per noise level), and on the scored seeds :data:`EXTRA_SKF`
  (exponent 0.5 without smoothing at the paper's unsmoothed priors, EP 0 / PM 0 dB);
- MNE's minimum norm, dSPM, sLORETA and eLORETA (``mne.minimum_norm``, free orientation,
  no depth weighting, as the SKF has none; lambda2 = 1/9, lambda2 = 10^(-SNR/10) from
  the run's true peak SNR, and the lambda2 matched to the SKF's PM-SNR of 0 dB), one
  prepared operator per noise level, method and lambda2;
- LCMV (``mne.beamformer.make_lcmv``, free orientation, unit-noise-gain weights,
  regularization :data:`LCMV_REG` = 0.05 of the mean eigenvalue), from the run's data
  covariance: the second moment of the run's 41 samples, Y Y^T / T;
- MxNE (``mne.inverse_sparse.mixed_norm``, free orientation, MNE's default depth 0.9),
  alpha fixed at :data:`MXNE_ALPHA` = 50 % of alpha_max. **This rule was written down
  before any MxNE number was computed**: the middle of MNE's 0-100 scale, near the 55 % of
  MNE's own MxNE examples; SURE (``alpha="sure"``) took 7.7 s per run against 0.4 s, too
  slow for the report's time budget.

Every method uses the noise covariance the data were drawn with (sigma^2 I for white noise;
the scaled real covariance, average-referenced, for the real-noise condition) and the
average reference (MNE's projector). The SKF takes white noise as ``noise_std = sigma`` on
the average-referenced lead field, exactly as the sweeps do, and real noise whitened
(``eigh`` of the covariance, its null direction dropped). Every method's amplitude is the
norm over the three orientations; the metrics are :func:`skf_ref.study.metrics.summarize`'s.

The choice seeds (:data:`recommend.CHOICE_SEEDS`) run the SKF settings only, in the realistic
cortex + thalamus cell with white noise: the recommendation rule reads them, no table does.
Results are resumable: one file per condition, noise level and seed set.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from itertools import product
from pathlib import Path

import numpy as np
import pandas as pd

from skf_ref._utils.atomic_files import atomic_path
from skf_ref.study.baselines import MINIMUM_NORM_METHODS

from .recommend import CHOICE_SEEDS
from .settings import EXPONENTS, MONTAGE, NOISE_LEVELS, SMOOTHERS, TUNED_PRIOR

__all__ = [
    "BASELINES",
    "Condition",
    "LCMV_REG",
    "MXNE_ALPHA",
    "baseline_files",
    "baseline_jobs",
    "conditions",
    "describe",
    "read_baselines",
]

#: Folder of the results files, relative to the report folder.
BASELINES = "baselines"
#: LCMV's regularization (fraction of the data covariance's mean eigenvalue).
LCMV_REG = 0.05
#: MxNE's alpha, % of alpha_max (fixed before any run).
MXNE_ALPHA = 50.0
#: The lambda2 rules: label -> lambda2 from the peak SNR (dB).
LAMBDA2 = {
    "1/9": lambda snr_db: 1.0 / 9.0,
    "SNR": lambda snr_db: 10.0 ** (-snr_db / 10.0),
    "matched": lambda snr_db: MATCHED_LAMBDA2,
}
#: MNE's lambda2 matched to the SKF's PM-SNR of 0 dB: 10^(-PM/10) r / n, with the whitener's
#: rank r = n - 1 (the average reference) on the 64 BioSemi or the 59 sample electrodes: the
#: value for 64 channels; the real-noise condition's 59 channels give 0.983 (0.01 dB apart).
MATCHED_LAMBDA2 = 63.0 / 64.0
#: SKF settings beyond the twelve at EP 20 / PM 0 dB, scored only (not the old rule's
#: candidates): label -> (exponent, smoother, EP-SNR, PM-SNR). The paper's unsmoothed priors.
EXTRA_SKF = {"0.5/none/EP0-PM0": (0.5, None, 0.0, 0.0)}
#: The three data sets: label -> sources simulated.
DATA = {"both": ("deep", "superficial"), "deep": ("deep",), "superficial": ("superficial",)}
#: The columns of a results file.
COLUMNS = (
    "condition",
    "snr_db",
    "seed",
    "data",
    "method",
    "setting",
    "deep_region_db",
    "deep_level",
    "deep_epoch_db",
    "superficial_region_db",
    "deep_error_mm",
    "superficial_error_mm",
    "run_s",
    "prep_s",
)
#: Seeds in the realistic cortex + thalamus conditions (at least 20 for the ROC tables).
WIDE_SEEDS = 20


@dataclass(frozen=True)
class Condition:
    """A head and a kind of noise the baselines run on.

    Attributes
    ----------
    name : str
        Folder name (the cell's, or ``"bem-anatomical-real-noise"``).
    cell : Cell
    montage : str
    noise : str
        ``"white"`` or ``"head"`` (the head's own noise covariance).
    wide : bool
        Whether its tables take :data:`WIDE_SEEDS` seeds.
    """

    name: str
    cell: object
    montage: str
    noise: str
    wide: bool

    @property
    def title(self):
        """E.g. ``"BEM, cortex + thalamus, real noise (60 electrodes)"``."""
        if self.noise == "head":
            return f"{self.cell.title}, the sample subject's electrodes and real noise"
        return self.cell.title


def conditions(settings):
    """The conditions a report run computes: every cell, and the real-noise condition.

    The main condition (the rule's, with :data:`WIDE_SEEDS` seeds) is the realistic head with
    cortex + thalamus, or without MNE's testing dataset the sphere with cortex + thalamus.
    A ``--quick`` run computes the main condition and the real-noise one only.
    """
    main = "bem-anatomical" if settings.realistic else "sphere-anatomical"
    out = [
        Condition(cell.name, cell, MONTAGE, "white", cell.name == main)
        for cell in settings.cells
        if cell.name == main or not settings.quick
    ]
    if settings.realistic:
        cell = next(c.cell for c in out if c.wide)
        out.append(Condition("bem-anatomical-real-noise", cell, "sample", "head", True))
    return out


def describe(settings):
    """What the baselines' results depend on besides the code (for the manifest)."""
    return dict(
        conditions={
            c.name: [c.montage, c.noise, scored_seeds(c, settings)[-1] + 1]
            for c in conditions(settings)
        },
        choice_seeds=choice_seeds(settings),
        skf=[list(EXPONENTS), list(SMOOTHERS), list(TUNED_PRIOR), list(EXTRA_SKF)],
        mne=[list(MINIMUM_NORM_METHODS), list(LAMBDA2), LCMV_REG, MXNE_ALPHA],
    )


def scored_seeds(condition, settings):
    """The seeds a condition's tables score (0 .. n - 1)."""
    wide = condition.wide and not settings.quick
    return list(range(max(settings.seeds, WIDE_SEEDS) if wide else settings.seeds))


def choice_seeds(settings):
    """The seeds the recommendation rule reads (disjoint from every scored seed)."""
    return list(CHOICE_SEEDS)[: settings.seeds if settings.quick else None]


def _tasks(settings):
    """(condition, noise level, seeds, with the baselines, file name) of every results file."""
    tasks = []
    for condition in conditions(settings):
        for snr in NOISE_LEVELS:
            seeds = scored_seeds(condition, settings)
            tasks.append((condition, snr, seeds, True, f"{condition.name}/snr{snr:g}.csv"))
            if condition.wide and condition.noise == "white":
                tasks.append(
                    (condition, snr, choice_seeds(settings), False, f"choice/snr{snr:g}.csv")
                )
    return tasks


def baseline_files(settings):
    """Every results file of the baselines, relative to the report folder."""
    return [f"{BASELINES}/{task[-1]}" for task in _tasks(settings)]


# --------------------------------------------------------------------------- one noise level


def _whitener(noise_cov):
    """W with W C W^T = I on the covariance's range (its null direction dropped)."""
    lam, U = np.linalg.eigh(0.5 * (noise_cov + noise_cov.T))
    keep = lam > lam.max() * 1e-10
    return (U[:, keep] / np.sqrt(lam[keep])).T


class _Timer:
    def __enter__(self):
        self.start = time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.seconds = time.perf_counter() - self.start


def _spectral(L, noise_std, priors, T):
    from skf_ref.method import SpectralModel, StateSpaceModel, priors_from_snr

    ep, pm = priors
    theta0, q = priors_from_snr(L, noise_std, pm, ep, T)
    return SpectralModel(StateSpaceModel.create(L, noise_std=noise_std, theta0=theta0, q=q), T)


def _skf(head, sims, noise, extras=False):
    """The SKF settings' amplitudes: (method, setting, data, seed) -> (amplitude, run s),
    and the preparation's seconds. ``extras``: also :data:`EXTRA_SKF`."""
    first = next(iter(sims.values()))
    with _Timer() as prep:
        if noise == "white":  # as the sweeps run it
            L, W, noise_std = head.leadfield, None, first.sigma
        else:
            W = _whitener(first.noise_cov)
            L, noise_std = W @ head.leadfield, 1.0
        T = first.Y.shape[1]
        spectral = _spectral(L, noise_std, TUNED_PRIOR, T)
    settings = [
        (f"{exponent:g}/{smoother}", spectral, exponent, None if smoother == "none" else smoother)
        for exponent, smoother in product(EXPONENTS, SMOOTHERS)
    ]
    if extras:
        for label, (exponent, smoother, ep, pm) in EXTRA_SKF.items():
            settings.append((label, _spectral(L, noise_std, (ep, pm), T), exponent, smoother))
    out = {}
    for (data, seed), sim in sims.items():
        Y = sim.Y if W is None else W @ sim.Y
        for label, model, exponent, smoother in settings:
            with _Timer() as run:
                amplitude = model.apply(Y, exponent, smoother).amplitude(3)
            out["SKF", label, data, seed] = (amplitude, run.seconds)
    return out, {"SKF": prep.seconds}


def _minimum_norm(head, sims, snr_db):
    from mne.minimum_norm import prepare_inverse_operator

    from skf_ref.study.baselines import apply_minimum_norm, inverse_operator

    first = next(iter(sims.values()))
    with _Timer() as make:
        inverse = inverse_operator(head, first)
    out, prep = {}, {}
    for method, (rule, lambda2) in product(MINIMUM_NORM_METHODS, LAMBDA2.items()):
        lambda2 = lambda2(snr_db)
        with _Timer() as timer:
            prepared = prepare_inverse_operator(inverse, 1, lambda2, method, verbose=False)
        setting = f"lambda2={rule}"
        prep[method, setting] = make.seconds + timer.seconds
        for (data, seed), sim in sims.items():
            with _Timer() as run:
                amplitude = apply_minimum_norm(head, sim, prepared, method, lambda2, True)
            out[method, setting, data, seed] = (amplitude, run.seconds)
    return out, prep


def _per_run(head, sims):
    """LCMV and MxNE: their preparation depends on the run's data."""
    import mne
    from mne.beamformer import apply_lcmv, make_lcmv
    from mne.inverse_sparse import mixed_norm

    from skf_ref.study.baselines import amplitude_on_positions, mne_data

    out, prep = {}, {}
    for (data, seed), sim in sims.items():
        evoked, cov = mne_data(head, sim)
        second_moment = sim.Y @ sim.Y.T / sim.Y.shape[1]
        data_cov = mne.Covariance(
            second_moment, evoked.info.ch_names, [], [], sim.Y.shape[1], verbose=False
        )
        with _Timer() as make:
            filters = make_lcmv(
                evoked.info, head.fwd, data_cov, reg=LCMV_REG, noise_cov=cov, pick_ori=None,
                weight_norm="unit-noise-gain", rank="info", verbose=False,
            )  # fmt: skip
        with _Timer() as run:
            stc = apply_lcmv(evoked, filters, verbose=False)
        key = ("LCMV", f"reg={LCMV_REG:g}", data, seed)
        out[key], prep[key] = (amplitude_on_positions(stc, head), run.seconds), make.seconds
        with _Timer() as run:
            stc = mixed_norm(evoked, head.fwd, cov, alpha=MXNE_ALPHA, loose=1.0, verbose=False)
        key = ("MxNE", f"alpha={MXNE_ALPHA:g}%", data, seed)
        out[key], prep[key] = (amplitude_on_positions(stc, head), run.seconds), 0.0
    return out, prep


def run_level(head_kwargs, condition, snr_db, seeds, with_baselines):
    """Every method on one condition's data sets at one noise level.

    Parameters
    ----------
    head_kwargs : dict
        Keyword arguments of :func:`skf_ref.study.head.make_head` (without the montage).
    condition : Condition
    snr_db : float
    seeds : list of int
    with_baselines : bool
        False: the SKF settings only (the choice seeds).

    Returns
    -------
    list of dict
        One row per method, data set and seed (:data:`COLUMNS`).
    """
    import warnings

    from skf_ref.study import metrics
    from skf_ref.study import scenario as simulate
    from skf_ref.study.head import make_head

    head = make_head(**dict(head_kwargs, montage=condition.montage))
    scenario = simulate.p20n20_scenario()
    sims = {
        (data, seed): simulate.simulate(
            head, scenario, snr_db, seed, sources=s, noise=condition.noise
        )
        for data, s in DATA.items()
        for seed in seeds
    }
    truth = next(iter(sims.values())).truth
    results, prep = _skf(head, sims, condition.noise, extras=with_baselines)
    if with_baselines:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # MNE's rank and convergence chatter
            for part, part_prep in (_minimum_norm(head, sims, snr_db), _per_run(head, sims)):
                results.update(part)
                prep.update(part_prep)
    rows = []
    for (method, setting, data, seed), (amplitude, seconds) in results.items():
        summary = metrics.summarize(amplitude, head, truth)
        prep_s = prep.get((method, setting, data, seed), prep.get((method, setting)))
        rows.append(
            dict(
                condition=condition.name,
                snr_db=snr_db,
                seed=seed,
                data=data,
                method=method,
                setting=setting,
                deep_region_db=summary["deep_region_db"],
                **_deep_levels(amplitude, head, truth),
                superficial_region_db=summary["superficial_region_db"],
                deep_error_mm=_error(amplitude, summary, truth, 0),
                superficial_error_mm=_error(amplitude, summary, truth, 1),
                run_s=seconds,
                prep_s=prep.get("SKF") if method == "SKF" else prep_s,
            )
        )
    return rows


def _deep_levels(amplitude, head, truth):
    """The deep region's maximum at its peak time (absolute), and that re. the epoch's
    maximum over every position and sample (dB; -inf for an empty region)."""
    from skf_ref.study.regions import region_mask

    index = truth.peak_indices[0]
    level = float(amplitude[region_mask(head.positions, truth.positions[0]), index].max())
    peak = float(amplitude.max())
    epoch = 20 * np.log10(level / peak) if level > 0 and peak > 0 else -np.inf
    return dict(deep_level=level, deep_epoch_db=epoch)


def _error(amplitude, summary, truth, source):
    """The peak error, or NaN when the estimate is zero everywhere at the peak time."""
    index = truth.peak_indices[source]
    key = ("deep_error_mm", "superficial_error_mm")[source]
    return summary[key] if amplitude[:, index].max() > 0 else float("nan")


# --------------------------------------------------------------------------- the study


def _run_task(head_kwargs, task, path):
    condition, snr, seeds, with_baselines, _ = task
    rows = run_level(head_kwargs, condition, snr, seeds, with_baselines)
    table = pd.DataFrame(rows, columns=list(COLUMNS))
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False, float_format="%.10g", lineterminator="\n")
    return path


def baseline_jobs(settings, out, testing_data=None, cache_dir=None):
    """The jobs that compute every baselines results file not yet written, longest first.

    Parameters
    ----------
    settings : Settings
    out : Path
        The report folder.
    testing_data, cache_dir : path-like or None
        As for the cells (:func:`cells.head_kwargs`).

    Returns
    -------
    list of tuple
        ``(function, *args)``: each writes one results file (resumable); run them on any
        workers, then read every row with :func:`read_baselines`.
    """
    from .cells import head_kwargs

    folder = Path(out) / BASELINES
    jobs = []
    for task in sorted(_tasks(settings), key=_cost, reverse=True):
        path = folder / task[-1]
        if not path.exists():
            kwargs = head_kwargs(task[0].cell, settings, testing_data, cache_dir)
            jobs.append((_run_task, kwargs, task, path))
    return jobs


def _cost(task):
    """A task's relative run time, to start the longest first (no worker then idles behind
    the last long one): its seeds, times 8 with MNE's methods (LCMV and MxNE on every data
    set), times 2 more with real noise (measured on the full report: 150-200 s, 70-110 s
    with white noise, 12-30 s for the SKF settings alone)."""
    condition, _, seeds, with_baselines, _ = task
    return len(seeds) * (8 if with_baselines else 1) * (2 if condition.noise == "head" else 1)


def read_baselines(settings, out):
    """Every row of the baselines results files (which must all exist): :data:`COLUMNS`;
    the choice seeds' rows are those whose ``seed`` is in :data:`recommend.CHOICE_SEEDS`."""
    tables = [pd.read_csv(Path(out) / name) for name in baseline_files(settings)]
    return pd.concat(tables, ignore_index=True)
