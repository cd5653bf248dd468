"""The public entry point :func:`reconstruct`: check once, build the model, pick a path."""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils import memory
from .._utils.checks import InputError, InputTypeError, check_real, path_renamed
from .._utils.log import caller_stacklevel
from ._model import StateSpaceModel, missing_steps
from ._paths import dense, spectral
from ._paths import filterpy_skf as kalman
from ._result import Reconstruction
from ._settings import Settings, check_gaps, check_settings
from ._standardization import check_positions_seen

__all__ = ["reconstruct", "run_checked", "slow_path_seconds"]

#: The speed assumed for the dense and filterpy paths' estimate (operations a second).
#: Each of their steps is an eigendecomposition and products of (n, n) matrices, about
#: 20 n^3 operations, which ran at 1.7e9 a second on a two-core laptop beside other work
#: (``eigh`` runs far below BLAS's peak): the estimate errs long.
_FLOPS_PER_SECOND = 1e9
#: A dense or filterpy run estimated to take longer than this (seconds) warns first.
_WARN_SECONDS = 10.0


def slow_path_seconds(n_sources: int, n_channels: int, n_times: int) -> float:
    """The seconds a dense or filterpy run is estimated to take, at most.

    ``(20 n^3 + 8 n^2 m) T`` operations (an eigendecomposition and the products of a step
    of §2.2, in (n, n) and (n, m) matrices) at 1e9 operations a second, a rate a busy
    laptop beats: the estimate errs long.

    Parameters
    ----------
    n_sources, n_channels, n_times : int

    Returns
    -------
    float

    Examples
    --------
    >>> round(slow_path_seconds(600, 64, 100))
    450
    """
    operations = (20 * n_sources**3 + 8 * n_sources**2 * n_channels) * n_times
    return operations / _FLOPS_PER_SECOND


def _warn_if_slow(path: str, model: StateSpaceModel, n_times: int, isotropic: bool) -> None:
    """Warn, before any work, of a covariance-storing run estimated to take long."""
    seconds = slow_path_seconds(model.n_sources, model.n_channels, n_times)
    if seconds <= _WARN_SECONDS:
        return
    instead = (
        "; path='spectral' computes this isotropic model exactly in a fraction of that"
        if isotropic
        else ""
    )
    warnings.warn(
        f"path={path!r} on {model.n_sources} sources x {n_times} steps is estimated to "
        f"take {seconds:.3g} s (about 20 n^3 operations a step, at {_FLOPS_PER_SECOND:.0e} "
        f"a second){instead}",
        UserWarning,
        stacklevel=caller_stacklevel(),
    )


_NO_PRIORS = (
    "reconstruct needs the priors theta0 and q (docs/model.md §4), got {got}: from SNRs in "
    "dB, theta0, q = skf_ref.priors_from_snr(L, noise_std, pm_snr_db=0.0, ep_snr_db=20.0, "
    "n_steps=Y.shape[1]) (the settings the paper starts from), or chosen by the data, "
    "result = skf_ref.tune(L, Y, noise_std=...) and then theta0=result.theta0, q=result.q"
)


@path_renamed
def reconstruct(
    L: ArrayLike,
    Y: ArrayLike,
    *,
    noise_std: float | None = None,
    noise_cov: ArrayLike | None = None,
    theta0: float | ArrayLike | None = None,
    q: float | ArrayLike | None = None,
    exponent: float = 0.5,
    smoother: str | None = None,
    path: str = "auto",
    transition: float | ArrayLike = 1.0,
    memory_limit: float | None = None,
    standardize: str = "column",
    n_orient: int | None = None,
) -> Reconstruction:
    """Standardized Kalman filter (and smoother) reconstruction of EEG sources.

    The model (docs/model.md §1): ``x_t = A x_{t-1} + q_t``, ``y_t = L x_t + r_t`` with
    ``q_t ~ N(0, Q)``, ``r_t ~ N(0, R)``, ``x_0 ~ N(0, P_0)``; the filter is §2.2 eqs.
    (4)-(7) of Prasikala et al. (2025), the smoothers §2.3.

    The priors ``theta0`` and ``q`` have no default: they set how strongly the estimate
    follows the data, and the right values depend on the lead field, the noise and the
    number of steps. :func:`skf_ref.priors_from_snr` gives them from two SNRs in dB
    (docs/model.md §4; the paper's settings are PM-SNR 0 dB and EP-SNR 0 or 20 dB), and
    :func:`skf_ref.tune` chooses them from the data.

    ``L`` and ``Y`` must carry the same reference: if the data are average referenced,
    average-reference the lead field too (subtract each column's channel mean). Average
    referenced data with an unreferenced ``L`` are refused (to the precision the numbers
    carry, float32 included); other mismatches cannot be seen in the arrays, and give a
    wrong estimate without an error (docs/model.md §1).

    Which setting to use. Here the defaults are the filter alone at exponent 0.5. An array
    does not say which columns form a position, so ``standardize`` defaults to ``"column"``:
    for a free-orientation lead field (three columns per position, MNE's order) pass
    ``standardize="position", n_orient=3`` (the MNE routes, :func:`skf_ref.apply_skf`, take
    ``n_orient`` from the forward and default to the package's recommended setting,
    docs/choosing.md). The paper's setting is :data:`skf_ref.PAPER_SETTING` (exponent 1.25,
    smoothed; docs/model.md §7 on what it does to a deep region).

    Missing steps. A column of ``Y`` that is all NaN is a step without a measurement (a bad
    segment, say): the filter predicts across it without an update, so nothing of it
    reaches the estimate at other steps, and the standardized outputs there are NaN
    (docs/model.md §2). A column NaN in some channels only is refused.

    Parameters
    ----------
    L : array_like, shape (n_channels, n_sources)
        Lead field. Free orientation: three columns per position, MNE's order.
    Y : array_like, shape (n_channels, n_times)
        Data, with the same reference as ``L``; a column of NaN is a missing step.
    noise_std : float, optional
        Noise standard deviation sigma: ``R = sigma**2 I``. Give this or ``noise_cov``.
    noise_cov : array_like, shape (n_channels, n_channels), optional
        Noise covariance R, symmetric positive definite.
    theta0 : float or array_like, shape (n_sources, n_sources)
        Initial covariance: ``P_0 = theta0 I`` for a scalar, else the SPD matrix itself.
        Required (see above).
    q : float or array_like, shape (n_sources, n_sources)
        Process covariance: ``Q = q I`` (``q >= 0``) for a scalar, else the SPD matrix.
        Required (see above).
    exponent : float
        Standardization exponent alpha of §2.2 eq. (7), >= 0. 0.5 is the original SKF.
    smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}
        None (or ``"none"``, as the command line and results tables write it): the filter
        only. ``"rts-standardized"`` is the paper's smoother over the standardized sequence
        (undefined over missing steps: refused there); ``"rts-state"`` the textbook RTS on
        the state, standardized afterwards with the filter's weights;
        ``"rts-smoothed-weights"`` the same smoothed state standardized by its own
        variance, the sLORETA principle applied to the smoothed estimate (defined at
        missing steps too). docs/model.md §3.
    path : {"auto", "filterpy", "dense", "spectral"}
        Computational path; all give the same result to rounding. ``"spectral"`` (exact,
        fast, memory O(n r + n T)) needs scalar (isotropic) ``transition``, ``q`` and
        ``theta0``; ``"auto"`` takes it whenever the model qualifies and ``"dense"``
        otherwise. ``"filterpy"`` is the filterpy subclass. The dense and filterpy paths
        cost about 20 n^3 operations a step and warn first when a run is estimated to
        take more than 10 s.
    transition : float or array_like, shape (n_sources, n_sources)
        ``A = transition * I`` for a scalar (1: random walk, §3.1 eq. 8), else the matrix.
    memory_limit : float, optional
        Bytes the reconstruction may use; default half the available memory. Checked
        before any work: the covariance-storing paths need ``8 n^2 (k T + 8)`` bytes, the
        spectral path ``8 n (4 m + T)`` for its model and one output (each further output
        asked for ``8 n T`` more, checked when it is asked for).
    standardize : {"column", "position"}
        ``"column"`` (the paper's, the default here, as an array does not say which columns
        form a position) standardizes each column of ``L`` by its own weight;
        ``"position"`` (the MNE routes' default; pass ``n_orient=3`` for a free-orientation
        lead field) each source position's ``n_orient`` columns by their block of the weights
        matrix, as sLORETA does for free orientations (Pascual-Marqui 2002): the result
        then does not depend on the coordinate axes, and a noise-free dipole of
        any orientation is found at its position at the first step (docs/model.md §2).
    n_orient : {1, 3}, optional
        Columns per source position (3 for free orientation, MNE's x, y, z order; 1 for
        fixed). Required by ``standardize="position"``.

    Returns
    -------
    Reconstruction

    Raises
    ------
    skf_ref.InputError
        A parameter is out of range or inconsistent (a ``ValueError``; a ``TypeError``
        too when it is the wrong kind of object, or the priors are not given).
    MemoryError
        The chosen path would need more than ``memory_limit``.

    Warns
    -----
    UserWarning
        A dense or filterpy run estimated to take more than 10 s, before it starts.

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

    A missing step (a column of NaN) has no standardized estimate; the others do:

    >>> Y[:, 2] = np.nan
    >>> rec = reconstruct(L, Y, noise_std=0.1, theta0=1.0, q=0.1)
    >>> np.isnan(rec.z).all(axis=0).tolist()
    [False, False, True, False, False, False, False]
    """
    if theta0 is None or q is None:
        missing = [name for name, value in (("theta0", theta0), ("q", q)) if value is None]
        raise InputTypeError(_NO_PRIORS.format(got=f"no {' and no '.join(missing)}"))
    model = StateSpaceModel.create(
        L, noise_std=noise_std, noise_cov=noise_cov, theta0=theta0, q=q, transition=transition
    )
    data = model.check_data(Y)
    settings = check_settings(
        exponent, smoother, path, standardize, n_orient, n_sources=model.n_sources
    )
    if memory_limit is not None:
        memory_limit = check_real("memory_limit", memory_limit, positive=True)
    check_gaps(settings.smoother, missing_steps(data))
    return run_checked(model, data, settings, memory_limit)


def run_checked(
    model: StateSpaceModel,
    Y: NDArray[np.float64],
    settings: Settings,
    memory_limit: float | None,
    prepared: Callable[[], spectral.SpectralModel] | None = None,
) -> Reconstruction:
    """Pick the path, check the memory (and the time) it needs, and run it.

    The one kernel behind :func:`reconstruct` and :meth:`skf_ref.SKFOperator.reconstruct`:
    everything it is given is checked, and nothing is checked again.

    Parameters
    ----------
    model : StateSpaceModel
    Y : ndarray, shape (n_channels, n_times)
        Checked by ``model.check_data``.
    settings : Settings
        Checked by :func:`check_settings` and :func:`check_gaps`.
    memory_limit : float or None
        Checked.
    prepared : callable, optional
        Returns the spectral path's prepared model (an operator's, which keeps its SVD and
        recursions); by default one is made for ``model``.

    Returns
    -------
    Reconstruction
    """
    smoother, path = settings.smoother, settings.path
    problem = model.isotropic_problem()
    if path == "auto":
        path = "dense" if problem else "spectral"
    if path == "spectral" and problem:
        raise InputError(f"path='spectral' needs A = a I, Q = q I, P_0 = theta0 I: {problem}")
    n, m, T = model.n_sources, model.n_channels, Y.shape[1]
    if path != "spectral":
        _warn_if_slow(path, model, T, problem is None)
        if problem is None:  # isotropic priors: a singular block is a dependent position
            check_positions_seen(model.L, model.R, settings.block)
    memory.check_reconstruction(path, smoother, n, m, T, memory_limit)
    if path == "spectral":
        if prepared is None:
            return spectral.run(model, Y, settings, memory_limit)
        return prepared()._checked_apply(Y, settings, memory_limit)
    run = kalman.run if path == "filterpy" else dense.run
    try:
        return run(model, Y, settings)
    except np.linalg.LinAlgError as err:
        hint = (
            ""
            if problem
            else "; path='spectral' computes this isotropic model exactly without forming "
            "these matrices"
        )
        raise InputError(f"path={path!r} failed {str(err).rstrip('.')}{hint}") from err
