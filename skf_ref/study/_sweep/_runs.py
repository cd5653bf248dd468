"""Sweep runs: one group of runs on one prepared model, and the sweep over a grid."""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import itertools
import logging
import math
import multiprocessing
import os
import signal
import sys
import warnings
import weakref
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ..._utils.checks import InputError, check_int
from ..._utils.extras import require
from ..._utils.log import caller_stacklevel, logger, verbosity
from ..._utils.provenance import blas_threads, package_versions
from .._sizes import DEFAULT_POSITIONS
from ._grid import AXES, GROUP, check_grid, row_key, smoother_label
from ._results import ResultsFile, read_results

if TYPE_CHECKING:
    import numpy as np
    import pandas as pd
    from numpy.typing import NDArray

    from ...method import SpectralBasis, StateSpaceModel
    from .._head import HeadModel
    from .._scenario import Truth

#: One run of a group: (exponent, smoother, seed).
Run = tuple[float, str | None, int]

__all__ = ["run_group", "run_on_head", "run_sweep"]


def _die_with_parent() -> None:
    """In a worker process on Linux: be terminated when the process that started it dies.

    A sweep killed with SIGKILL cannot stop its joblib (loky) workers; without this they
    would run on as orphans until their idle timeout.
    """
    if sys.platform != "linux" or multiprocessing.current_process().name == "MainProcess":
        return
    libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
    pr_set_pdeathsig = 1
    libc.prctl(pr_set_pdeathsig, signal.SIGTERM)


def _head(n_positions: int, montage: str, head: Mapping[str, Any] | None) -> HeadModel:
    from .._head import make_head, make_head_model

    if head is None:
        return make_head_model(n_positions, montage)
    return make_head(**dict(head, montage=montage))


def run_group(
    snr_db: float,
    ep_snr_db: float,
    pm_snr_db: float,
    runs: Sequence[Run],
    n_positions: int = DEFAULT_POSITIONS,
    montage: str = "biosemi64",
    head: Mapping[str, Any] | None = None,
    data: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """All runs that share a noise level and priors, on one prepared spectral model.

    Parameters
    ----------
    snr_db, ep_snr_db, pm_snr_db : float
        The data's peak SNR and the priors' EP-SNR and PM-SNR, dB.
    runs : list of (exponent, smoother, seed)
        The runs: standardization exponent, smoother (None: none) and noise seed.
    n_positions : int
        Positions of the sphere's volume grid (without ``head``).
    montage : str
        Name of an MNE built-in montage.
    head : dict or None
        Keyword arguments of :func:`skf_ref.study._head.make_head` (``conductor``,
        ``source_space``, ``testing_data``, ``cache_dir``...); None: the sphere's volume grid
        of ``n_positions``.
    data : dict or None
        Keyword arguments of ``run_on_head`` that shape the data (``sources``,
        ``forward``, ``window``).

    Returns
    -------
    list of dict
        One tidy row per run, in the order of the seeds, then of ``runs``.
    """
    _die_with_parent()
    model = _head(n_positions, montage, head)
    return run_on_head(model, snr_db, ep_snr_db, pm_snr_db, runs, **(data or {}))


def _sources_label(sources: Sequence[str]) -> str:
    return "+".join(sources)


def _region_values(
    amplitude: NDArray[np.float64], head: HeadModel, truth: Truth
) -> dict[str, float]:
    """Raw region maxima (standardized amplitude, shape (n_positions, n_times)) at the two
    peaks, for the controls, and the height (m, head coordinates) of the global maximum at
    each peak."""
    from .._regions import region_time_course

    i_deep, i_sup = truth.peak_indices
    deep = region_time_course(amplitude, head.positions, truth.positions[0])
    sup = region_time_course(amplitude, head.positions, truth.positions[1])
    return {
        "deep_max_at_deep_peak": float(deep[i_deep]),
        "deep_max_at_superficial_peak": float(deep[i_sup]),
        "superficial_max_at_superficial_peak": float(sup[i_sup]),
        "max_at_deep_peak": float(amplitude[:, i_deep].max()),
        "max_at_superficial_peak": float(amplitude[:, i_sup].max()),
        "max_height_at_deep_peak": float(head.positions[amplitude[:, i_deep].argmax(), 2]),
        "max_height_at_superficial_peak": float(head.positions[amplitude[:, i_sup].argmax(), 2]),
    }


@functools.cache  # metadata lookups take milliseconds, and every task records them
def _package_columns() -> tuple[tuple[str, str], ...]:
    """The package versions of a row, ``("numpy_version", "2.4.6")``..., this process's."""
    return tuple((f"{name}_version", v) for name, v in package_versions().items())


#: Each head's spectral bases by noise level, kept while the head lives: a worker prepares
#: many groups of the same head and noise (priors differ, the SVD of L / sigma does not).
_BASES: weakref.WeakKeyDictionary[HeadModel, dict[float, SpectralBasis]] = (
    weakref.WeakKeyDictionary()
)


def _basis(head: HeadModel, sigma: float, model: StateSpaceModel) -> SpectralBasis:
    """The whitening and SVD of ``model``: the head's lead field and white noise of ``sigma``."""
    from ...method import SpectralBasis

    bases = _BASES.setdefault(head, {})
    if sigma not in bases:
        bases[sigma] = SpectralBasis(model.L, model.R)
    return bases[sigma]


def run_on_head(
    head: HeadModel,
    snr_db: float,
    ep_snr_db: float,
    pm_snr_db: float,
    runs: Sequence[Run],
    *,
    sources: Sequence[str] = ("deep", "superficial"),
    forward: str = "exact",
    window: str = "hann",
) -> list[dict[str, Any]]:
    """:func:`run_group` on a given head model (a cropped grid, another montage...).

    Parameters
    ----------
    head : skf_ref.study._head.HeadModel
        The head model.
    snr_db, ep_snr_db, pm_snr_db : float
        The data's peak SNR and the priors' EP-SNR and PM-SNR, dB.
    runs : list of (exponent, smoother, seed)
        The runs: standardization exponent, smoother (None: none) and noise seed.
    sources : sequence of str
        Sources active in the data (:func:`skf_ref.study._scenario.simulate`); the metrics always
        refer to both.
    forward : {"exact", "grid"}
        How the data's field is computed (:func:`skf_ref.study._scenario.simulate`).
    window : str
        Pulse window of the scenario (:func:`skf_ref.study._scenario.p20n20_scenario`).

    Returns
    -------
    list of dict
        One row per run; ``n_positions`` is the head's own count.
    """
    from ...method import SpectralModel, StateSpaceModel, priors_from_snr
    from .. import _metrics as metrics
    from .. import _scenario as simulate

    scenario = simulate.p20n20_scenario(window=window)
    L, T = head.leadfield, len(scenario.times)
    model = None
    rows = []
    versions: dict[str, str | int] = dict(_package_columns())
    blas = blas_threads()
    versions["blas"] = " ".join(f"{b['library']}-{b['version']}" for b in blas) or "none"
    versions["blas_threads"] = max((b["threads"] for b in blas), default=1)
    for seed in sorted({seed for _, _, seed in runs}):
        sim = simulate.simulate(head, scenario, snr_db, seed, sources=sources, forward=forward)
        if model is None:  # sigma depends on the noise level only, not on the seed
            theta0, q = priors_from_snr(L, sim.sigma, pm_snr_db, ep_snr_db, T)
            state_space = StateSpaceModel.create(L, noise_std=sim.sigma, theta0=theta0, q=q)
            model = SpectralModel(state_space, T, _basis(head, sim.sigma, state_space))
        for exponent, smoother, run_seed in runs:
            if run_seed != seed:
                continue
            rec = model.apply(sim.Y, exponent, smoother)
            amplitude = rec.amplitude(3)
            params = dict(
                n_positions=head.n_positions,
                montage=head.montage,
                conductor=head.conductor_kind,
                source_space=head.source_space,
                sources=_sources_label(sim.sources),
                forward=forward,
                window=window,
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
            summary = metrics.summarize(amplitude, head, sim.truth)
            rows.append(params | summary | _region_values(amplitude, head, sim.truth) | versions)
    return rows


def _check_identity(
    existing: pd.DataFrame, identity: Mapping[str, Any], out: str | os.PathLike
) -> None:
    """Refuse to add runs of one head or kind of data to a file holding another's."""
    for column, value in identity.items():
        if column in existing and not existing.empty and set(existing[column]) != {value}:
            raise InputError(
                f"{out} holds runs with {column} {sorted(set(existing[column]))}, not {value!r}; "
                "give a new file name"
            )


def _pending(
    grid: Mapping[str, Sequence[Any]],
    done: set[tuple[Any, ...]],
    n_positions: int,
    montage: str,
    runs_per_task: int,
) -> list[tuple[tuple[float, ...], list[Run]]]:
    """Unfinished runs grouped by (snr_db, ep_snr_db, pm_snr_db), in tasks of bounded size."""
    groups: dict[tuple[float, ...], list[Run]] = {}
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
    grid: Mapping[str, Any],
    out: str | os.PathLike,
    n_jobs: int = 1,
    *,
    n_positions: int = DEFAULT_POSITIONS,
    montage: str = "biosemi64",
    backend: str | None = None,
    verbose: bool | str | int | None = None,
    progress: bool | None = None,
    runs_per_task: int = 24,
    size_name: str = "n_positions",
    head: Mapping[str, Any] | None = None,
    data: Mapping[str, Any] | None = None,
) -> pd.DataFrame:
    """Run every point of a grid not yet in ``out``, appending one row per run.

    Parameters
    ----------
    grid : mapping
        Axis -> values over ``AXES``; see :func:`paper_grid`.
    out : path-like
        Results file: CSV, or Parquet when the name ends ``.parquet``.
    n_jobs : int
        Workers of joblib (-1: all cores).
    n_positions : int
        Source positions requested of the head model; rows record the count it holds
        (:func:`skf_ref.study._head.grid_size`).
    montage : str
        Name of an MNE built-in montage.
    backend : str, optional
        The backend of joblib; None uses the caller's ``joblib.parallel_config`` (default loky).
    verbose : bool or str or int or None
        Show a tqdm progress bar (runs done of the grid) when the ``"skf_ref"`` log shows
        INFO, as MNE's ``verbose``: None keeps the log's level (INFO unless set otherwise),
        False hides the bar.
    progress : bool
        The 0.2 name of ``verbose``; it warns and goes in 0.4.
    runs_per_task : int
        Runs of one group handed to a worker at once: rows reach the file after each task,
        so this bounds what an interruption can lose; each task prepares its model once.
    size_name : str
        How errors name ``n_positions`` (the command line says ``--positions``).
    head : dict or None
        Another head than the sphere's volume grid: keyword arguments of
        :func:`skf_ref.study._head.make_head` (built once here, to check it and count its
        positions, then in each worker; a BEM head's forward comes from the disk cache).
    data : dict or None
        Keyword arguments of ``run_on_head`` that shape the data: ``sources`` (the
        controls: one source, the noise of both), ``forward``, ``window``. A results file
        holds one head and one kind of data; another is refused.

    Returns
    -------
    pandas.DataFrame
        Every row of the results file, the new ones included.
    """
    require(("joblib", "tqdm", "filelock"), "study", "run_sweep")
    if progress is not None:
        warnings.warn(
            "run_sweep's progress= is now verbose= (as MNE names it); progress goes in 0.4",
            FutureWarning,
            stacklevel=caller_stacklevel(),
        )
        verbose = progress
    with verbosity(verbose):
        shown = logger.isEnabledFor(logging.INFO)
    from joblib import Parallel, delayed
    from tqdm.auto import tqdm

    from .._head import check_montage, check_size, grid_size

    axes = check_grid(grid)
    per_task = check_int("runs_per_task", runs_per_task, minimum=1)
    workers = check_int("n_jobs", n_jobs, minimum=None)
    if workers == 0:
        raise InputError("n_jobs must be a positive number of workers or -1 (all cores), got 0")
    check_montage(montage)
    if head is None:
        check_size(n_positions, montage, name=size_name)
        n_actual = grid_size(n_positions)
        identity = dict(conductor="sphere", source_space="volume")
    else:
        built = _head(n_positions, montage, head)
        n_actual = built.n_positions
        identity = dict(conductor=built.conductor_kind, source_space=built.source_space)
    shape = dict(data or {})
    identity["sources"] = _sources_label(shape.get("sources", ("deep", "superficial")))
    with ResultsFile(out) as results:
        _check_identity(results.existing, identity, out)
        done = {row_key(row) for _, row in results.existing.iterrows()}
        tasks = _pending(axes, done, n_actual, montage, per_task)
        total = math.prod(len(v) for v in axes.values())
        remaining = sum(len(runs) for _, runs in tasks)
        jobs = (
            delayed(run_group)(*group, runs, n_positions, montage, head, shape)
            for group, runs in tasks
        )
        parallel = Parallel(n_jobs=workers, backend=backend, return_as="generator_unordered")
        bar = tqdm(total=total, initial=total - remaining, disable=not shown, unit="run")
        with bar:
            for rows in parallel(jobs):
                results.add(rows)
                bar.update(len(rows))
    return read_results(out)
