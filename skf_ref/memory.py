"""How much memory a reconstruction needs, and how much there is."""

import os

__all__ = ["available_memory", "covariance_memory"]


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
