"""How much memory a reconstruction needs, and how much there is."""

import os

__all__ = ["available_memory", "covariance_memory", "require"]


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
        Bytes allowed; default the available memory (:func:`available_memory`).

    Examples
    --------
    >>> require(2**40, "a test array", budget=2**30)
    Traceback (most recent call last):
    ...
    MemoryError: a test array needs 1.02e+03 GiB, over the 1 GiB available
    """
    budget = available_memory() if budget is None else budget
    if nbytes > budget:
        raise MemoryError(
            f"{what} needs {nbytes / 2**30:.3g} GiB, over the {budget / 2**30:.3g} GiB available"
        )


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
