"""Work on every core: worker threads, each on one BLAS thread.

The spectral path cuts its products and elementwise passes into tiles and runs them here;
so does the amplitude of a time-major output.
"""

import collections
import functools
import itertools
import threading
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

__all__ = ["map_threads", "one_blas_thread"]

_T = TypeVar("_T")


@functools.cache
def _blas() -> Any:
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def one_blas_thread() -> Any:
    """A context in which BLAS runs on one thread (threadpoolctl), for small products."""
    return _blas().select(user_api="blas").limit(limits=1)


def map_threads(func: Callable[[_T], Any], items: Iterable[_T]) -> Iterator[Any]:
    """``func`` over ``items`` in worker threads, the results in the order of ``items``.

    One worker per BLAS thread this process may use (threadpoolctl: a caller that limits
    BLAS, as joblib's workers do, limits this too), each on one BLAS thread, so the
    elementwise work between BLAS calls runs on every core as well, and a core another
    process keeps busy slows one worker, not every call. Results are consumed in order, at
    most two per worker ahead, so sums over them are the same whatever the number of
    workers, and memory stays bounded. The workers persist between calls (starting a
    thread costs a millisecond or two); a call from inside a worker runs in that worker.

    Parameters
    ----------
    func : callable
        Must release the GIL for most of its time (numpy, BLAS, LAPACK do).
    items : iterable

    Yields
    ------
    object
        ``func(item)`` for each item, in order.

    Examples
    --------
    >>> list(map_threads(lambda k: k * k, range(5)))
    [0, 1, 4, 9, 16]
    """
    controller = _blas().select(user_api="blas")
    workers = max((entry["num_threads"] for entry in controller.info()), default=1)
    if workers < 2 or getattr(_WORKER, "active", False):
        yield from map(func, items)
        return
    pool = _pool(workers)

    def run(item: _T) -> Any:
        _WORKER.active = True
        try:
            return func(item)
        finally:
            _WORKER.active = False

    items = iter(items)
    with controller.limit(limits=1):
        pending = collections.deque(
            pool.submit(run, i) for i in itertools.islice(items, 2 * workers)
        )
        while pending:
            result = pending.popleft().result()
            pending.extend(pool.submit(run, i) for i in itertools.islice(items, 1))
            yield result


_WORKER = threading.local()
_POOLS: dict[int, ThreadPoolExecutor] = {}
_POOLS_LOCK = threading.Lock()


def _pool(workers: int) -> ThreadPoolExecutor:
    """The persistent pool of ``workers`` threads."""
    with _POOLS_LOCK:
        if workers not in _POOLS:
            _POOLS[workers] = ThreadPoolExecutor(workers, thread_name_prefix="skf_ref")
        return _POOLS[workers]
