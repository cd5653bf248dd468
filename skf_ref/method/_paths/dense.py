"""The SKF and its smoothers in plain numpy: the readable statement of the algorithm.

One loop, one equation a line. Equation numbers are the paper's, with its section, since the
paper reuses tags across sections: §2.2 eqs. (4)-(7) for the filter, §2.3 eq. (4) for the
RTS smoother; docs/model.md states them all. This module is the oracle: every other path
(the filterpy subclass, the spectral path) is compared against it. It stores every
covariance, so it costs O(n^3) per step and O(T n^2) memory.

Symbols: ``L`` lead field (m, n), ``R`` noise covariance (m, m), ``A`` transition (n, n),
``Q`` process covariance (n, n), ``P0`` initial covariance (n, n). Internally time runs
along the first axis, (T, n); the public result is (n, T).
"""

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import linalg

from .._model import StateSpaceModel
from .._result import Reconstruction
from .._standardization import inverse_sqrt, raw_weights, restandardize, standardize

__all__ = ["kalman_filter", "predict", "result", "rts", "run", "smooth", "update"]

_LOG_2PI = np.log(2 * np.pi)
_Array = NDArray[np.float64]


def predict(
    x: NDArray[np.float64],
    P: NDArray[np.float64],
    A: NDArray[np.float64],
    Q: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One prediction, §2.2 eq. (4): ``x_{t|t-1}, P_{t|t-1}`` from ``x_{t-1|t-1}, P_{t-1|t-1}``.

    Parameters
    ----------
    x : ndarray, shape (n_sources,)
    P, A, Q : ndarray, shape (n_sources, n_sources)

    Returns
    -------
    x_pred : ndarray, shape (n_sources,)
    P_pred : ndarray, shape (n_sources, n_sources)
        Symmetrized.
    """
    # x_{t|t-1} = A x_{t-1|t-1}                                     §2.2 (4)
    x_pred = A @ x
    # P_{t|t-1} = A P_{t-1|t-1} A^T + Q                             §2.2 (4)
    P_pred = A @ P @ A.T + Q
    return x_pred, (P_pred + P_pred.T) / 2


def update(
    x_pred: NDArray[np.float64],
    P_pred: NDArray[np.float64],
    y: NDArray[np.float64],
    L: NDArray[np.float64],
    R: NDArray[np.float64],
) -> tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], float
]:
    """One update, §2.2 eq. (5), with the step's innovation log-likelihood.

    Parameters
    ----------
    x_pred : ndarray, shape (n_sources,)
    P_pred : ndarray, shape (n_sources, n_sources)
    y : ndarray, shape (n_channels,)
    L : ndarray, shape (n_channels, n_sources)
    R : ndarray, shape (n_channels, n_channels)

    Returns
    -------
    x : ndarray, shape (n_sources,)
        ``x_{t|t}``.
    P : ndarray, shape (n_sources, n_sources)
        ``P_{t|t}``, symmetrized.
    K : ndarray, shape (n_sources, n_channels)
    S : ndarray, shape (n_channels, n_channels)
    log_likelihood : float
        ``log N(y_t - L x_{t|t-1}; 0, S_t)``.

    Raises
    ------
    scipy.linalg.LinAlgError
        If ``S_t`` is not positive definite in double precision.
    """
    # S_t = L P_{t|t-1} L^T + R                                     §2.2 (5)
    S = L @ P_pred @ L.T + R
    try:
        S_chol = linalg.cho_factor(S, lower=True)
    except linalg.LinAlgError as err:
        eigenvalues = linalg.eigvalsh(S)
        raise linalg.LinAlgError(
            "S_t = L P_t|t-1 L^T + R is not positive definite in double precision (eigenvalues "
            f"from {eigenvalues[0]:.3g} to {eigenvalues[-1]:.3g})"
        ) from err
    # K_t = P_{t|t-1} L^T S_t^{-1}   (a solve with S, never its inverse)   §2.2 (5)
    K = linalg.cho_solve(S_chol, L @ P_pred).T
    # e_t = y_t - L x_{t|t-1}
    e = y - L @ x_pred
    # x_{t|t} = x_{t|t-1} + K_t e_t                                 §2.2 (5)
    x = x_pred + K @ e
    # P_{t|t} = P_{t|t-1} - K_t S_t K_t^T                           §2.2 (5)
    P = P_pred - K @ S @ K.T
    # log N(e_t; 0, S_t) = -(m log 2 pi + log det S_t + e^T S_t^{-1} e) / 2
    log_det = 2 * np.sum(np.log(np.diag(S_chol[0])))
    log_likelihood = -0.5 * (len(y) * _LOG_2PI + log_det + e @ linalg.cho_solve(S_chol, e))
    return x, (P + P.T) / 2, K, S, log_likelihood


def kalman_filter(
    L: NDArray[np.float64],
    Y: NDArray[np.float64],
    R: NDArray[np.float64],
    A: NDArray[np.float64],
    Q: NDArray[np.float64],
    P0: NDArray[np.float64],
    exponent: float,
) -> dict[str, Any]:
    """Run the SKF forward pass (§2.2 eqs. 4-7), keeping every mean and covariance.

    A column of ``Y`` that is all NaN is a missing step (docs/model.md §2): the prediction
    stands, ``x_{t|t} = x_{t|t-1}`` and ``P_{t|t} = P_{t|t-1}``; the step has no weights,
    no ``z`` (NaN) and no term of the log-likelihood.

    Parameters
    ----------
    L : ndarray, shape (n_channels, n_sources)
    Y : ndarray, shape (n_channels, n_times)
    R : ndarray, shape (n_channels, n_channels)
    A, Q, P0 : ndarray, shape (n_sources, n_sources)
    exponent : float

    Returns
    -------
    dict
        ``x_filt``, ``x_pred``, ``z``, raw weights ``w`` and ``weights`` (the diagonal of
        ``W_t^(alpha)``) of shape (n_times, n_sources);
        ``P_filt``, ``P_pred``, ``P_pred_inv_sqrt`` of shape (n_times, n_sources, n_sources);
        ``log_likelihood`` (float); ``missing`` (n_times,), the missing steps.
    """
    n, T = L.shape[1], Y.shape[1]
    out: dict[str, Any] = {
        key: np.full((T, n), np.nan) for key in ("x_filt", "x_pred", "z", "w", "weights")
    }
    for key in ("P_filt", "P_pred", "P_pred_inv_sqrt"):
        out[key] = np.full((T, n, n), np.nan)
    x, P, total = np.zeros(n), P0, 0.0
    for t in range(T):
        x_pred, P_pred = predict(x, P, A, Q)
        out["x_pred"][t], out["P_pred"][t] = x_pred, P_pred
        if np.isnan(Y[0, t]):
            # a missing step: x_{t|t} = x_{t|t-1}, P_{t|t} = P_{t|t-1}   docs/model.md §2
            x, P = x_pred, P_pred
            out["x_filt"][t], out["P_filt"][t] = x, P
            continue
        try:
            x, P, K, S, log_likelihood = update(x_pred, P_pred, Y[:, t], L, R)
            P_pred_inv_sqrt = inverse_sqrt(P_pred)
        except linalg.LinAlgError as err:
            raise linalg.LinAlgError(f"at step {t + 1}: {err}") from err
        w = raw_weights(P_pred_inv_sqrt, K, S)
        weights, z = standardize(w, P_pred_inv_sqrt @ x, exponent)
        total += log_likelihood
        out["x_filt"][t], out["z"][t], out["w"][t], out["weights"][t] = x, z, w, weights
        out["P_filt"][t], out["P_pred_inv_sqrt"][t] = P, P_pred_inv_sqrt
    out["log_likelihood"], out["missing"] = total, np.isnan(Y[0])
    return out


def rts(
    sequence: NDArray[np.float64],
    P_filt: NDArray[np.float64],
    P_pred: NDArray[np.float64],
    A: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The RTS backward pass of §2.3 eq. (4) over a filtered sequence.

    ``s_T = m_T``;  ``s_t = m_t + G_t (s_{t+1} - A m_t)`` with the gain
    ``G_t = P_{t|t} A^T P_{t+1|t}^{-1}``. Over the state ``m_t = x_{t|t}`` (``A x_{t|t}`` is
    ``x_{t+1|t}``) this is the textbook smoother, ``"rts-state"``; over the standardized
    ``m_t = z_{t|t}`` it is the paper's ``"rts-standardized"`` (docs/model.md §3). Over a
    missing step ``P_{t|t} = P_{t|t-1}``, and the state smoother interpolates there.

    Parameters
    ----------
    sequence : ndarray, shape (n_times, n_sources)
    P_filt, P_pred : ndarray, shape (n_times, n_sources, n_sources)
        ``P_{t|t}`` and ``P_{t|t-1}``; ``P_pred[t + 1]`` is ``P_{t+1|t}``.
    A : ndarray, shape (n_sources, n_sources)

    Returns
    -------
    ndarray, shape (n_times, n_sources)
    """
    s = sequence.copy()
    for t in range(len(s) - 2, -1, -1):
        # G_t = P_{t|t} A^T P_{t+1|t}^{-1}  (a solve: P_{t+1|t} G_t^T = A P_{t|t})  §2.3 (4)
        G = linalg.solve(P_pred[t + 1], A @ P_filt[t], assume_a="pos").T
        # s_t = m_t + G_t (s_{t+1} - A m_t)                         §2.3 (4)
        s[t] = sequence[t] + G @ (s[t + 1] - A @ sequence[t])
    return s


def run(
    model: StateSpaceModel, Y: NDArray[np.float64], exponent: float, smoother: str | None
) -> Reconstruction:
    """Filter, smooth if asked, and return the result.

    Parameters
    ----------
    model : StateSpaceModel
    Y : ndarray, shape (n_channels, n_times)
        A column of NaN is a missing step.
    exponent : float
    smoother : {None, "rts-standardized", "rts-state"}
        ``"rts-standardized"`` only without missing steps (the caller checks).

    Returns
    -------
    Reconstruction
    """
    A, Q, P0 = (model.matrix(name) for name in ("transition", "q", "theta0"))
    f = kalman_filter(model.L, Y, model.R, A, Q, P0, exponent)
    x, z = smooth(f, smoother, A, exponent)
    return result(f, x, z, model, exponent, smoother, "dense")


def smooth(
    filtered: dict[str, Any], smoother: str | None, A: _Array, exponent: float
) -> tuple[_Array, _Array]:
    """The smoothed ``x`` and ``z`` (time-major) of :func:`kalman_filter`'s output.

    Parameters
    ----------
    filtered : dict
        :func:`kalman_filter`'s output.
    smoother : {None, "rts-standardized", "rts-state"}
    A : ndarray, shape (n_sources, n_sources)
    exponent : float

    Returns
    -------
    x, z : ndarray, shape (n_times, n_sources)
        The filtered ones for ``smoother=None``.
    """
    f = filtered
    x, z = f["x_filt"], f["z"]
    if smoother == "rts-standardized":
        # the paper's smoother: RTS over the standardized sequence (docs/model.md §3)
        z = rts(f["z"], f["P_filt"], f["P_pred"], A)
    elif smoother == "rts-state":
        # textbook RTS on the state, then z^s_t = W_t^(alpha) P_{t|t-1}^{-1/2} x^s_t
        x = rts(f["x_filt"], f["P_filt"], f["P_pred"], A)
        z = restandardize(f["w"], f["P_pred_inv_sqrt"], x, exponent)
    return x, z


def result(
    filtered: dict[str, Any],
    x: NDArray[np.float64],
    z: NDArray[np.float64],
    model: StateSpaceModel,
    exponent: float,
    smoother: str | None,
    method: str,
) -> Reconstruction:
    """The result of a covariance-storing path (dense, filterpy) from its time-major
    (n_times, n_sources) filter output and its (smoothed) ``x`` and ``z``."""
    return Reconstruction(
        z=z.T,
        x=x.T,
        z_filtered=filtered["z"].T,
        x_filtered=filtered["x_filt"].T,
        weights=filtered["weights"].T,
        log_likelihood=filtered["log_likelihood"],
        n_sources=model.n_sources,
        n_times=len(z),
        exponent=exponent,
        smoother=smoother,
        method=method,
        theta0=model.theta0,
        q=model.q,
        transition=model.transition,
        missing=filtered.get("missing"),  # None: every step observed
        min_raw_weight=float(np.nanmin(filtered["w"])),
    )
