"""Parameter sweeps over the P20/N20 study: one tidy row per run, resumable, parallel.

A grid is a mapping from axis name to a list of values over ``snr_db``, ``ep_snr_db``,
``pm_snr_db``, ``exponent``, ``smoother`` (``None`` included) and ``seed``. Every run adds
one row to the results file: its parameters, every metric of
:func:`skf_ref.study._metrics.summarize`, the package versions and the BLAS threads of the worker.

Work is grouped by (snr_db, ep_snr_db, pm_snr_db): these fix the noise level and the priors, so one
:class:`skf_ref.method.SpectralModel` (whitening, SVD and the whole covariance
recursion, which do not depend on the data) serves every seed, exponent and smoother of the group;
many seeds cost little more than one.

Runs go through :mod:`joblib`; ``backend=None`` leaves the choice to the caller's
``joblib.parallel_config``, so the same sweep runs on a Dask or Ray cluster::

    from dask.distributed import Client
    import joblib
    client = Client("tcp://scheduler:8786")          # or Client() for a local cluster
    with joblib.parallel_config(backend="dask"):
        run_sweep(paper_grid(), "results.csv", n_jobs=-1)

    from ray.util.joblib import register_ray         # Ray: the same with
    register_ray()                                   # backend="ray"

Only the main process writes, and only one sweep at a time: the file is locked while a
sweep writes it. Rerunning with the same ``out`` skips the rows already there. See
:func:`read_results` for what is checked when a file is read.
"""

from ._grid import AXES, KEY, check_grid, paper_grid
from ._results import TornLineWarning, read_results
from ._runs import run_group, run_on_head, run_sweep

__all__ = [
    "AXES",
    "KEY",
    "TornLineWarning",
    "check_grid",
    "paper_grid",
    "read_results",
    "run_group",
    "run_on_head",
    "run_sweep",
]
