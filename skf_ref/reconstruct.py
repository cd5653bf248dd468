"""The public entry point: validate once, build the model, pick a path."""

import os

import numpy as np

from . import dense, kalman, spectral
from ._validation import (
    check_array,
    check_choice,
    check_leadfield,
    check_real,
    check_scalar_or_spd,
    check_spd,
    check_transition,
)

__all__ = ["reconstruct", "SMOOTHERS", "METHODS"]

SMOOTHERS = (None, "rts-standardized", "rts-state")
METHODS = ("auto", "filterpy", "dense", "spectral")


def available_memory():
    """Bytes of memory available to new allocations (``MemAvailable`` on Linux)."""
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


def _check_memory(method, smoother, n_sources, n_times, memory_limit):
    needed = covariance_memory(n_sources, n_times, method, smoother)
    budget = available_memory() / 2 if memory_limit is None else memory_limit
    if needed > budget:
        raise MemoryError(
            f"method={method!r} stores {n_times} covariances of {n_sources}^2 entries: about "
            f"{needed / 2**30:.3g} GiB, over the memory budget of {budget / 2**30:.3g} GiB "
            "(memory_limit; default half the available memory). For random-walk models with "
            "isotropic priors use method='spectral', which never forms an n_sources^2 matrix."
        )


def _as_matrix(value, n):
    return value * np.eye(n) if np.ndim(value) == 0 else value


def _validated(L, Y, noise_std, noise_cov, theta0, q, transition, exponent):
    """The model's arrays and scalars, checked; R as a matrix."""
    L = check_leadfield(L)
    m, n = L.shape
    Y = check_array("Y", Y, (m, None))
    if Y.shape[1] < 1:
        raise ValueError("Y must have at least one time step (column)")
    if (noise_std is None) == (noise_cov is None):
        raise ValueError("give exactly one of noise_std (a scalar) or noise_cov (a matrix)")
    if noise_std is not None:
        R = check_real("noise_std", noise_std, positive=True) ** 2 * np.eye(m)
    else:
        R = check_spd("noise_cov", noise_cov, m)
    theta0 = check_scalar_or_spd("theta0", theta0, n)
    q = check_scalar_or_spd("q", q, n, allow_zero=True)
    A = check_transition(transition, n)
    exponent = check_real("exponent", exponent, nonnegative=True)
    if np.ndim(q) == 0 and q == 0 and np.ndim(A) == 0 and A == 0:
        raise ValueError("q must be > 0 when transition is 0: P_t|t-1 would be 0")
    return L, Y, R, theta0, q, A, exponent


def reconstruct(
    L,
    Y,
    *,
    noise_std=None,
    noise_cov=None,
    theta0,
    q,
    exponent=0.5,
    smoother=None,
    method="auto",
    transition=1.0,
    memory_limit=None,
):
    """Standardized Kalman filter (and smoother) reconstruction of EEG sources.

    The model (spec §1-3): ``x_t = A x_{t-1} + q_t``, ``y_t = L x_t + r_t`` with
    ``q_t ~ N(0, Q)``, ``r_t ~ N(0, R)``, ``x_0 ~ N(0, P_0)``.

    Parameters
    ----------
    L : array_like, shape (n_channels, n_sources)
        Lead field. Free orientation: three columns per position, MNE's order.
    Y : array_like, shape (n_channels, n_times)
        Data.
    noise_std : float, optional
        Noise standard deviation sigma: ``R = sigma**2 I``. Give this or ``noise_cov``.
    noise_cov : array_like, shape (n_channels, n_channels), optional
        Noise covariance R, symmetric positive definite.
    theta0 : float or array_like, shape (n_sources, n_sources)
        Initial covariance: ``P_0 = theta0 I`` for a scalar, else the SPD matrix itself.
    q : float or array_like, shape (n_sources, n_sources)
        Process covariance: ``Q = q I`` (``q >= 0``) for a scalar, else the SPD matrix.
    exponent : float
        Standardization exponent alpha of eq. (7), >= 0. 0.5 is the original SKF.
    smoother : {None, "rts-standardized", "rts-state"}
        ``"rts-standardized"`` is the paper's smoother over the standardized sequence;
        ``"rts-state"`` the textbook RTS on the state, standardized afterwards.
    method : {"auto", "filterpy", "dense", "spectral"}
        Computational path; all give the same result to rounding. ``"spectral"`` (exact,
        fast, memory O(n r + n T)) needs scalar (isotropic) ``transition``, ``q`` and
        ``theta0``; ``"auto"`` takes it whenever the model qualifies and ``"dense"``
        otherwise. ``"filterpy"`` is the filterpy subclass.
    transition : float or array_like, shape (n_sources, n_sources)
        ``A = transition * I`` for a scalar (1: random walk, eq. 8), else the matrix.
    memory_limit : float, optional
        Bytes the covariance-storing paths may use; default half the available memory.

    Returns
    -------
    Reconstruction

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> L = rng.standard_normal((8, 12))
    >>> Y = L[:, [3]] * np.hanning(7) + 0.1 * rng.standard_normal((8, 7))
    >>> rec = reconstruct(L, Y, noise_std=0.1, theta0=1.0, q=0.1, smoother="rts-standardized")
    >>> rec.z.shape, rec.weights.shape
    ((12, 7), (12, 7))
    >>> int(np.argmax(np.abs(rec.z[:, 3])))
    3
    """
    L, Y, R, theta0, q, A, exponent = _validated(
        L, Y, noise_std, noise_cov, theta0, q, transition, exponent
    )
    if memory_limit is not None:
        memory_limit = check_real("memory_limit", memory_limit, positive=True)
    check_choice("smoother", smoother, SMOOTHERS)
    check_choice("method", method, METHODS)
    n = L.shape[1]
    problem = spectral.qualification_problem(A, q, theta0)
    if method == "auto":
        method = "dense" if problem else "spectral"
    if method == "spectral":
        if problem:
            raise ValueError(
                f"method='spectral' needs A = a I, Q = q I, P_0 = theta0 I: {problem}"
            )
        return spectral.run(L, Y, R, A, q, theta0, exponent, smoother)
    _check_memory(method, smoother, n, Y.shape[1], memory_limit)
    path = kalman.run if method == "filterpy" else dense.run
    try:
        return path(
            L, Y, R, _as_matrix(A, n), _as_matrix(q, n), _as_matrix(theta0, n), exponent, smoother
        )
    except np.linalg.LinAlgError as err:
        raise ValueError(
            f"the predicted covariance P_t|t-1 = A P A^T + Q is singular ({err}): "
            "give q > 0 or an invertible transition"
        ) from err
