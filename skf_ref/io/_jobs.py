"""``n_jobs`` of :func:`~skf_ref.io._apply.apply_skf_epochs` and
:func:`~skf_ref.io._raw.apply_skf_raw`: what is independent, run as joblib's jobs.

- Epochs are independent runs of the SKF over one operator: they are cut into one run of
  consecutive epochs per job, each job sent the operator once (its covariance recursion is
  computed there, once per job).
- A recording is one run: the filter's state carries over from each sample to the next, so
  it cannot be cut in time, and the filter runs here. Every row of the estimate then
  depends on that row of the lead field's SVD and on the filter's r x T quantities only
  (``skf_ref.method._outputs``): the rows (the standardization and the product that gives
  the sources, the n x T part of the work) are cut into one run of whole positions per job,
  each job sent the reconstruction once.

The jobs' results equal this process's to rounding (another order of sums: BLAS threads
and block shapes differ), not bit for bit.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._utils.log import verbosity
from .._utils.parallel import Jobs, run_jobs

__all__ = ["epochs_in_jobs", "position_parts", "rows_in_jobs"]


def _epochs_part(operator, data, settings, tmin, tstep, pick_ori, verbose):
    """One job's epochs: the SKF on each, as source estimates."""
    with verbosity(verbose):
        return [
            operator.to_stc(operator._reconstruct(epoch, **settings), tmin, tstep, pick_ori)
            for epoch in data
        ]


def epochs_in_jobs(
    data: list[np.ndarray],
    operator: Any,
    settings: dict[str, Any],
    times: tuple[float, float],
    pick_ori: str | None,
    jobs: Jobs,
    verbose: Any = None,
) -> list[Any]:
    """The SKF on each epoch, the epochs cut into one run per job.

    Parameters
    ----------
    data : list of ndarray, each (len(operator.ch_names), n_times)
        The operator's channels of each epoch, checked (:meth:`SKFOperator.select`).
    operator : SKFOperator
    settings : dict
        :meth:`SKFOperator.reconstruct`'s keyword arguments.
    times : (float, float)
        ``tmin`` and ``tstep`` of the estimates.
    pick_ori : {None, "vector"}
    jobs : Jobs
        :func:`skf_ref._utils.parallel.plan_jobs`'s answer.
    verbose : bool or str or int, optional
        The log's level in the jobs.

    Returns
    -------
    list of source estimates
        One per epoch, in order.
    """
    parts = [part for part in np.array_split(np.arange(len(data)), jobs.count) if len(part)]
    calls = [
        (operator, [data[k] for k in part], settings, *times, pick_ori, verbose) for part in parts
    ]
    return [stc for estimates in run_jobs(_epochs_part, calls, jobs) for stc in estimates]


def position_parts(n_sources: int, align: int, count: int) -> list[slice]:
    """``n_sources`` rows cut into at most ``count`` runs of whole positions (``align`` rows
    each), as equal as they can be.

    Examples
    --------
    >>> position_parts(12, 3, 2)
    [slice(0, 6, None), slice(6, 12, None)]
    >>> position_parts(6, 3, 4)
    [slice(0, 3, None), slice(3, 6, None)]
    """
    positions = np.array_split(np.arange(n_sources // align), count)
    return [slice(int(p[0]) * align, (int(p[-1]) + 1) * align) for p in positions if len(p)]


def _rows_part(reconstruction, name, rows, shared):
    return reconstruction._block(name, rows, shared)


def rows_in_jobs(reconstruction: Any, align: int, jobs: Jobs, name: str = "z") -> None:
    """Compute output ``name`` of a reconstruction in jobs, one run of whole positions
    each, and keep it in the reconstruction (in memory, as if asked for here).

    Nothing is done when the jobs would run here, or when the output is in memory
    already (the dense and filterpy paths compute every output at once).

    Parameters
    ----------
    reconstruction : skf_ref.Reconstruction
    align : int
        Rows of one source position (rows standardized together are computed together).
    jobs : Jobs
    name : str
        The output.
    """
    if jobs.local or reconstruction.lazy_outputs is None or reconstruction.computed(name):
        return
    n, T = reconstruction.n_sources, reconstruction.n_times
    shared = reconstruction._shared(name)
    parts = position_parts(n, align, jobs.count)
    out = np.empty((n, T))
    calls = [(reconstruction, name, rows, shared) for rows in parts]
    for rows, block in zip(parts, run_jobs(_rows_part, calls, jobs), strict=True):
        out[rows] = block  # each part kept, then dropped before the next arrives
    reconstruction._hold(name, out)
