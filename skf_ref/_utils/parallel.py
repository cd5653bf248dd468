"""Jobs as MNE-Python runs them: ``n_jobs`` through joblib, a cluster through its context.

MNE's convention (``mne.parallel.parallel_func``): ``n_jobs=1`` runs in this process; an
integer is a number of joblib jobs (processes on this machine; -1 every core, -2 all but
one); ``None`` runs in this process unless a ``joblib.parallel_config`` is active, whose
backend and number of jobs it then takes, so that

.. code-block:: python

    with joblib.parallel_config(backend="dask"):  # a distributed.Client is active
        skf_ref.apply_skf_epochs(epochs, operator)  # n_jobs=None: on the Dask cluster

sends the jobs to the cluster's workers (as many jobs as they have threads). MNE takes a
context whose ``n_jobs`` is set; a context that names a backend other than joblib's default
is taken here too. joblib is needed only when jobs run elsewhere (the extra ``mne`` installs
it).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any

from .checks import InputError, check_int
from .extras import optional

__all__ = ["HERE", "Jobs", "check_n_jobs", "plan_jobs", "run_jobs"]


@dataclass(frozen=True)
class Jobs:
    """How work is run: in this process, or as joblib's jobs.

    Attributes
    ----------
    count : int
        How many parts to cut the work into (one per job), >= 1.
    n_jobs : int or None
        What ``joblib.Parallel`` is given (None: the active context's).
    local : bool
        Whether the work runs in this process, one part after the other.
    """

    count: int
    n_jobs: int | None
    local: bool


#: Work in this process.
HERE = Jobs(1, 1, True)


def check_n_jobs(n_jobs: Any, name: str = "n_jobs") -> int | None:
    """``n_jobs`` as MNE takes it: None, or a nonzero integer.

    Examples
    --------
    >>> check_n_jobs(None), check_n_jobs(2), check_n_jobs(-1)
    (None, 2, -1)
    >>> check_n_jobs(0)
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: n_jobs must be a number of jobs (1: in this ...), got 0
    """
    if n_jobs is None:
        return None
    value = check_int(name, n_jobs, minimum=None)
    if value == 0:
        raise InputError(
            f"{name} must be a number of jobs (1: in this process, -1: every core) or None "
            "(the active joblib.parallel_config's), got 0"
        )
    return value


def _context_active() -> bool:
    """Whether a ``joblib.parallel_config`` sets a number of jobs or a backend of its own."""
    try:
        from joblib.parallel import get_active_backend
    except ImportError:
        return False
    backend, n_jobs = get_active_backend()
    return n_jobs is not None or type(backend).__name__ != "LokyBackend"


def _is_local(backend: Any) -> bool:
    """joblib's own backends run on this machine; a cluster's (Dask, Ray) elsewhere."""
    return type(backend).__module__.startswith("joblib._parallel_backends")


def plan_jobs(n_jobs: Any, what: str = "this") -> Jobs:
    """How many jobs ``n_jobs`` asks for, and where they run (MNE's convention).

    Parameters
    ----------
    n_jobs : int or None
        1: this process; an integer: that many joblib jobs (-1: every core); None: this
        process unless a ``joblib.parallel_config`` is active (then its backend's).
    what : str
        What asks, for the message when joblib is missing.

    Returns
    -------
    Jobs

    Examples
    --------
    >>> plan_jobs(1)
    Jobs(count=1, n_jobs=1, local=True)
    >>> plan_jobs(None).local  # no joblib.parallel_config active
    True
    """
    n_jobs = check_n_jobs(n_jobs)
    if n_jobs == 1 or (n_jobs is None and not _context_active()):
        return HERE
    joblib = optional("joblib", "mne", f"{what} with n_jobs={n_jobs}")
    from joblib.parallel import get_active_backend

    count = max(1, int(joblib.effective_n_jobs(n_jobs)))
    local = count == 1 and _is_local(get_active_backend()[0])
    return HERE if local else Jobs(count, n_jobs, False)


def run_jobs(func: Callable[..., Any], calls: Iterable[tuple], jobs: Jobs) -> Iterator[Any]:
    """``func(*call)`` for each of ``calls``, as ``jobs`` says; the results in order.

    Results are yielded as they come (joblib's ``return_as="generator"``): the caller can
    keep each and drop it before the next arrives.

    Parameters
    ----------
    func : callable
        Importable by name (the jobs elsewhere unpickle it).
    calls : iterable of tuple
        The arguments of each call.
    jobs : Jobs
        :func:`plan_jobs`'s answer.

    Yields
    ------
    object
        ``func(*call)``, in the order of ``calls``.

    Examples
    --------
    >>> list(run_jobs(pow, [(2, 3), (3, 2)], plan_jobs(1)))
    [8, 9]
    """
    if jobs.local:
        for call in calls:
            yield func(*call)
        return
    import joblib

    parallel = joblib.Parallel(n_jobs=jobs.n_jobs, return_as="generator")
    yield from parallel(joblib.delayed(func)(*call) for call in calls)
