"""Sweep runs: one group of runs on one prepared model, and the sweep over a grid."""

import ctypes
import ctypes.util
import itertools
import math
import multiprocessing
import signal
import sys

from ..checks import InputError, check_int
from ..provenance import blas_threads, package_versions
from ._grid import AXES, GROUP, check_grid, row_key, smoother_label
from ._results import ResultsFile, read_results

__all__ = ["run_group", "run_on_head", "run_sweep"]


def _die_with_parent():
    """In a worker process on Linux: be terminated when the process that started it dies.

    A sweep killed with SIGKILL cannot stop its joblib (loky) workers; without this they
    would run on as orphans until their idle timeout.
    """
    if sys.platform != "linux" or multiprocessing.current_process().name == "MainProcess":
        return
    libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
    pr_set_pdeathsig = 1
    libc.prctl(pr_set_pdeathsig, signal.SIGTERM)


def run_group(snr_db, ep_snr_db, pm_snr_db, runs, n_positions=3000, montage="biosemi64"):
    """All runs that share a noise level and priors, on one prepared spectral model.

    Parameters
    ----------
    snr_db, ep_snr_db, pm_snr_db : float
    runs : list of (exponent, smoother, seed)
    n_positions : int
    montage : str

    Returns
    -------
    list of dict
        One tidy row per run, in the order of the seeds, then of ``runs``.
    """
    from ..head import make_head_model

    _die_with_parent()
    head = make_head_model(n_positions, montage)
    return run_on_head(head, snr_db, ep_snr_db, pm_snr_db, runs)


def run_on_head(head, snr_db, ep_snr_db, pm_snr_db, runs):
    """:func:`run_group` on a given head model (a cropped grid, another montage...).

    Parameters
    ----------
    head : skf_ref.simulate.HeadModel
    snr_db, ep_snr_db, pm_snr_db : float
    runs : list of (exponent, smoother, seed)

    Returns
    -------
    list of dict
        One row per run; ``n_positions`` is the head's own count.
    """
    from .. import metrics, simulate
    from ..model import StateSpaceModel
    from ..priors import priors_from_snr
    from ..spectral import SpectralModel

    scenario = simulate.p20n20_scenario()
    L, T = head.leadfield, len(scenario.times)
    model = None
    rows = []
    versions = {f"{name}_version": v for name, v in package_versions().items()}
    blas = blas_threads()
    versions["blas"] = " ".join(f"{b['library']}-{b['version']}" for b in blas) or "none"
    versions["blas_threads"] = max((b["threads"] for b in blas), default=1)
    for seed in sorted({seed for _, _, seed in runs}):
        sim = simulate.simulate(head, scenario, snr_db, seed)
        if model is None:  # sigma depends on the noise level only, not on the seed
            theta0, q = priors_from_snr(L, sim.sigma, pm_snr_db, ep_snr_db, T)
            state_space = StateSpaceModel.create(L, noise_std=sim.sigma, theta0=theta0, q=q)
            model = SpectralModel(state_space, T)
        for exponent, smoother, run_seed in runs:
            if run_seed != seed:
                continue
            rec = model.apply(sim.Y, exponent, smoother)
            params = dict(
                n_positions=head.n_positions,
                montage=head.montage,
                snr_db=snr_db,
                ep_snr_db=ep_snr_db,
                pm_snr_db=pm_snr_db,
                exponent=exponent,
                smoother=smoother_label(smoother),
                seed=seed,
                theta0=theta0,
                q=q,
                sigma=sim.sigma,
                log_likelihood=rec.log_likelihood,
            )
            rows.append(params | metrics.summarize(rec, head, sim.truth) | versions)
    return rows


def _pending(grid, done, n_positions, montage, runs_per_task):
    """Unfinished runs grouped by (snr_db, ep_snr_db, pm_snr_db), in tasks of bounded size."""
    groups = {}
    for values in itertools.product(*(grid[a] for a in AXES)):
        run = dict(zip(AXES, values, strict=True), n_positions=n_positions, montage=montage)
        if row_key(run) in done:
            continue
        groups.setdefault(tuple(run[a] for a in GROUP), []).append(
            (run["exponent"], run["smoother"], run["seed"])
        )
    return [
        (group, runs[start : start + runs_per_task])
        for group, runs in groups.items()
        for start in range(0, len(runs), runs_per_task)
    ]


def run_sweep(
    grid,
    out,
    n_jobs=1,
    *,
    n_positions=3000,
    montage="biosemi64",
    backend=None,
    progress=True,
    runs_per_task=24,
    size_name="n_positions",
):
    """Run every point of a grid not yet in ``out``, appending one row per run.

    Parameters
    ----------
    grid : mapping
        Axis -> values over :data:`AXES`; see :func:`paper_grid`.
    out : path-like
        Results file: CSV, or Parquet when the name ends ``.parquet``.
    n_jobs : int
        joblib workers (-1: all cores).
    n_positions : int
        Source positions requested of the head model; rows record the count it holds
        (:func:`skf_ref.head.grid_size`).
    montage : str
    backend : str, optional
        joblib backend; None uses the caller's ``joblib.parallel_config`` (default loky).
    progress : bool
        Show a tqdm progress bar (runs done of the grid).
    runs_per_task : int
        Runs of one group handed to a worker at once: rows reach the file after each task,
        so this bounds what an interruption can lose; each task prepares its model once.
    size_name : str
        How errors name ``n_positions`` (the command line says ``--positions``).

    Returns
    -------
    pandas.DataFrame
        Every row of the results file, the new ones included.
    """
    from joblib import Parallel, delayed
    from tqdm.auto import tqdm

    from ..head import check_montage, check_size, grid_size

    grid = check_grid(grid)
    runs_per_task = check_int("runs_per_task", runs_per_task, minimum=1)
    n_jobs = check_int("n_jobs", n_jobs, minimum=None)
    if n_jobs == 0:
        raise InputError("n_jobs must be a positive number of workers or -1 (all cores), got 0")
    check_montage(montage)
    check_size(n_positions, montage, name=size_name)
    n_actual = grid_size(n_positions)
    with ResultsFile(out) as results:
        done = {row_key(row) for _, row in results.existing.iterrows()}
        tasks = _pending(grid, done, n_actual, montage, runs_per_task)
        total = math.prod(len(v) for v in grid.values())
        remaining = sum(len(runs) for _, runs in tasks)
        jobs = (delayed(run_group)(*group, runs, n_positions, montage) for group, runs in tasks)
        parallel = Parallel(n_jobs=n_jobs, backend=backend, return_as="generator_unordered")
        bar = tqdm(total=total, initial=total - remaining, disable=not progress, unit="run")
        with bar:
            for rows in parallel(jobs):
                results.add(rows)
                bar.update(len(rows))
    return read_results(out)
