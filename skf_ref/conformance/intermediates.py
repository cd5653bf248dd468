"""The intermediate quantities of the SKF, in the order its equations produce them.

An implementation under test may give, besides its six outputs, any of the quantities it
computes on the way (the variables below); :func:`skf_ref.compare` then names the first of
them that leaves the tolerance, and the equation of docs/model.md that computes it
(:mod:`skf_ref.conformance.divergence`). Every per-step array has time as its last axis,
as the outputs have: ``x_pred`` is (n_sources, n_times), ``P_pred`` is
(n_sources, n_sources, n_times), MATLAB's ``P_pred(:, :, t)``. A covariance may be given as
its diagonal instead, (n_sources, n_times).

Each variable belongs to one *quantity* (:data:`QUANTITIES`), the name ``compare`` reports.
The equations produce them in this order: the priors once; then, at each step
``t = 1, ..., T``, the prediction, ``S_t``, ``K_t``, ``x_{t|t}``, ``P_{t|t}``, the weights
and ``z_{t|t}``; the log-likelihood once the forward pass is done; the smoother's backward
pass from ``t = T`` down to 1 (``G_t``, the smoothed state, ``P^s_t``); and last, at each
step again, what standardizes the smoothed state (``Sigma_t``, ``w^s_t``, ``z^s_t``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import linalg

from ..method import StateSpaceModel
from ..method._paths import dense

__all__ = [
    "INTERMEDIATES",
    "QUANTITIES",
    "Variable",
    "expected_intermediates",
    "log_likelihood_scale",
    "production_order",
    "scales",
    "variables",
]

#: What :func:`skf_ref.compare` may name as the first divergence, in the issue's order.
QUANTITIES = (
    "priors",
    "prediction",
    "innovation_covariance",
    "gain",
    "filtered_state",
    "posterior_covariance",
    "weights",
    "standardized",
    "smoother_gain",
    "smoothed_state",
    "smoothed_covariance",
    "smoothed_weights",
    "log_likelihood",
)

_FILTER = "docs/model.md §2, §2.2 eq. "
_SMOOTHER = "docs/model.md §3, §2.3 eq. (4)"


@dataclass(frozen=True)
class Variable:
    """One quantity an implementation can give, as a named variable of its outputs.

    Attributes
    ----------
    name : str
        The variable's name in their file (``P_pred``).
    quantity : str
        One of :data:`QUANTITIES`.
    shape : str
        Its shape, in words (``"(n_sources, n_sources, n_times)"``).
    equation : str
        Where docs/model.md states it, and the equation.
    stage : {"once", "forward", "end", "backward", "after"}
        When the equations produce it: before the loop, at each step of the forward pass,
        after it, in the backward pass, or at each step after the backward pass.
    diagonal : bool
        Whether its diagonal, (n_sources, n_times), may be given instead (covariances).
    inputs : tuple of str
        The variables it is computed from (its own earlier steps left out).
    """

    name: str
    quantity: str
    shape: str
    equation: str
    stage: str
    diagonal: bool = False
    inputs: tuple = ()


_NN_T = "(n_sources, n_sources, n_times)"
_N_T = "(n_sources, n_times)"

#: Every intermediate an implementation may give, with the outputs, in production order.
#: ``x`` and ``z`` depend on the smoother: :func:`variables` gives each its entry.
INTERMEDIATES = (
    Variable(
        "theta0",
        "priors",
        "scalar or (n_sources, n_sources)",
        "docs/model.md §4, §3.1 eqs. (8)-(10): theta0 = 10**(PM/10) sigma**2 amplitude**2 / N",
        "once",
    ),
    Variable(
        "q",
        "priors",
        "scalar or (n_sources, n_sources)",
        "docs/model.md §4, §3.1 eqs. (9)-(10): q = 10**(EP/10) theta0 / K",
        "once",
    ),
    Variable(
        "x_pred",
        "prediction",
        _N_T,
        _FILTER + "(4): x_{t|t-1} = A x_{t-1|t-1}",
        "forward",
        inputs=("x_filtered",),
    ),
    Variable(
        "P_pred",
        "prediction",
        _NN_T,
        _FILTER + "(4): P_{t|t-1} = A P_{t-1|t-1} A^T + Q",
        "forward",
        diagonal=True,
        inputs=("theta0", "q", "P_filt"),
    ),
    Variable(
        "S",
        "innovation_covariance",
        "(n_channels, n_channels, n_times)",
        _FILTER + "(5): S_t = L P_{t|t-1} L^T + R",
        "forward",
        inputs=("P_pred",),
    ),
    Variable(
        "K",
        "gain",
        "(n_sources, n_channels, n_times)",
        _FILTER + "(5): K_t = P_{t|t-1} L^T S_t^{-1}",
        "forward",
        inputs=("P_pred", "S"),
    ),
    Variable(
        "x_filtered",
        "filtered_state",
        _N_T,
        _FILTER + "(5): x_{t|t} = x_{t|t-1} + K_t (y_t - L x_{t|t-1})",
        "forward",
        inputs=("x_pred", "K"),
    ),
    Variable(
        "P_filt",
        "posterior_covariance",
        _NN_T,
        _FILTER + "(5): P_{t|t} = P_{t|t-1} - K_t S_t K_t^T",
        "forward",
        diagonal=True,
        inputs=("P_pred", "K", "S"),
    ),
    Variable(
        "w",
        "weights",
        _N_T,
        _FILTER + "(7): w_t = diag(P_{t|t-1}^{-1/2} K_t S_t K_t^T P_{t|t-1}^{-1/2})",
        "forward",
        inputs=("P_pred", "K", "S"),
    ),
    Variable(
        "weights",
        "weights",
        _N_T,
        _FILTER + "(7): the diagonal of W_t^(alpha) = Diag(w_t ** -alpha)",
        "forward",
        inputs=("w",),
    ),
    Variable(
        "z_filtered",
        "standardized",
        _N_T,
        _FILTER + "(6): z_{t|t} = W_t^(alpha) P_{t|t-1}^{-1/2} x_{t|t}",
        "forward",
        inputs=("weights", "P_pred", "x_filtered"),
    ),
    Variable(
        "log_likelihood",
        "log_likelihood",
        "scalar",
        "docs/model.md §2, innovation log-likelihood: sum_t log N(y_t - L x_{t|t-1}; 0, S_t)",
        "end",
        inputs=("x_pred", "S"),
    ),
    Variable(
        "G",
        "smoother_gain",
        "(n_sources, n_sources, n_times - 1)",
        _SMOOTHER + ": G_t = P_{t|t} A^T P_{t+1|t}^{-1}, t = 1, ..., T - 1",
        "backward",
        inputs=("P_filt", "P_pred"),
    ),
    Variable(
        "P_smooth",
        "smoothed_covariance",
        _NN_T,
        _SMOOTHER + ": P^s_t = P_{t|t} + G_t (P^s_{t+1} - P_{t+1|t}) G_t^T",
        "backward",
        diagonal=True,
        inputs=("P_filt", "G", "P_pred"),
    ),
    Variable(
        "Sigma",
        "smoothed_weights",
        _NN_T,
        "docs/model.md §3, rts-smoothed-weights: Sigma_t = A Sigma_{t-1} A^T + Q, Sigma_0 = P_0",
        "after",
        diagonal=True,
        inputs=("theta0", "q"),
    ),
    Variable(
        "w_smooth",
        "smoothed_weights",
        _N_T,
        "docs/model.md §3, rts-smoothed-weights: "
        "w^s_t = diag(Sigma_t^{-1/2} (Sigma_t - P^s_t) Sigma_t^{-1/2})",
        "after",
        inputs=("Sigma", "P_smooth"),
    ),
)

_SMOOTHED_X = Variable(
    "x",
    "smoothed_state",
    _N_T,
    _SMOOTHER + ": x^s_t = x_{t|t} + G_t (x^s_{t+1} - x_{t+1|t})",
    "backward",
    inputs=("x_filtered", "G"),
)
#: ``z`` and ``x`` by smoother: what computes them (docs/conformance.md lists the same).
_OUTPUTS_BY_SMOOTHER = {
    None: (
        Variable("x", "filtered_state", _N_T, "x = x_filtered without smoothing", "forward"),
        Variable("z", "standardized", _N_T, "z = z_filtered without smoothing", "forward"),
    ),
    "rts-standardized": (
        Variable("x", "filtered_state", _N_T, "x = x_filtered (rts-standardized)", "forward"),
        Variable(
            "z",
            "smoothed_state",
            _N_T,
            "docs/model.md §3, rts-standardized: s_t = z_{t|t} + G_t (s_{t+1} - A z_{t|t})",
            "backward",
            inputs=("z_filtered", "G"),
        ),
    ),
    "rts-state": (
        _SMOOTHED_X,
        Variable(
            "z",
            "standardized",
            _N_T,
            "docs/model.md §3, rts-state: z^s_t = W_t^(alpha) P_{t|t-1}^{-1/2} x^s_t",
            "after",
            inputs=("weights", "P_pred", "x"),
        ),
    ),
    "rts-smoothed-weights": (
        _SMOOTHED_X,
        Variable(
            "z",
            "standardized",
            _N_T,
            "docs/model.md §3, rts-smoothed-weights: z^s_t = W^s_t^(alpha) Sigma_t^{-1/2} x^s_t",
            "after",
            inputs=("w_smooth", "Sigma", "x"),
        ),
    ),
}
#: Variables that exist only with a smoother, or only with the smoother standardized by its
#: own variance.
_SMOOTHING_ONLY = ("G", "P_smooth")
_SMOOTHED_WEIGHTS_ONLY = ("Sigma", "w_smooth")


def variables(smoother: str | None) -> dict[str, Variable]:
    """Every variable a case with ``smoother`` defines, by name, in production order.

    Within a stage the order is the equations'; ``x`` and ``z`` take their place by what
    computes them (``z`` is the smoothed state of ``"rts-standardized"``, the standardized
    smoothed state of ``"rts-state"``).

    Parameters
    ----------
    smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}

    Returns
    -------
    dict of str to Variable

    Examples
    --------
    >>> list(variables(None))[:6]
    ['theta0', 'q', 'x_pred', 'P_pred', 'S', 'K']
    >>> variables("rts-standardized")["z"].quantity
    'smoothed_state'
    """
    x, z = _OUTPUTS_BY_SMOOTHER[smoother]
    found = []
    for variable in INTERMEDIATES:
        if variable.name in _SMOOTHING_ONLY and smoother is None:
            continue
        if variable.name in _SMOOTHED_WEIGHTS_ONLY and smoother != "rts-smoothed-weights":
            continue
        found.append(variable)
        if variable.name == "x_filtered" and x.stage == "forward":
            found.append(x)
        if variable.name == "z_filtered" and z.stage == "forward":
            found.append(z)
        if variable.name == "G":
            found += [v for v in (x, z) if v.stage == "backward"]
    found += [z] if z.stage == "after" else []
    return {variable.name: variable for variable in found}


def production_order(smoother: str | None, n_times: int) -> list[tuple[str, int | None]]:
    """Every (variable, step) in the order the equations produce them; steps count from 1.

    The priors and the log-likelihood have no step (None). The backward pass runs from
    ``T`` down to 1: at ``T`` the smoothed state and covariance start from the filter's,
    and the gain ``G_t`` comes before the smoothed values of step ``t``.

    Parameters
    ----------
    smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}
    n_times : int

    Returns
    -------
    list of (str, int or None)

    Examples
    --------
    >>> production_order("rts-state", 2)  # doctest: +NORMALIZE_WHITESPACE
    [('theta0', None), ('q', None), ('x_pred', 1), ('P_pred', 1), ('S', 1), ('K', 1),
     ('x_filtered', 1), ('P_filt', 1), ('w', 1), ('weights', 1), ('z_filtered', 1),
     ('x_pred', 2), ('P_pred', 2), ('S', 2), ('K', 2), ('x_filtered', 2), ('P_filt', 2),
     ('w', 2), ('weights', 2), ('z_filtered', 2), ('log_likelihood', None), ('x', 2),
     ('P_smooth', 2), ('G', 1), ('x', 1), ('P_smooth', 1), ('z', 1), ('z', 2)]
    """
    by_stage: dict[str, list[str]] = {}
    for name, variable in variables(smoother).items():
        by_stage.setdefault(variable.stage, []).append(name)
    order: list[tuple[str, int | None]] = [(name, None) for name in by_stage.get("once", [])]
    for t in range(1, n_times + 1):
        order += [(name, t) for name in by_stage.get("forward", [])]
    order += [(name, None) for name in by_stage.get("end", [])]
    backward = by_stage.get("backward", [])
    for t in range(n_times, 0, -1):  # no gain at T: the pass starts from the filter's
        order += [(name, t) for name in backward if name != "G" or t < n_times]
    for t in range(1, n_times + 1):
        order += [(name, t) for name in by_stage.get("after", [])]
    return order


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
        ``P_filt``, ``w`` with time last; with a smoother also ``G`` and ``P_smooth``.
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
    f = dense.kalman_filter(model.L, Y, model.R, A, Q, P0, case.inputs["exponent"])
    S, K = [], []
    for t in range(Y.shape[1]):
        _, _, K_t, S_t, _ = dense.update(f["x_pred"][t], f["P_pred"][t], Y[:, t], model.L, model.R)
        S.append(S_t)
        K.append(K_t)
    found = {"theta0": case.inputs["theta0"], "q": case.inputs["q"]}
    found |= {name: _steps_last(f[name]) for name in ("x_pred", "P_pred", "P_filt", "w")}
    found |= {"S": _steps_last(np.array(S)), "K": _steps_last(np.array(K))}
    if case.inputs["smoother"] is not None:
        G, P_smooth = _rts_covariances(f, A)
        found |= {"G": _steps_last(G), "P_smooth": _steps_last(P_smooth)}
    return found


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
