"""Known ways to get the SKF subtly wrong, each computed: what a mistaken SKF would output.

:func:`skf_ref.compare` runs every suspect that applies to a conformance case and names those that
reproduce an implementation's numbers to the tolerance. Each suspect is the reference computation
with one mistake, built from the pieces of ``skf_ref.method._paths.dense`` and
``skf_ref.method._standardization``, and cites the equation it gets wrong (docs/model.md states
them all). A suspect returns the outputs a :class:`~skf_ref.Reconstruction` has (``z``,
``z_filtered``, ``x``, ``x_filtered``, ``weights`` as (n_sources, n_times) arrays,
``log_likelihood``), or None when the mistake cannot happen in that case (no smoother to swap, no
lead field before its reference).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..method import StateSpaceModel, ar1_priors, priors_from_snr
from ..method._outputs import ARRAYS
from ..method._paths import dense
from ..method._priors import CONVENTIONS
from ..method._result import stored_result
from ..method._settings import Settings
from ..method._standardization import inverse_sqrt, standardize

if TYPE_CHECKING:
    from ._cases import Case

__all__ = ["SUSPECTS", "Suspect"]


@dataclass(frozen=True)
class Suspect:
    """A known mistake: its name, what it is, and the outputs it produces on a case.

    Attributes
    ----------
    name : str
    description : str
        The mistake, with the equation it gets wrong.
    compute : callable
        ``compute(case)`` -> dict of outputs, or None when the mistake does not apply.
    """

    name: str
    description: str
    compute: Callable[[Case], dict[str, Any] | None]


def _model(case, **changes):
    """The case's model as matrices: ``L, Y, R, A, Q, P0`` (with ``changes`` applied)."""
    p = {**case.inputs, **changes}
    noise_cov = p["noise_cov"]
    R = noise_cov * np.eye(p["L"].shape[0]) if np.ndim(noise_cov) == 0 else noise_cov
    model = StateSpaceModel(p["L"], R, p["transition"], p["q"], p["theta0"])
    return model, p["Y"]


def _matrices(model):
    return model.L, model.R, *(model.matrix(name) for name in ("transition", "q", "theta0"))


def _block(case):
    """The columns standardized together: the case's ``n_orient`` by position, else 1."""
    p = case.inputs
    return int(p.get("n_orient", 1)) if p.get("standardize") == "position" else 1


def _outputs(filtered, model, case, smoother=None):
    """Smooth (the case's smoother unless another is given) and package a filter's output."""
    smoother = smoother or case.inputs["smoother"]
    exponent, block = filtered["exponent"], _block(case)
    A, Q, P0 = (model.matrix(name) for name in ("transition", "q", "theta0"))
    x, z = dense.smooth(filtered, smoother, A, exponent, block, prior=(Q, P0))
    standardize, n_orient = case.inputs.get("standardize", "column"), block if block > 1 else None
    settings = Settings(exponent, smoother, standardize=standardize, n_orient=n_orient)
    rec = stored_result(filtered, x, z, model, settings, "suspect")
    return {**{name: getattr(rec, name) for name in ARRAYS}, "log_likelihood": rec.log_likelihood}


def _filtered(case, **changes):
    """The reference forward pass (``dense.kalman_filter``) with ``changes`` to the inputs.

    The model is not checked as :func:`skf_ref.reconstruct` checks it: some mistakes make
    one it would refuse (a lead field without the data's reference).
    """
    model, Y = _model(case, **changes)
    L, R, A, Q, P0 = _matrices(model)
    exponent = changes.get("exponent", case.inputs["exponent"])
    f = dense.kalman_filter(L, Y, R, A, Q, P0, exponent, _block(case))
    return f | {"exponent": exponent}, model


def _rerun(case, **changes):
    """The reference computation on the case with ``changes`` to its inputs."""
    f, model = _filtered(case, **changes)
    return _outputs(f, model, case)


def _restandardized(f, w, whitening):
    """``f`` with ``z_t = Diag(w_t ** -alpha) whitening_t x_{t|t}`` (§2.2 eqs. (6)-(7))."""
    exponent = f["exponent"]
    weights, z = standardize(w, np.einsum("tij,tj->ti", whitening, f["x_filt"]), exponent)
    blocks = weights[:, :, None, None]  # W_t's 1 x 1 blocks, which "rts-state" applies again
    return {**f, "w": w, "P_pred_inv_sqrt": whitening, "weights": weights, "z": z, "W": blocks}


def _posterior_weights(f):
    """``w_t`` with ``P_{t|t}`` in place of ``P_{t|t-1}`` in §2.2 eq. (7).

    ``K_t S_t K_t^T = P_{t|t-1} - P_{t|t}`` (§2.2 eq. (5)), so
    ``w_t = diag(P_{t|t}^{-1/2} (P_{t|t-1} - P_{t|t}) P_{t|t}^{-1/2})``.
    """
    whitening = np.array([inverse_sqrt(P) for P in f["P_filt"]])
    gain = f["P_pred"] - f["P_filt"]
    return np.einsum("tij,tjk,tik->ti", whitening, gain, whitening), whitening


def _toolbox_weights(f, R, L):
    """``w_t = diag(B^T (B B^T + R)^{-1} B)`` with ``B = L P_{t|t}^{1/2}`` (the toolbox's form).

    With ``P_{t|t-1}`` in ``B`` this is §2.2 eq. (7) (docs/model.md §2, "Two identities"); with
    the updated ``P_{t|t}`` it is not.
    """
    w = np.empty(f["w"].shape)
    for t, P in enumerate(f["P_filt"]):
        values, vectors = np.linalg.eigh(P)
        B = L @ ((vectors * np.sqrt(np.clip(values, 0, None))) @ vectors.T)
        w[t] = np.einsum("ji,ji->i", B, np.linalg.solve(B @ B.T + R, B))
    return w


def transposed(case: Case) -> dict[str, Any] | None:
    """The outputs as (n_times, n_sources): time-major, as filters compute them inside."""
    return {
        name: np.transpose(value) for name, value in case.expected.items() if name in ARRAYS
    } | {"log_likelihood": case.expected["log_likelihood"]}


def posterior_in_weights(case: Case) -> dict[str, Any] | None:
    """§2.2 eq. (7) with ``P_{t|t}`` for ``P_{t|t-1}``: the weights from the updated covariance."""
    if _block(case) > 1:  # a mistake in the standardization of each column on its own
        return None
    f, model = _filtered(case)
    w, _ = _posterior_weights(f)
    f = _restandardized(f, w, f["P_pred_inv_sqrt"])
    return _outputs(f, model, case)


def posterior_in_whitening(case: Case) -> dict[str, Any] | None:
    """§2.2 eq. (6) with ``P_{t|t}^{-1/2} x_{t|t}``: whitened by the updated covariance."""
    if _block(case) > 1:  # a mistake in the standardization of each column on its own
        return None
    f, model = _filtered(case)
    _, whitening = _posterior_weights(f)
    f = _restandardized(f, f["w"], whitening)
    return _outputs(f, model, case)


def posterior_in_both(case: Case) -> dict[str, Any] | None:
    """§2.2 eqs. (6) and (7) with ``P_{t|t}`` for ``P_{t|t-1}`` in weights and whitening."""
    if _block(case) > 1:  # a mistake in the standardization of each column on its own
        return None
    f, model = _filtered(case)
    w, whitening = _posterior_weights(f)
    f = _restandardized(f, w, whitening)
    return _outputs(f, model, case)


def posterior_weights_toolbox_form(case: Case) -> dict[str, Any] | None:
    """§2.2 eq. (7) as ``diag(B' (B B' + R)^-1 B)``, ``B = L P_{t|t}^{1/2}``: the toolbox's form
    with the updated covariance.

    The toolbox writes the weights in this form, which equals §2.2 eq. (7) only with the
    predicted ``P_{t|t-1}`` in ``B``.
    """
    if _block(case) > 1:  # a mistake in the standardization of each column on its own
        return None
    f, model = _filtered(case)
    w = _toolbox_weights(f, model.R, model.L)
    f = _restandardized(f, w, f["P_pred_inv_sqrt"])
    return _outputs(f, model, case)


def standardized_after_update(case: Case) -> dict[str, Any] | None:
    """§2.2 eqs. (6)-(7) computed after the update, from ``P_{t|t}`` as if it were
    ``P_{t|t-1}``.

    ``w_t = diag(B' (B B' + R)^-1 B)`` with ``B = L P_{t|t}^{1/2}`` and
    ``z_t = W_t P_{t|t}^{-1/2} x_{t|t}``: the standardization placed after the update, where
    the covariance at hand is ``P_{t|t}``, instead of on ``P_{t|t-1}``.
    """
    if _block(case) > 1:  # a mistake in the standardization of each column on its own
        return None
    f, model = _filtered(case)
    w = _toolbox_weights(f, model.R, model.L)
    whitening = np.array([inverse_sqrt(P) for P in f["P_filt"]])
    f = _restandardized(f, w, whitening)
    return _outputs(f, model, case)


def exponent_on_square_root(case: Case) -> dict[str, Any] | None:
    """§2.2 eq. (7) as ``(w_t ** 1/2) ** -alpha``: the exponent on the square root of ``w_t``."""
    if _block(case) > 1:  # a mistake in the standardization of each column on its own
        return None
    f, model = _filtered(case)
    f = _restandardized(f, np.sqrt(f["w"]), f["P_pred_inv_sqrt"])
    return _outputs(f, model, case)


def exponent_fixed_at_half(case: Case) -> dict[str, Any] | None:
    """§2.2 eq. (7) as ``w_t ** -0.5`` whatever the exponent: the original SKF's, hard-wired."""
    return None if case.inputs["exponent"] == 0.5 else _rerun(case, exponent=0.5)


def exponent_dropped(case: Case) -> dict[str, Any] | None:
    """§2.2 eq. (7) as ``1 / w_t``: the exponent left out (as if it were 1)."""
    return None if case.inputs["exponent"] == 1 else _rerun(case, exponent=1.0)


def other_smoother(case: Case) -> dict[str, Any] | None:
    """§2.3 eq. (4) over the state ``x`` instead of ``z``, or over ``z`` instead of ``x``."""
    smoother = case.inputs["smoother"]
    if smoother in (None, "rts-smoothed-weights"):
        return None
    f, model = _filtered(case)
    swapped = {"rts-standardized": "rts-state", "rts-state": "rts-standardized"}[smoother]
    return _outputs(f, model, case, swapped)


def other_convention(case: Case) -> dict[str, Any] | None:
    """The priors of §3.1 eqs. (8)-(10) with the other amplitude (docs/model.md §4), or
    those of the stationary AR(1) prior (:func:`skf_ref.ar1_priors`) for its cases."""
    convention = case.extras.get("convention")
    if convention is None:
        return None
    other = [name for name in CONVENTIONS if name != convention][0]
    e, L = case.extras, case.inputs["L"]
    if "time_constant_ms" in e:  # the AR(1) prior: its transition is the case's
        theta0, q, _ = ar1_priors(
            L, e["noise_std"], e["pm_snr_db"], e["time_constant_ms"], e["sfreq"], other
        )
    else:
        theta0, q = priors_from_snr(
            L, e["noise_std"], e["pm_snr_db"], e["ep_snr_db"], case.shape[1], other
        )
    return _rerun(case, theta0=theta0, q=q)


def noise_std_as_variance(case: Case) -> dict[str, Any] | None:
    """``R = sigma I`` instead of ``sigma**2 I``: the noise standard deviation where the
    variance belongs.

    A scalar ``noise_cov`` in a case is the variance ``c`` (``R = c I``); this is the
    implementation that takes ``sqrt(c) I``.
    """
    c = case.inputs["noise_cov"]
    return None if np.ndim(c) or c == 1 else _rerun(case, noise_cov=np.sqrt(c))


def noise_variance_as_std(case: Case) -> dict[str, Any] | None:
    """``R = c**2 I`` from a scalar ``noise_cov = c``: the variance taken for a standard deviation.

    What ``reconstruct(..., noise_std=noise_cov)`` computes: a case's scalar ``noise_cov``
    is already the variance.
    """
    c = case.inputs["noise_cov"]
    return None if np.ndim(c) or c == 1 else _rerun(case, noise_cov=c**2)


def transition_ignored(case: Case) -> dict[str, Any] | None:
    """§2.2 eq. (4) with ``A = I`` whatever the transition (the toolbox, when ``A`` is
    diagonal with some diagonal entry exactly 1)."""
    A = case.inputs["transition"]
    if np.array_equal(A, np.eye(case.shape[0]) if np.ndim(A) else 1.0):
        return None
    return _rerun(case, transition=1.0)


def _first_prediction_unseen(case: Case) -> bool:
    """Whether ``A P_0 A^T + Q = P_0`` (to 1e-12): the stationary AR(1) prior's first step
    (:func:`skf_ref.ar1_priors`), where one prediction more or less before ``t = 1`` changes
    nothing, and a mistake in it cannot show."""
    _, _, A, Q, P0 = _matrices(_model(case)[0])
    return bool(np.allclose(A @ P0 @ A.T + Q, P0, rtol=1e-12, atol=0.0))


def no_first_prediction(case: Case) -> dict[str, Any] | None:
    """§2.2 eq. (4) skipped at ``t = 1``: update, then predict, so ``P_{1|0} = P_0``."""
    if _block(case) > 1:  # a mistake in the standardization of each column on its own
        return None
    if _first_prediction_unseen(case):
        return None
    model, Y = _model(case)
    L, R, A, Q, P0 = _matrices(model)
    T, n = Y.shape[1], L.shape[1]
    f: dict[str, Any] = {
        key: np.empty((T, n)) for key in ("x_filt", "x_pred", "z", "w", "weights")
    }
    for key in ("P_filt", "P_pred", "P_pred_inv_sqrt"):
        f[key] = np.empty((T, n, n))
    f["log_likelihood"], f["exponent"] = 0.0, case.inputs["exponent"]
    x, P = np.zeros(n), P0
    for t in range(T):
        # the mistake: no prediction before the first update (A = I, Q = 0), P_{1|0} = P_0
        A_t, Q_t = (np.eye(n), np.zeros((n, n))) if t == 0 else (A, Q)
        step = dense.step(x, P, Y[:, t], L, R, A_t, Q_t, case.inputs["exponent"])
        x, P = step["x"], step["P"]
        f["log_likelihood"] += step["log_likelihood"]
        f["weights"][t] = step["W"].ravel()
        for key, name in (("x_filt", "x"), ("P_filt", "P")):
            f[key][t] = step[name]
        for key in ("x_pred", "z", "w", "P_pred", "P_pred_inv_sqrt"):
            f[key][t] = step[key]
    f["W"] = f["weights"][:, :, None, None]  # W_t's 1 x 1 blocks
    return _outputs(f, model, case)


def extra_first_prediction(case: Case) -> dict[str, Any] | None:
    """§2.2 eq. (4) applied twice before ``t = 1``: ``P_{1|0} = A (A P_0 A^T + Q) A^T + Q``."""
    if _first_prediction_unseen(case):
        return None
    model, _ = _model(case)
    _, _, A, Q, P0 = _matrices(model)
    return _rerun(case, theta0=A @ P0 @ A.T + Q)


def missing_average_reference(case: Case) -> dict[str, Any] | None:
    """``L`` without the average reference of the data (docs/model.md §1, "Reference")."""
    L = case.extras.get("L_unreferenced")
    return None if L is None else _rerun(case, L=L)


#: Every known mistake, in the order the report lists them.
SUSPECTS = tuple(
    Suspect(function.__name__, function.__doc__ or "", function)
    for function in (
        transposed,
        posterior_in_weights,
        posterior_in_whitening,
        posterior_in_both,
        posterior_weights_toolbox_form,
        standardized_after_update,
        exponent_on_square_root,
        exponent_fixed_at_half,
        exponent_dropped,
        other_smoother,
        other_convention,
        noise_std_as_variance,
        noise_variance_as_std,
        transition_ignored,
        no_first_prediction,
        extra_first_prediction,
        missing_average_reference,
    )
)
