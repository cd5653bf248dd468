"""How much memory a reconstruction needs, and how much there is."""

import os

__all__ = [
    "available_memory",
    "check_reconstruction",
    "covariance_memory",
    "memory_budget",
    "require",
    "spectral_memory",
]


def available_memory() -> int:
    """Bytes of memory available to new allocations (``MemAvailable`` on Linux).

    Returns
    -------
    int
    """
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def memory_budget(memory_limit: float | None = None) -> float:
    """The bytes a computation may use: ``memory_limit``, or by default half the memory
    available now (:func:`available_memory`).

    Examples
    --------
    >>> memory_budget(2**30)
    1073741824.0
    """
    return available_memory() / 2 if memory_limit is None else float(memory_limit)


def require(nbytes: float, what: str, budget: float | None = None) -> None:
    """Raise ``MemoryError`` before allocating ``nbytes`` that do not fit.

    Parameters
    ----------
    nbytes : int
    what : str
        What the bytes are for, for the message.
    budget : float, optional
        Bytes allowed; default half the memory available now (:func:`available_memory`).

    Examples
    --------
    >>> require(2**40, "a test array", budget=2**30)
    Traceback (most recent call last):
    ...
    MemoryError: a test array needs 1.02e+03 GiB, over the memory budget of 1 GiB
    """
    whose = " (half the memory available now)" if budget is None else ""
    allowed = memory_budget(budget)
    if nbytes > allowed:
        raise MemoryError(
            f"{what} needs {nbytes / 2**30:.3g} GiB, over the memory budget of "
            f"{allowed / 2**30:.3g} GiB{whose}"
        )


def spectral_memory(n_sources: int, n_channels: int, n_times: int) -> int:
    """Bytes the spectral path needs for its model, before any (n, T) output.

    Parameters
    ----------
    n_sources, n_channels, n_times : int

    Returns
    -------
    int
        ``8 (4 n m + 8 m T)``: ``V`` and ``V o V`` (n x r each, r <= m), about as much
        again for the SVD, and the r x T recursions. Each output asked for in memory needs
        ``8 n T`` more (checked when it is asked for); streamed (``Reconstruction.to_zarr``,
        ``.blocks``, ``.to_dask``) a few blocks of about 4 MiB.

    Examples
    --------
    >>> round(spectral_memory(150_000, 128, 1000) / 2**30, 2)  # GiB
    0.58
    """
    return 8 * (4 * n_sources * n_channels + 8 * n_channels * n_times)


def covariance_memory(
    n_sources: int, n_times: int, path: str = "dense", smoother: str | None = None
) -> int:
    """Bytes the covariance-storing paths need for their (n, n) matrices.

    Parameters
    ----------
    n_sources, n_times : int
    path : {"dense", "filterpy"}
    smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}

    Returns
    -------
    int
        ``8 n^2 (k T + 8)``: the dense path stores k = 3 matrices a step (``P_{t|t}``,
        ``P_{t|t-1}`` and its inverse square root); the filterpy path stores 2, and filterpy's
        ``rts_smoother`` copies two sequences and adds its gains (k = 5); 8 working matrices.
        ``"rts-smoothed-weights"`` adds the prior covariances ``Sigma_t`` (k + 1) and, on the
        dense path, the smoothed ``P^s_t`` (k + 2).

    Examples
    --------
    >>> covariance_memory(1000, 41) / 2**30  # GiB
    0.976...
    """
    per_step = 3 if path == "dense" else 2 if smoother is None else 5
    if smoother == "rts-smoothed-weights":
        per_step += 2 if path == "dense" else 1
    return 8 * n_sources**2 * (per_step * n_times + 8)


def check_reconstruction(
    path: str,
    smoother: str | None,
    n_sources: int,
    n_channels: int,
    n_times: int,
    memory_limit: float | None = None,
) -> None:
    """Refuse, before any work, a reconstruction that does not fit in the memory budget.

    Parameters
    ----------
    path : {"spectral", "dense", "filterpy"}
    smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}
    n_sources, n_channels, n_times : int
        The lead field's columns, its rows (or the whitened data's rank) and the steps.
    memory_limit : float, optional
        Bytes allowed; default half the available memory (:func:`memory_budget`).

    Raises
    ------
    MemoryError
        Saying what needs the memory and what to do instead.

    Examples
    --------
    >>> check_reconstruction("dense", None, 5000, 64, 100, memory_limit=2**30)
    Traceback (most recent call last):
    ...
    MemoryError: path='dense' stores 100 covariances of 5000^2 entries: about 57.4 GiB, ...
    """
    allowed = memory_budget(memory_limit)
    if path == "spectral":
        needed = spectral_memory(n_sources, n_channels, n_times)
        if needed > allowed:
            raise MemoryError(
                f"path='spectral' needs about {needed / 2**30:.3g} GiB for its model (the "
                f"SVD of a ({n_channels}, {n_sources}) lead field and {n_times} steps of its "
                f"recursions), over the memory budget of {allowed / 2**30:.3g} GiB "
                "(memory_limit; default half the available memory); reconstruct shorter "
                "segments of the data"
            )
        return
    needed = covariance_memory(n_sources, n_times, path, smoother)
    if needed > allowed:
        raise MemoryError(
            f"path={path!r} stores {n_times} covariances of {n_sources}^2 entries: about "
            f"{needed / 2**30:.3g} GiB, over the memory budget of {allowed / 2**30:.3g} GiB "
            "(memory_limit; default half the available memory). For random-walk models with "
            "isotropic priors use path='spectral', which never forms an n_sources^2 matrix."
        )
