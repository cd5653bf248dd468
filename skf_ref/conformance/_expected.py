"""The expected intermediates of a case and each variable's own scale.

The dense path computes them (docs/model.md §2-§3): the forward pass keeps every mean and
covariance (:func:`skf_ref.method._paths.dense.kalman_filter`), each step's ``S_t`` and
``K_t`` are its update again, and the smoother's gains and covariances follow §2.3 eq. (4).
:mod:`skf_ref.conformance._intermediates` says what each variable is; the comparison
measures each against the scale :func:`scales` gives it.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import linalg

from ..method import StateSpaceModel
from ..method._paths import dense
from ..method._standardization import inverse_sqrt

__all__ = ["expected_intermediates", "expected_variables", "log_likelihood_scale", "scales"]


def _steps_last(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Time-major (T, ...) as time-last (..., T), the layout of the case files."""
    return np.ascontiguousarray(np.moveaxis(values, 0, -1))


def _rts_covariances(f: dict[str, Any], A: NDArray[np.float64]) -> tuple[Any, Any]:
    """The gains ``G_t`` and the smoothed covariances ``P^s_t`` of §2.3 eq. (4), time-major."""
    P_filt, P_pred = f["P_filt"], f["P_pred"]
    T = len(P_filt)
    G = np.empty((T - 1, *P_filt.shape[1:]))
    P_smooth = P_filt.copy()
    for t in range(T - 2, -1, -1):
        # G_t = P_{t|t} A^T P_{t+1|t}^{-1}  (a solve: P_{t+1|t} G_t^T = A P_{t|t})
        G[t] = linalg.solve(P_pred[t + 1], A @ P_filt[t], assume_a="pos").T
        # P^s_t = P_{t|t} + G_t (P^s_{t+1} - P_{t+1|t}) G_t^T
        P = P_filt[t] + G[t] @ (P_smooth[t + 1] - P_pred[t + 1]) @ G[t].T
        P_smooth[t] = (P + P.T) / 2
    return G, P_smooth


def _model(case: Any) -> tuple[StateSpaceModel, NDArray[np.float64]]:
    p = case.inputs
    R = p["noise_cov"]
    R = R * np.eye(p["L"].shape[0]) if np.ndim(R) == 0 else R
    return StateSpaceModel(p["L"], R, p["transition"], p["q"], p["theta0"]), p["Y"]


def expected_intermediates(case: Any) -> dict[str, Any]:
    """The intermediates of a case, as the dense path computes them (docs/model.md §2-§3).

    Parameters
    ----------
    case : Case

    Returns
    -------
    dict
        ``theta0`` and ``q`` as the case gives them; ``x_pred``, ``P_pred``, ``S``, ``K``,
        ``P_filt``, ``w`` with time last; with a smoother also ``G`` and ``P_smooth``; with
        ``"rts-smoothed-weights"`` also ``Sigma`` and ``w_smooth``.
        The outputs are the case's own (``case.expected``).

    Examples
    --------
    >>> from skf_ref.conformance import cases
    >>> found = expected_intermediates(cases()[2])  # average_reference, rts-standardized
    >>> {name: found[name].shape for name in ("P_pred", "S", "K", "G")}
    {'P_pred': (8, 8, 7), 'S': (6, 6, 7), 'K': (8, 6, 7), 'G': (8, 8, 6)}
    """
    model, Y = _model(case)
    A, Q, P0 = (model.matrix(name) for name in ("transition", "q", "theta0"))
    p = case.inputs
    block = int(p.get("n_orient", 1)) if p.get("standardize") == "position" else 1
    f = dense.kalman_filter(model.L, Y, model.R, A, Q, P0, p["exponent"], block)
    S, K = [], []
    for P_pred in f["P_pred"]:  # S_t and K_t of §2.2 eq. (5), as the dense path's step
        S.append(model.L @ P_pred @ model.L.T + model.R)
        K.append(linalg.cho_solve(linalg.cho_factor(S[-1], lower=True), model.L @ P_pred).T)
    found = {"theta0": case.inputs["theta0"], "q": case.inputs["q"]}
    found |= {name: _steps_last(f[name]) for name in ("x_pred", "P_pred", "P_filt", "w")}
    found |= {"S": _steps_last(np.array(S)), "K": _steps_last(np.array(K))}
    if case.inputs["smoother"] is not None:
        G, P_smooth = _rts_covariances(f, A)
        found |= {"G": _steps_last(G), "P_smooth": _steps_last(P_smooth)}
    if case.inputs["smoother"] == "rts-smoothed-weights":
        Sigma = dense.prior_covariances(A, Q, P0, Y.shape[1])
        found |= {"Sigma": _steps_last(Sigma), "w_smooth": _smoothed_raw_weights(Sigma, P_smooth)}
    return found


def _smoothed_raw_weights(Sigma: NDArray[np.float64], P_smooth: NDArray[np.float64]) -> Any:
    """``w^s_t``, diag(``Sigma_t^{-1/2} (Sigma_t - P^s_t) Sigma_t^{-1/2}``), time last."""
    w = np.empty(Sigma.shape[:2])
    for t in range(len(Sigma)):
        root = inverse_sqrt(Sigma[t])
        w[t] = np.diag(root @ (Sigma[t] - P_smooth[t]) @ root)
    return _steps_last(w)


def log_likelihood_scale(S: NDArray[np.float64], x_pred: NDArray[np.float64], case: Any) -> float:
    """The log-likelihood's own scale: the sum of the sizes of its terms.

    ``sum_t (m log 2 pi + |log det S_t| + e_t^T S_t^{-1} e_t) / 2``, with
    ``e_t = y_t - L x_{t|t-1}``: what rounding is relative to when the terms nearly cancel
    (a log-likelihood near zero), and never smaller than ``|log_likelihood|``.

    Parameters
    ----------
    S : ndarray, shape (n_channels, n_channels, n_times)
    x_pred : ndarray, shape (n_sources, n_times)
    case : Case

    Returns
    -------
    float
    """
    L, Y = case.inputs["L"], case.inputs["Y"]
    total = 0.0
    for t in range(Y.shape[1]):
        factor = linalg.cho_factor(S[:, :, t], lower=True)
        e = Y[:, t] - L @ x_pred[:, t]
        log_det = 2 * np.sum(np.log(np.diag(factor[0])))
        total += len(e) * np.log(2 * np.pi) + abs(log_det) + e @ linalg.cho_solve(factor, e)
    return total / 2


def scales(case: Any, expected: dict[str, Any]) -> dict[str, float]:
    """Each variable's own scale: ``max|expected|``, the log-likelihood's its terms' sizes.

    Parameters
    ----------
    case : Case
    expected : dict
        The case's outputs and :func:`expected_intermediates`, by name.

    Returns
    -------
    dict of str to float
        Positive: a variable that is zero throughout has scale 1 (its differences absolute).
    """
    found = {name: float(np.max(np.abs(value))) or 1.0 for name, value in expected.items()}
    found["log_likelihood"] = log_likelihood_scale(expected["S"], expected["x_pred"], case)
    return found


@lru_cache(maxsize=64)
def expected_variables(case: Any) -> tuple[dict[str, Any], dict[str, float]]:
    """The case's outputs and intermediates by name, and their scales (once per case).

    The intermediates the case file carries (pinned), or else computed by the dense path.

    Parameters
    ----------
    case : Case

    Returns
    -------
    expected : dict
    scales : dict of str to float
    """
    pinned = {**case.intermediates, "theta0": case.inputs["theta0"], "q": case.inputs["q"]}
    computed = pinned if case.intermediates else expected_intermediates(case)
    expected = {**case.expected, **computed}
    return expected, scales(case, expected)
