"""How much memory a reconstruction needs, and how much there is."""

import os

__all__ = ["available_memory", "covariance_memory", "require", "spectral_memory"]


def available_memory():
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


def require(nbytes, what, budget=None):
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
    if budget is None:
        budget, whose = available_memory() / 2, " (half the memory available now)"
    else:
        whose = ""
    if nbytes > budget:
        raise MemoryError(
            f"{what} needs {nbytes / 2**30:.3g} GiB, over the memory budget of "
            f"{budget / 2**30:.3g} GiB{whose}"
        )


def spectral_memory(n_sources, n_channels, n_times):
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


def covariance_memory(n_sources, n_times, method="dense", smoother=None):
    """Bytes the covariance-storing paths need for their (n, n) matrices.

    Parameters
    ----------
    n_sources, n_times : int
    method : {"dense", "filterpy"}
    smoother : {None, "rts-standardized", "rts-state"}

    Returns
    -------
    int
        ``8 n^2 (k T + 8)``: the dense path stores k = 3 matrices a step (``P_{t|t}``,
        ``P_{t|t-1}`` and its inverse square root); the filterpy path stores 2, and filterpy's
        ``rts_smoother`` copies two sequences and adds its gains (k = 5); 8 working matrices.

    Examples
    --------
    >>> covariance_memory(1000, 41) / 2**30  # GiB
    0.976...
    """
    per_step = 3 if method == "dense" else 2 if smoother is None else 5
    return 8 * n_sources**2 * (per_step * n_times + 8)
