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
from .._powers import block_power
from .._result import Reconstruction, stored_result
from .._settings import Settings
from .._standardization import (
    apply_blocks,
    block_diagonal,
    diagonal_blocks,
    inverse_sqrt,
    restandardize_blocks,
    standardize_smoothed,
)

__all__ = [
    "kalman_filter",
    "prior_covariances",
    "rts",
    "rts_covariances",
    "run",
    "smooth",
    "step",
]

_LOG_2PI = np.log(2 * np.pi)
_Array = NDArray[np.float64]


def step(
    x: _Array,
    P: _Array,
    y: _Array | None,
    L: _Array,
    R: _Array,
    A: _Array,
    Q: _Array,
    exponent: float,
    block: int = 1,
) -> dict[str, Any]:
    """One step of the SKF, §2.2 eqs. (4)-(7), one line an equation (docs/model.md §2).

    Parameters
    ----------
    x : ndarray, shape (n_sources,)
        ``x_{t-1|t-1}``.
    P : ndarray, shape (n_sources, n_sources)
        ``P_{t-1|t-1}``.
    y : ndarray, shape (n_channels,), or None
        ``y_t``; None for a missing step (a prediction without an update).
    L : ndarray, shape (n_channels, n_sources)
    R : ndarray, shape (n_channels, n_channels)
    A, Q : ndarray, shape (n_sources, n_sources)
    exponent : float
    block : int
        Columns standardized together: 1, each on its own (the paper's); ``n_orient``, each
        position's block (docs/model.md §2).

    Returns
    -------
    dict
        ``x_pred``, ``x``, ``z``, ``w`` (n_sources,); ``P_pred``, ``P``,
        ``P_pred_inv_sqrt`` (n_sources, n_sources); ``K`` (n_sources, n_channels), ``S``
        (n_channels, n_channels); ``W`` (n_sources // block, block, block), the blocks of
        ``W_t^(alpha)``; ``log_likelihood``, ``log N(y_t - L x_{t|t-1}; 0, S_t)``. A missing
        step gives ``x_pred``, ``P_pred``, ``x`` and ``P`` only.

    Raises
    ------
    scipy.linalg.LinAlgError
        If ``S_t`` or ``P_{t|t-1}`` is not positive definite in double precision.
    """
    # predict                                                          §2.2 eq. (4)
    x_pred = A @ x
    P_pred = _symmetric(A @ P @ A.T + Q)
    if y is None:  # a missing step: x_{t|t} = x_{t|t-1}, P_{t|t} = P_{t|t-1}  docs/model.md §2
        return dict(x_pred=x_pred, P_pred=P_pred, x=x_pred, P=P_pred)
    # update (S_t by Cholesky, never its inverse)                      §2.2 eq. (5)
    S = L @ P_pred @ L.T + R
    S_factor = _cholesky(S)
    K = linalg.cho_solve(S_factor, L @ P_pred).T
    e = y - L @ x_pred
    x = x_pred + K @ e
    P = _symmetric(P_pred - K @ S @ K.T)
    # weights: w_t = diag(Psi_t), Psi_t = P^{-1/2} K_t S_t K_t^T P^{-1/2}  §2.2 eq. (7)
    P_pred_inv_sqrt = inverse_sqrt(P_pred)
    M = P_pred_inv_sqrt @ K
    Psi = M @ S @ M.T
    w = np.diag(Psi).copy()
    if block == 1:
        with np.errstate(over="ignore", divide="ignore"):  # the result refuses inf, with why
            # W_t^(alpha) = Diag(w_t)^(-alpha)                         §2.2 eq. (7)
            W = w**-exponent
            # z_{t|t} = W_t^(alpha) P_{t|t-1}^{-1/2} x_{t|t}             §2.2 eq. (6)
            z = W * (P_pred_inv_sqrt @ x)
        W = W[:, None, None]
    else:  # per position: W_t^(alpha) = blockdiag_i B_t(i)^(-alpha)   docs/model.md §2
        W = block_power(diagonal_blocks(Psi, block), exponent)
        z = apply_blocks(W, P_pred_inv_sqrt @ x)
    log_likelihood = _log_density(e, S_factor)
    return dict(x_pred=x_pred, P_pred=P_pred, x=x, P=P, K=K, S=S, w=w, W=W, z=z) | dict(
        P_pred_inv_sqrt=P_pred_inv_sqrt, log_likelihood=log_likelihood
    )


def _symmetric(P: _Array) -> _Array:
    """``(P + P^T) / 2``: a covariance kept symmetric to the last bit."""
    return (P + P.T) / 2


def _cholesky(S: _Array) -> tuple[_Array, bool]:
    """The Cholesky factor of ``S_t``, or an error naming its eigenvalues."""
    try:
        return linalg.cho_factor(S, lower=True)
    except linalg.LinAlgError as err:
        eigenvalues = linalg.eigvalsh(S)
        raise linalg.LinAlgError(
            "S_t = L P_t|t-1 L^T + R is not positive definite in double precision (eigenvalues "
            f"from {eigenvalues[0]:.3g} to {eigenvalues[-1]:.3g})"
        ) from err


def _log_density(e: _Array, S_factor: tuple[_Array, bool]) -> float:
    """``log N(e; 0, S) = -(m log 2 pi + log det S + e^T S^{-1} e) / 2``, by ``S``'s factor."""
    log_det = 2 * np.sum(np.log(np.diag(S_factor[0])))
    return float(-0.5 * (len(e) * _LOG_2PI + log_det + e @ linalg.cho_solve(S_factor, e)))


def kalman_filter(
    L: _Array,
    Y: _Array,
    R: _Array,
    A: _Array,
    Q: _Array,
    P0: _Array,
    exponent: float,
    block: int = 1,
) -> dict[str, Any]:
    """Run the SKF forward pass (§2.2 eqs. 4-7, :func:`step`), keeping every mean and covariance.

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
    names = {"x_filt": "x", "x_pred": "x_pred", "z": "z", "w": "w", "W": "W", "P_filt": "P"}
    names |= {"P_pred": "P_pred", "P_pred_inv_sqrt": "P_pred_inv_sqrt"}
    out: dict[str, Any] = {key: np.full((T, n), np.nan) for key in ("x_filt", "x_pred", "z", "w")}
    out["W"] = np.full((T, n // block, block, block), np.nan)
    for key in ("P_filt", "P_pred", "P_pred_inv_sqrt"):
        out[key] = np.full((T, n, n), np.nan)
    out["missing"] = np.isnan(Y[0])
    x, P, total = np.zeros(n), P0, 0.0
    for t in range(T):
        y = None if out["missing"][t] else Y[:, t]
        try:
            s = step(x, P, y, L, R, A, Q, exponent, block)
        except linalg.LinAlgError as err:
            raise linalg.LinAlgError(f"at step {t + 1}: {err}") from err
        x, P, total = s["x"], s["P"], total + s.get("log_likelihood", 0.0)
        for key, name in names.items():
            if name in s:
                out[key][t] = s[name]
    out["weights"] = block_diagonal(out["W"])  # the diagonal of W_t^(alpha)
    out["log_likelihood"] = total
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


def run(model: StateSpaceModel, Y: _Array, settings: Settings) -> Reconstruction:
    """Filter, smooth if asked, and return the result.

    Parameters
    ----------
    model : StateSpaceModel
    Y : ndarray, shape (n_channels, n_times)
        A column of NaN is a missing step.
    settings : Settings
        Checked by the caller (``"rts-standardized"`` only without missing steps).

    Returns
    -------
    Reconstruction
    """
    exponent, block = settings.exponent, settings.block
    A, Q, P0 = (model.matrix(name) for name in ("transition", "q", "theta0"))
    f = kalman_filter(model.L, Y, model.R, A, Q, P0, exponent, block)
    x, z = smooth(f, settings.smoother, A, exponent, block, prior=(Q, P0))
    return stored_result(f, x, z, model, settings, "dense")


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
        # (a filter's output with the column weights only, skf_ref.conformance's: 1 x 1 blocks)
        W = f["W"] if "W" in f else f["weights"][..., None, None]
        z = restandardize_blocks(W, f["P_pred_inv_sqrt"], x)
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
