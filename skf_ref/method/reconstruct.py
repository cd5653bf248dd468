"""The public entry point :func:`reconstruct`: check once, build the model, pick a path."""

import numpy as np

from .._utils import memory
from .._utils.checks import InputError, check_choice, check_real
from .model import StateSpaceModel
from .paths import dense, spectral
from .paths import filterpy_skf as kalman

__all__ = ["METHODS", "SMOOTHERS", "check_smoother", "reconstruct"]

SMOOTHERS = (None, "rts-standardized", "rts-state")
METHODS = ("auto", "filterpy", "dense", "spectral")


def check_smoother(smoother):
    """The smoother, with ``"none"`` (the command line's and the results tables' word) as None.

    Examples
    --------
    >>> check_smoother("none") is None, check_smoother("rts-state")
    (True, 'rts-state')
    """
    if isinstance(smoother, str) and smoother == "none":
        return None
    try:
        return check_choice("smoother", smoother, SMOOTHERS)
    except InputError:
        raise InputError(
            f"smoother must be one of {[*SMOOTHERS, 'none']!r}, got {smoother!r}"
        ) from None


def _check_memory(method, smoother, model, n_times, memory_limit):
    """Refuse, before any work, a run that does not fit in the memory budget."""
    n, m = model.n_sources, model.n_channels
    budget = memory.available_memory() / 2 if memory_limit is None else memory_limit
    if method == "spectral":
        needed = memory.spectral_memory(n, m, n_times)
        if needed > budget:
            raise MemoryError(
                f"method='spectral' needs about {needed / 2**30:.3g} GiB for its model (the "
                f"SVD of a ({m}, {n}) lead field and {n_times} steps of its recursions), over "
                f"the memory budget of {budget / 2**30:.3g} GiB (memory_limit; default half "
                "the available memory); reconstruct shorter segments of the data"
            )
        return
    needed = memory.covariance_memory(n, n_times, method, smoother)
    if needed > budget:
        raise MemoryError(
            f"method={method!r} stores {n_times} covariances of {n}^2 entries: about "
            f"{needed / 2**30:.3g} GiB, over the memory budget of {budget / 2**30:.3g} GiB "
            "(memory_limit; default half the available memory). For random-walk models with "
            "isotropic priors use method='spectral', which never forms an n_sources^2 matrix."
        )


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

    The model (docs/model.md §1): ``x_t = A x_{t-1} + q_t``, ``y_t = L x_t + r_t`` with
    ``q_t ~ N(0, Q)``, ``r_t ~ N(0, R)``, ``x_0 ~ N(0, P_0)``; the filter is §2.2 eqs.
    (4)-(7) of Prasikala et al. (2025), the smoothers §2.3.

    ``L`` and ``Y`` must carry the same reference: if the data are average referenced,
    average-reference the lead field too (subtract each column's channel mean). Average
    referenced data with an unreferenced ``L`` are refused (to the precision the numbers
    carry, float32 included); other mismatches cannot be seen in the arrays, and give a
    wrong estimate without an error (docs/model.md §1).

    Which setting to use. The defaults, exponent 0.5 without smoothing (the original SKF,
    :data:`skf_ref.RECOMMENDED_SETTING`), are what the study recommends: on a realistic head with
    cortex + thalamus they tell a deep source present from absent about as well as MNE's
    sLORETA. The paper's setting, :data:`skf_ref.PAPER_SETTING` (exponent 1.25, smoothed), puts
    activity in the deep region whether or not a deep source is there: a "detection" there
    means little (validation/report/REPORT.md, "Which setting, and against what").

    Parameters
    ----------
    L : array_like, shape (n_channels, n_sources)
        Lead field. Free orientation: three columns per position, MNE's order.
    Y : array_like, shape (n_channels, n_times)
        Data, with the same reference as ``L``.
    noise_std : float, optional
        Noise standard deviation sigma: ``R = sigma**2 I``. Give this or ``noise_cov``.
    noise_cov : array_like, shape (n_channels, n_channels), optional
        Noise covariance R, symmetric positive definite.
    theta0 : float or array_like, shape (n_sources, n_sources)
        Initial covariance: ``P_0 = theta0 I`` for a scalar, else the SPD matrix itself.
    q : float or array_like, shape (n_sources, n_sources)
        Process covariance: ``Q = q I`` (``q >= 0``) for a scalar, else the SPD matrix.
    exponent : float
        Standardization exponent alpha of §2.2 eq. (7), >= 0. 0.5 is the original SKF.
    smoother : {None, "rts-standardized", "rts-state"}
        None (or ``"none"``, as the command line and results tables write it): the filter
        only. ``"rts-standardized"`` is the paper's smoother over the standardized sequence;
        ``"rts-state"`` the textbook RTS on the state, standardized afterwards
        (docs/model.md §3).
    method : {"auto", "filterpy", "dense", "spectral"}
        Computational path; all give the same result to rounding. ``"spectral"`` (exact,
        fast, memory O(n r + n T)) needs scalar (isotropic) ``transition``, ``q`` and
        ``theta0``; ``"auto"`` takes it whenever the model qualifies and ``"dense"``
        otherwise. ``"filterpy"`` is the filterpy subclass.
    transition : float or array_like, shape (n_sources, n_sources)
        ``A = transition * I`` for a scalar (1: random walk, §3.1 eq. 8), else the matrix.
    memory_limit : float, optional
        Bytes the reconstruction may use; default half the available memory. Checked
        before any work: the covariance-storing paths need ``8 n^2 (k T + 8)`` bytes, the
        spectral path ``8 n (4 m + T)`` for its model and one output (each further output
        asked for ``8 n T`` more, checked when it is asked for).

    Returns
    -------
    Reconstruction

    Raises
    ------
    skf_ref.InputError
        A parameter is out of range or inconsistent (a ``ValueError``; a ``TypeError``
        too when it is the wrong kind of object).
    MemoryError
        The chosen path would need more than ``memory_limit``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> L = rng.standard_normal((8, 12))
    >>> Y = L[:, [3]] * np.hanning(7) + 0.1 * rng.standard_normal((8, 7))
    >>> rec = reconstruct(L, Y, noise_std=0.1, theta0=1.0, q=0.1, smoother="rts-standardized")
    >>> rec
    <Reconstruction | 12 sources x 7 steps, spectral, exponent 0.5, rts-standardized>
    >>> int(np.argmax(np.abs(rec.z[:, 3])))
    3
    """
    model = StateSpaceModel.create(
        L, noise_std=noise_std, noise_cov=noise_cov, theta0=theta0, q=q, transition=transition
    )
    Y = model.check_data(Y)
    exponent = check_real("exponent", exponent, nonnegative=True)
    if memory_limit is not None:
        memory_limit = check_real("memory_limit", memory_limit, positive=True)
    smoother = check_smoother(smoother)
    check_choice("method", method, METHODS)
    problem = model.isotropic_problem()
    if method == "auto":
        method = "dense" if problem else "spectral"
    if method == "spectral" and problem:
        raise InputError(f"method='spectral' needs A = a I, Q = q I, P_0 = theta0 I: {problem}")
    _check_memory(method, smoother, model, Y.shape[1], memory_limit)
    if method == "spectral":
        return spectral.run(model, Y, exponent, smoother, memory_limit)
    path = kalman.run if method == "filterpy" else dense.run
    try:
        return path(model, Y, exponent, smoother)
    except np.linalg.LinAlgError as err:
        hint = (
            ""
            if problem
            else "; method='spectral' computes this isotropic model exactly without forming "
            "these matrices"
        )
        raise InputError(f"method={method!r} failed {str(err).rstrip('.')}{hint}") from err
