"""The intermediate quantities of the SKF, in the order its equations produce them.

An implementation under test may give, besides its six outputs, any of the quantities it
computes on the way (the variables below); :func:`skf_ref.compare` then names the first of
them that leaves the tolerance, and the equation of docs/model.md that computes it
(:mod:`skf_ref.conformance._divergence`). Every per-step array has time as its last axis,
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

from .._utils.checks import InputError, describe

__all__ = [
    "INTERMEDIATES",
    "NAMES",
    "QUANTITIES",
    "Variable",
    "checked_intermediate",
    "production_order",
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
        _FILTER + "(7): the diagonal of W_t^(alpha) = Diag(w_t ** -alpha) (by position: "
        "its blocks B_t(i) ** -alpha)",
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

#: The names of every intermediate (the outputs are ``OUTPUTS``).
NAMES = tuple(variable.name for variable in INTERMEDIATES if variable.name != "log_likelihood")

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


def _shape(name: str, n_channels: int, n_sources: int, n_times: int) -> tuple[int, ...]:
    steps = n_times - 1 if name == "G" else n_times
    if name in ("x_pred", "w", "w_smooth"):
        return (n_sources, n_times)
    inner = {"S": (n_channels, n_channels), "K": (n_sources, n_channels)}
    return (*inner.get(name, (n_sources, n_sources)), steps)


def checked_intermediate(
    name: str, value: Any, n_channels: int, n_sources: int, n_times: int, source: str
) -> Any:
    """An intermediate of their outputs as numbers of its documented shape; else an error.

    Parameters
    ----------
    name : str
        One of :data:`NAMES`.
    value : object
    n_channels, n_sources, n_times : int
    source : str
        Their file, for messages.

    Returns
    -------
    float or ndarray
        ``theta0`` and ``q`` as a number or an (n_sources, n_sources) array; a covariance as
        given, whole or by its diagonal (n_sources, n_times).

    Raises
    ------
    skf_ref.InputError
        Not real numbers, or another shape: names the variable and the shapes expected.

    Examples
    --------
    >>> checked_intermediate("P_pred", np.ones((3, 7)), 5, 3, 7, "mine.npz").shape
    (3, 7)
    >>> checked_intermediate("S", np.ones((3, 3, 7)), 5, 3, 7, "mine.npz")
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: mine.npz: S must have shape (5, 5, 7) ..., got (3, 3, 7)
    """
    variable = next(v for v in INTERMEDIATES if v.name == name)
    array = np.asarray(value) if not isinstance(value, str) else np.asarray(None)
    if array.dtype.kind == "c" and not np.any(array.imag):
        array = array.real
    if array.dtype.kind not in "fiu":
        raise InputError(f"{source}: {name} must be real numbers, got {describe(value)}")
    array = array.astype(float)
    if variable.stage == "once":
        if array.ndim == 0 or array.shape == (n_sources, n_sources):
            return float(array) if array.ndim == 0 else array
        wanted = f"a number or ({n_sources}, {n_sources})"
    else:
        shape = _shape(name, n_channels, n_sources, n_times)
        if array.shape == shape or (variable.diagonal and array.shape == (n_sources, n_times)):
            return array
        wanted = f"{shape} {variable.shape}"
        if variable.diagonal:
            wanted += f" or its diagonal, ({n_sources}, {n_times})"
    raise InputError(f"{source}: {name} must have shape {wanted}, got {array.shape}")
