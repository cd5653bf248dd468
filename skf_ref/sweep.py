"""Parameter sweeps over the P20/N20 study: one tidy row per run, resumable, parallel.

A grid is a mapping from axis name to a list of values over ``snr_db``, ``ep_snr_db``,
``pm_snr_db``, ``exponent``, ``smoother`` (``None`` included) and ``seed``. Every run adds
one row to the results file: its parameters, every metric of
:func:`skf_ref.metrics.summarize` and the package versions.

Work is grouped by (snr_db, ep_snr_db, pm_snr_db): these fix the noise level and the priors,
so one :class:`skf_ref.spectral.SpectralModel` (whitening, SVD and the whole covariance
recursion, which do not depend on the data) serves every seed, exponent and smoother of the
group; many seeds cost little more than one.

Runs go through :mod:`joblib`; ``backend=None`` leaves the choice to the caller's
``joblib.parallel_config``, so the same sweep runs on a Dask or Ray cluster::

    from dask.distributed import Client
    import joblib
    client = Client("tcp://scheduler:8786")          # or Client() for a local cluster
    with joblib.parallel_config(backend="dask"):
        run_sweep(paper_grid(), "results.csv", n_jobs=-1)

    from ray.util.joblib import register_ray         # Ray: the same with
    register_ray()                                   # backend="ray"

Only the main process writes. A CSV gets one whole line per finished run in a single
``write`` call and is flushed to disk; a torn last line (power loss) is dropped when the
sweep resumes. A Parquet file (name ending ``.parquet``; needs pyarrow) is rewritten through
a temporary file and a rename after each group. Rerunning with the same ``out`` skips the
rows already there.
"""

import itertools
import math
import numbers
import os
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd

from . import __version__
from ._io import atomic_path
from ._validation import check_choice
from .reconstruct import SMOOTHERS

__all__ = [
    "run_sweep",
    "paper_grid",
    "check_grid",
    "run_group",
    "run_on_head",
    "package_versions",
    "AXES",
    "KEY",
]

AXES = ("snr_db", "ep_snr_db", "pm_snr_db", "exponent", "smoother", "seed")
GROUP = ("snr_db", "ep_snr_db", "pm_snr_db")
KEY = ("n_positions", "montage", *AXES)
_PACKAGES = ("skf_ref", "numpy", "scipy", "filterpy", "mne")


def paper_grid(seeds=10):
    """The paper's grid: 10/20/30 dB; EP, PM in {0, 20}; four exponents; three smoothers.

    Parameters
    ----------
    seeds : int
        Number of noise seeds, ``0 .. seeds - 1``.

    Returns
    -------
    dict

    Examples
    --------
    >>> grid = paper_grid(seeds=2)
    >>> grid["exponent"], grid["smoother"], grid["seed"]
    ([0.5, 1.0, 1.25, 1.5], [None, 'rts-standardized', 'rts-state'], [0, 1])
    """
    return dict(
        snr_db=[10.0, 20.0, 30.0],
        ep_snr_db=[0.0, 20.0],
        pm_snr_db=[0.0, 20.0],
        exponent=[0.5, 1.0, 1.25, 1.5],
        smoother=list(SMOOTHERS),
        seed=list(range(seeds)),
    )


def check_grid(grid):
    """Validate a grid before any work starts; returns it with normalized values.

    Parameters
    ----------
    grid : mapping
        Axis name -> non-empty list of values, for every name in :data:`AXES`.

    Returns
    -------
    dict

    Examples
    --------
    >>> check_grid(dict(paper_grid(1), exponent=[-1.0]))
    Traceback (most recent call last):
    ...
    ValueError: grid['exponent'] values must be finite and >= 0, got -1.0
    """
    if not hasattr(grid, "keys"):
        raise TypeError(f"grid must be a mapping of axis -> values, got {type(grid).__name__}")
    unknown = set(grid) - set(AXES)
    missing = set(AXES) - set(grid)
    if unknown or missing:
        raise ValueError(
            f"grid must have exactly the axes {list(AXES)}; "
            f"missing {sorted(missing)}, unknown {sorted(unknown)}"
        )
    out = {}
    for axis in AXES:
        values = grid[axis]
        if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
            values = [values]
        values = list(values)
        if not values:
            raise ValueError(f"grid[{axis!r}] is empty: give at least one value")
        if len(set(values)) != len(values):
            raise ValueError(f"grid[{axis!r}] has repeated values: {values}")
        for value in values:
            _check_value(axis, value)
        out[axis] = [v if axis == "smoother" else _number(axis, v) for v in values]
    return out


def _check_value(axis, value):
    if axis == "smoother":
        check_choice(f"grid['{axis}'] values", value, SMOOTHERS)
        return
    real = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if axis == "seed":
        if not isinstance(value, numbers.Integral) or isinstance(value, bool) or value < 0:
            raise ValueError(f"grid['seed'] values must be integers >= 0, got {value!r}")
    elif not real or not math.isfinite(value) or (axis == "exponent" and value < 0):
        extra = " and >= 0" if axis == "exponent" else ""
        raise ValueError(f"grid[{axis!r}] values must be finite{extra}, got {value!r}")


def _number(axis, value):
    return int(value) if axis == "seed" else float(value)


def package_versions(packages=_PACKAGES):
    """Versions of the packages results depend on, by name.

    skf_ref's own comes from the package itself, so it is known when run from a checkout.

    Parameters
    ----------
    packages : sequence of str

    Returns
    -------
    dict
        ``{name: version}``; ``"not installed"`` for a missing package.

    Examples
    --------
    >>> package_versions(("skf_ref", "no-such-package"))
    {'skf_ref': '...', 'no-such-package': 'not installed'}
    """
    versions = {}
    for package in packages:
        try:
            versions[package] = __version__ if package == "skf_ref" else metadata.version(package)
        except metadata.PackageNotFoundError:
            versions[package] = "not installed"
    return versions


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
    from . import simulate

    head = simulate.make_head_model(n_positions, montage)
    return run_on_head(head, snr_db, ep_snr_db, pm_snr_db, runs, n_positions=n_positions)


def run_on_head(head, snr_db, ep_snr_db, pm_snr_db, runs, n_positions=None):
    """:func:`run_group` on a given head model (a cropped grid, another montage...).

    Parameters
    ----------
    head : skf_ref.simulate.HeadModel
    snr_db, ep_snr_db, pm_snr_db : float
    runs : list of (exponent, smoother, seed)
    n_positions : int, optional
        The ``n_positions`` recorded in the rows (the requested size, which keys the
        results file); default ``head.n_positions``.

    Returns
    -------
    list of dict
    """
    from . import metrics, simulate
    from .priors import priors_from_snr
    from .spectral import SpectralModel

    scenario = simulate.p20n20_scenario()
    L, T = head.leadfield, len(scenario.times)
    model = None
    rows = []
    versions = {f"{name}_version": v for name, v in package_versions().items()}
    for seed in sorted({seed for _, _, seed in runs}):
        sim = simulate.simulate(head, scenario, snr_db, seed)
        if model is None:  # sigma depends on the noise level only, not on the seed
            theta0, q = priors_from_snr(L, sim.sigma, pm_snr_db, ep_snr_db, T)
            R = sim.sigma**2 * np.eye(head.n_channels)
            model = SpectralModel(L, R, 1.0, q, theta0, T)
        for exponent, smoother, run_seed in runs:
            if run_seed != seed:
                continue
            rec = model.apply(sim.Y, exponent, smoother)
            params = dict(
                n_positions=head.n_positions if n_positions is None else n_positions,
                montage=head.montage,
                snr_db=snr_db,
                ep_snr_db=ep_snr_db,
                pm_snr_db=pm_snr_db,
                exponent=exponent,
                smoother=_smoother_label(smoother),
                seed=seed,
                theta0=theta0,
                q=q,
                sigma=sim.sigma,
                log_likelihood=rec.log_likelihood,
            )
            rows.append(params | metrics.summarize(rec, head, sim.truth) | versions)
    return rows


def _smoother_label(smoother):
    return "none" if smoother is None else smoother


def _key(row):
    return tuple(
        _smoother_label(row[k]) if k == "smoother" else row[k] if k == "montage" else float(row[k])
        for k in KEY
    )


def read_results(out):
    """The rows already in a results file (none if it does not exist).

    A CSV whose last line was torn (no final newline) is repaired first by dropping it.

    Parameters
    ----------
    out : path-like

    Returns
    -------
    pandas.DataFrame
    """
    out = Path(out)
    if not out.exists() or out.stat().st_size == 0:
        return pd.DataFrame()
    if out.suffix == ".parquet":
        return pd.read_parquet(out)
    data = out.read_bytes()
    if not data.endswith(b"\n"):
        with open(out, "r+b") as f:
            f.truncate(data.rfind(b"\n") + 1)
    return pd.read_csv(out, keep_default_na=False, na_values=[""])


class _CsvWriter:
    def __init__(self, out, columns):
        self.out, self.columns = Path(out), columns

    def add(self, rows):
        frame = pd.DataFrame(rows)
        header = not self.out.exists() or self.out.stat().st_size == 0
        if header:
            self.columns = list(frame.columns)
        elif list(frame.columns) != self.columns:
            raise ValueError(f"{self.out}: existing columns differ from this sweep's rows")
        for _, row in frame.iterrows():
            text = row.to_frame().T.to_csv(index=False, header=header, lineterminator="\n")
            fd = os.open(self.out, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
            try:
                os.write(fd, text.encode())  # one whole line (with the header, the first time)
                os.fsync(fd)
            finally:
                os.close(fd)
            header = False


class _ParquetWriter:
    def __init__(self, out, existing):
        self.out, self.frame = Path(out), existing

    def add(self, rows):
        self.frame = pd.concat([self.frame, pd.DataFrame(rows)], ignore_index=True)
        with atomic_path(self.out) as tmp:
            self.frame.to_parquet(tmp, index=False)


def _pending(grid, done, n_positions, montage, runs_per_task):
    """Unfinished runs grouped by (snr_db, ep_snr_db, pm_snr_db), in tasks of bounded size."""
    groups = {}
    for values in itertools.product(*(grid[a] for a in AXES)):
        run = dict(zip(AXES, values, strict=True), n_positions=n_positions, montage=montage)
        if _key(run) in done:
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
        Source positions of the head model.
    montage : str
    backend : str, optional
        joblib backend; None uses the caller's ``joblib.parallel_config`` (default loky).
    progress : bool
        Show a tqdm progress bar (runs done of the grid).
    runs_per_task : int
        Runs of one group handed to a worker at once: rows reach the file after each task,
        so this bounds what an interruption can lose; each task prepares its model once.

    Returns
    -------
    pandas.DataFrame
        Every row of the results file, the new ones included.
    """
    from joblib import Parallel, delayed
    from tqdm.auto import tqdm

    grid = check_grid(grid)
    out = Path(out)
    if out.suffix == ".parquet":
        import pyarrow  # noqa: F401  (fail before any work if Parquet cannot be written)
    existing = read_results(out)
    done = {_key(row) for _, row in existing.iterrows()} if len(existing) else set()
    tasks = _pending(grid, done, n_positions, montage, runs_per_task)
    total = math.prod(len(v) for v in grid.values())
    remaining = sum(len(runs) for _, runs in tasks)
    writer = (
        _ParquetWriter(out, existing)
        if out.suffix == ".parquet"
        else _CsvWriter(out, list(existing.columns))
    )
    jobs = (delayed(run_group)(*group, runs, n_positions, montage) for group, runs in tasks)
    parallel = Parallel(n_jobs=n_jobs, backend=backend, return_as="generator_unordered")
    bar = tqdm(total=total, initial=total - remaining, disable=not progress, unit="run")
    with bar:
        for rows in parallel(jobs):
            writer.add(rows)
            bar.update(len(rows))
    return read_results(out)
