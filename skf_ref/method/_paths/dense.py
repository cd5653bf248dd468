"""The SKF and its smoothers in plain numpy: the readable statement of the algorithm.

One loop, one equation a line. Equation numbers are the paper's, with its section, since the
paper reuses tags across sections: §2.2 eqs. (4)-(7) for the filter, §2.3 eq. (4) for the
RTS smoother; docs/model.md states them all, and the two options beyond the paper: the
standardization per position (§2) and the smoother standardized by its own variance (§3).
This module is the oracle: every other path (the filterpy subclass, the spectral path) is
compared against it. It stores every covariance, so it costs O(n^3) per step and O(T n^2)
memory.

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
from .._standardization import (
    apply_blocks,
    block_diagonal,
    inverse_sqrt,
    raw_blocks,
    raw_weights,
    restandardize,
    restandardize_blocks,
    standardize_smoothed,
    weight_blocks,
)

__all__ = [
    "kalman_filter",
    "predict",
    "prior_covariances",
    "result",
    "rts",
    "rts_covariances",
    "run",
    "smooth",
    "update",
]

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
    block: int = 1,
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
    block : int
        Columns standardized together: 1, each column on its own (the paper's); the
        positions' ``n_orient`` for the standardization per position (docs/model.md §2).

    Returns
    -------
    dict
        ``x_filt``, ``x_pred``, ``z``, raw weights ``w`` and ``weights`` (the diagonal of
        ``W_t^(alpha)``) of shape (n_times, n_sources); ``W``, the blocks of
        ``W_t^(alpha)``, (n_times, n_sources // block, block, block);
        ``P_filt``, ``P_pred``, ``P_pred_inv_sqrt`` of shape (n_times, n_sources, n_sources);
        ``log_likelihood`` (float); ``missing`` (n_times,), the missing steps.
    """
    n, T = L.shape[1], Y.shape[1]
    out: dict[str, Any] = {
        key: np.full((T, n), np.nan) for key in ("x_filt", "x_pred", "z", "w", "weights")
    }
    out["W"] = np.full((T, n // block, block, block), np.nan)
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
        # w_t = diag(Psi_t), Psi_t = P_{t|t-1}^{-1/2} K_t S_t K_t^T P_{t|t-1}^{-1/2}  §2.2 (7)
        w = raw_weights(P_pred_inv_sqrt, K, S)
        # B_t(i): the n_orient x n_orient diagonal blocks of Psi_t (1 x 1: w_t)  docs/model.md §2
        B = raw_blocks(P_pred_inv_sqrt, K, S, block)
        # W_t^(alpha) = blockdiag_i B_t(i)^(-alpha)  (1 x 1: Diag(w_t)^(-alpha))    §2.2 (7)
        W = weight_blocks(B, exponent)
        # z_{t|t} = W_t^(alpha) P_{t|t-1}^{-1/2} x_{t|t}                          §2.2 (6)
        z = apply_blocks(W, P_pred_inv_sqrt @ x)
        total += log_likelihood
        out["x_filt"][t], out["z"][t], out["w"][t], out["W"][t] = x, z, w, W
        out["weights"][t] = block_diagonal(W)
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


def rts_covariances(
    P_filt: NDArray[np.float64], P_pred: NDArray[np.float64], A: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The smoothed covariances ``P^s_t`` of the RTS recursion, §2.3 eqs. (3)-(4).

    Parameters
    ----------
    P_filt, P_pred : ndarray, shape (n_times, n_sources, n_sources)
        ``P_{t|t}`` and ``P_{t|t-1}``.
    A : ndarray, shape (n_sources, n_sources)

    Returns
    -------
    ndarray, shape (n_times, n_sources, n_sources)
        Symmetrized.
    """
    # P^s_T = P_{T|T}                                              §2.3 (3)
    P_s = P_filt.copy()
    for t in range(len(P_s) - 2, -1, -1):
        # G_t = P_{t|t} A^T P_{t+1|t}^{-1}                             §2.3 (4)
        G = linalg.solve(P_pred[t + 1], A @ P_filt[t], assume_a="pos").T
        # P^s_t = P_{t|t} + G_t (P^s_{t+1} - P_{t+1|t}) G_t^T            §2.3 (4)
        P = P_filt[t] + G @ (P_s[t + 1] - P_pred[t + 1]) @ G.T
        P_s[t] = (P + P.T) / 2
    return P_s


def prior_covariances(
    A: NDArray[np.float64], Q: NDArray[np.float64], P0: NDArray[np.float64], n_times: int
) -> NDArray[np.float64]:
    """The prior covariance ``Sigma_t`` of the state ``x_t``, t = 1 .. T (docs/model.md §3).

    ``Sigma_0 = P_0`` (the covariance of ``x_0``), ``Sigma_t = A Sigma_{t-1} A^T + Q``: the
    covariance of ``x_t`` before any data are seen. ``Sigma_1 = P_{1|0}``.

    Returns
    -------
    ndarray, shape (n_times, n_sources, n_sources)
    """
    Sigma = np.empty((n_times, *P0.shape))
    previous = P0
    for t in range(n_times):
        # Sigma_t = A Sigma_{t-1} A^T + Q                            docs/model.md §3
        previous = A @ previous @ A.T + Q
        previous = Sigma[t] = (previous + previous.T) / 2
    return Sigma


def run(
    model: StateSpaceModel,
    Y: NDArray[np.float64],
    exponent: float,
    smoother: str | None,
    standardize: str = "column",
    n_orient: int | None = None,
) -> Reconstruction:
    """Filter, smooth if asked, and return the result.

    Parameters
    ----------
    model : StateSpaceModel
    Y : ndarray, shape (n_channels, n_times)
        A column of NaN is a missing step.
    exponent : float
    smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}
        ``"rts-standardized"`` only without missing steps (the caller checks).
    standardize : {"column", "position"}
    n_orient : {1, 3} or None
        Checked by the caller (``"position"`` needs it).

    Returns
    -------
    Reconstruction
    """
    block = n_orient if standardize == "position" and n_orient else 1
    A, Q, P0 = (model.matrix(name) for name in ("transition", "q", "theta0"))
    f = kalman_filter(model.L, Y, model.R, A, Q, P0, exponent, block)
    x, z = smooth(f, smoother, A, exponent, block, prior=(Q, P0))
    return result(f, x, z, model, exponent, smoother, "dense", (standardize, n_orient))


def smooth(
    filtered: dict[str, Any],
    smoother: str | None,
    A: _Array,
    exponent: float,
    block: int = 1,
    prior: tuple[_Array, _Array] | None = None,
) -> tuple[_Array, _Array]:
    """The smoothed ``x`` and ``z`` (time-major) of :func:`kalman_filter`'s output.

    Parameters
    ----------
    filtered : dict
        :func:`kalman_filter`'s output.
    smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}
    A : ndarray, shape (n_sources, n_sources)
    exponent : float
    block : int
        Columns standardized together (:func:`kalman_filter`).
    prior : (Q, P0), each ndarray of shape (n_sources, n_sources), optional
        The state's prior, which ``"rts-smoothed-weights"`` needs (``Sigma_t``).

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
        if "W" in f:
            z = restandardize_blocks(f["W"], f["P_pred_inv_sqrt"], x)
        else:  # a filter's output with the column weights only (skf_ref.conformance's)
            z = restandardize(f["w"], f["P_pred_inv_sqrt"], x, exponent)
    elif smoother == "rts-smoothed-weights":
        # textbook RTS on the state and its covariance P^s_t, then the smoothed state over
        # its own variance: z^s_t = W^s_t Sigma_t^{-1/2} x^s_t        docs/model.md §3
        if prior is None:
            raise ValueError("smoother='rts-smoothed-weights' needs prior=(Q, P0)")
        Q, P0 = prior
        x = rts(f["x_filt"], f["P_filt"], f["P_pred"], A)
        P_s = rts_covariances(f["P_filt"], f["P_pred"], A)
        Sigma = prior_covariances(A, Q, P0, len(x))
        z = standardize_smoothed(x, P_s, Sigma, exponent, block)
        z[_missing(f)] = np.nan  # no estimate at a missing step, as on every smoother
    return x, z


def _missing(f: dict[str, Any]) -> NDArray[np.bool_]:
    """The missing steps of a filter's output (none when it does not say)."""
    missing = f.get("missing")
    return np.zeros(len(f["x_filt"]), bool) if missing is None else missing


def result(
    filtered: dict[str, Any],
    x: NDArray[np.float64],
    z: NDArray[np.float64],
    model: StateSpaceModel,
    exponent: float,
    smoother: str | None,
    method: str,
    standardization: tuple[str, int | None] = ("column", None),
) -> Reconstruction:
    """The result of a covariance-storing path (dense, filterpy) from its time-major
    (n_times, n_sources) filter output and its (smoothed) ``x`` and ``z``;
    ``standardization`` is ``(standardize, n_orient)``."""
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
        standardize=standardization[0],
        n_orient=standardization[1],
        missing=filtered.get("missing"),  # None: every step observed
        min_raw_weight=float(np.nanmin(filtered["w"])),
    )
