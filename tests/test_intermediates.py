"""The intermediate quantities, the order the equations produce them, the first divergence,
and the measures compare names a known mistake by."""

import numpy as np
import pytest

from skf_ref.conformance import cases
from skf_ref.conformance._distances import FACTOR, NEARER, distance, explains, reproduces
from skf_ref.conformance._divergence import first_divergence, upstream
from skf_ref.conformance._expected import expected_intermediates, scales
from skf_ref.conformance._intermediates import (
    INTERMEDIATES,
    QUANTITIES,
    production_order,
    variables,
)

CASES = {case.name: case for case in cases()}
SMOOTHERS = (None, "rts-standardized", "rts-state", "rts-smoothed-weights")
# The identities below hold to rounding of double precision on these small cases.
RTOL = 1e-10


def _expected(case):
    expected = {**case.expected, **expected_intermediates(case)}
    return expected, scales(case, expected)


def _close(a, b):
    return np.max(np.abs(a - b)) <= RTOL * np.max(np.abs(b))


@pytest.mark.parametrize("name", CASES)
def test_the_expected_intermediates_satisfy_their_equations(name):
    case = CASES[name]
    found, _ = _expected(case)
    L, Y, T = case.inputs["L"], case.inputs["Y"], case.shape[1]
    R = case.inputs["noise_cov"]
    R = R * np.eye(L.shape[0]) if np.ndim(R) == 0 else R
    for t in range(T):
        P_pred, S, K, P = (found[k][:, :, t] for k in ("P_pred", "S", "K", "P_filt"))
        assert _close(L @ P_pred @ L.T + R, S)  # S_t = L P L^T + R
        assert _close(K @ S, P_pred @ L.T)  # K_t S_t = P L^T
        assert _close(P_pred - K @ S @ K.T, P)
        x_pred, x = found["x_pred"][:, t], found["x_filtered"][:, t]
        assert _close(x_pred + K @ (Y[:, t] - L @ x_pred), x)
        values, vectors = np.linalg.eigh(P_pred)
        whitening = (vectors / np.sqrt(values)) @ vectors.T
        assert _close(np.diag(whitening @ (P_pred - P) @ whitening), found["w"][:, t])
    if case.inputs["smoother"] is not None:
        for t in range(T - 1):  # P_{t+1|t} G_t^T = A P_{t|t}; P^s_t <= P_{t|t}
            G, P_next = found["G"][:, :, t], found["P_pred"][:, :, t + 1]
            A = case.inputs["transition"]
            A = A * np.eye(len(G)) if np.ndim(A) == 0 else A
            assert _close(P_next @ G.T, A @ found["P_filt"][:, :, t])
            gap = found["P_filt"][:, :, t] - found["P_smooth"][:, :, t]
            assert np.linalg.eigvalsh(gap).min() >= -RTOL * np.abs(gap).max()
        assert _close(found["P_smooth"][:, :, -1], found["P_filt"][:, :, -1])


@pytest.mark.parametrize("smoother", SMOOTHERS)
def test_the_order_holds_every_variable_once_a_step(smoother):
    T = 5
    order = production_order(smoother, T)
    defined = variables(smoother)
    assert len(order) == len(set(order))
    for name, variable in defined.items():
        steps = [step for other, step in order if other == name]
        if variable.stage in ("once", "end"):
            assert steps == [None]
        elif name == "G":
            assert sorted(steps) == list(range(1, T))
        else:
            assert sorted(steps) == list(range(1, T + 1))
    assert {v.quantity for v in defined.values()} <= set(QUANTITIES)
    # the priors first; the backward pass after the log-likelihood, from the last step down
    assert order[0] == ("theta0", None)
    end = order.index(("log_likelihood", None))
    assert all(defined[name].stage == "forward" for name, _ in order[2:end])
    backward = [step for name, step in order[end + 1 :] if defined[name].stage == "backward"]
    assert backward == sorted(backward, reverse=True)
    # each variable comes after what it is computed from: at its step, or the step before
    # (forward) or after (backward)
    position = {entry: i for i, entry in enumerate(order)}
    for (name, step), i in position.items():
        # the first prediction is from x_0, P_0; the smoothed state at T is the filter's
        first = name in ("x_pred", "P_pred") and step == 1
        first |= defined[name].stage == "backward" and step == T
        for source in defined[name].inputs:
            if step is None or defined[source].stage == "once" or first:
                continue
            near = [position.get((source, s), len(order)) for s in (step - 1, step, step + 1)]
            assert min(near) < i, (name, source, step)


def test_outputs_take_their_place_by_the_smoother():
    assert variables(None)["z"].quantity == "standardized"
    assert variables("rts-standardized")["z"].quantity == "smoothed_state"
    assert variables("rts-state")["x"].quantity == "smoothed_state"
    assert variables("rts-state")["z"].stage == "after"
    assert "G" not in variables(None) and "Sigma" not in variables("rts-state")
    assert {"Sigma", "w_smooth"} <= set(variables("rts-smoothed-weights"))
    named = {v.quantity for v in INTERMEDIATES}
    assert named | {"smoothed_state"} == set(QUANTITIES)


@pytest.mark.parametrize("name", ["original_skf", "general_model", "square", "transition"])
def test_the_first_divergence_is_where_a_change_is_made(name):
    case = CASES[name]
    expected, scale = _expected(case)
    smoother, T = case.inputs["smoother"], case.shape[1]
    rng = np.random.default_rng(36)
    assert first_divergence(expected, expected, scale, smoother, T, case.tolerance) is None
    order = [(n, s) for n, s in production_order(smoother, T) if s is not None]
    for _ in range(20):
        (first, step), (later, later_step) = sorted(
            (order[i] for i in rng.choice(len(order), 2, replace=False)), key=order.index
        )
        given = {k: np.array(v) for k, v in expected.items()}
        rows = []
        for variable, t in ((first, step), (later, later_step)):
            at_step = given[variable][..., t - 1]
            index = np.unravel_index(rng.integers(at_step.size), at_step.shape)
            given[variable][(*index, t - 1)] += 1e-3 * scale[variable]
            rows.append(index[0] + 1)
        found = first_divergence(given, expected, scale, smoother, T, case.tolerance)
        assert (found.output, found.step, found.source) == (first, step, rows[0])
        assert found.difference == pytest.approx(1e-3)
        assert found.quantity == variables(smoother)[first].quantity
        assert found.not_given == ()


def test_the_first_divergence_of_outputs_alone_lists_what_was_not_given():
    case = CASES["transition"]
    expected, scale = _expected(case)
    given = {k: np.array(expected[k]) for k in ("x_filtered", "weights", "z_filtered", "z")}
    given["x_filtered"][:, 1] *= 1.01
    found = first_divergence(given, expected, scale, "rts-state", 7, 1e-6)
    assert (found.quantity, found.output, found.step) == ("filtered_state", "x_filtered", 2)
    assert found.not_given == ("theta0", "q", "x_pred", "P_pred", "S", "K", "P_filt")
    assert "P_filt" in found.report()[1]
    # the prediction of step t comes from step t - 1's filtered state and covariance
    wanted = ["theta0", "q", "P_pred", "S", "K", "x_filtered", "P_filt"]
    assert upstream("x_pred", variables(None)) == wanted


def test_a_covariance_may_be_given_by_its_diagonal():
    case = CASES["full_noise_cov"]
    expected, scale = _expected(case)
    diagonal = np.diagonal(expected["P_filt"], axis1=0, axis2=1).T.copy()
    assert first_divergence({"P_filt": diagonal}, expected, scale, "rts-state", 7, 1e-6) is None
    diagonal[2, 3] *= 1.01
    found = first_divergence({"P_filt": diagonal}, expected, scale, "rts-state", 7, 1e-6)
    assert (found.step, found.source) == (4, 3)


def test_the_log_likelihood_is_measured_against_its_terms():
    case = CASES["priors_toolbox"]  # its log-likelihood is -0.43; its terms near 125
    expected, scale = _expected(case)
    assert abs(case.expected["log_likelihood"]) < 1 < 100 < scale["log_likelihood"]
    for other in CASES.values():
        found, own = _expected(other)
        # equal where every term has one sign, but the two sums round each their own way
        assert own["log_likelihood"] >= abs(other.expected["log_likelihood"]) * (1 - 1e-14)
    given = {"log_likelihood": case.expected["log_likelihood"] + 1e-5}  # 2e-5 of |LL|
    assert first_divergence(given, expected, scale, case.inputs["smoother"], 7, 1e-6) is None


def test_a_mistake_is_named_only_when_it_explains_every_output():
    tol = 1e-6
    agree, differ = {"x": 1e-9}, {"z": 1e-2}
    assert reproduces({"z": 0.5 * tol, "x": 0.0}, tol)
    assert explains({"z": FACTOR * tol, "x": 1e-9}, differ | agree, tol)
    assert explains({"z": 0.9e-2 / NEARER, "x": 1e-9}, differ | agree, tol)
    assert not explains({"z": 2e-2 / NEARER, "x": 1e-9}, differ | agree, tol)
    assert not explains({"z": 1e-9, "x": 2 * FACTOR * tol}, differ | agree, tol)  # breaks x
    assert not explains({"z": float("inf"), "x": 0.0}, {"z": float("inf"), "x": 0.0}, tol)


def test_two_small_sets_are_as_far_apart_as_they_are_from_each_other():
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((2, 4, 7))
    assert distance(a, b) == distance(b, a) == pytest.approx(distance(1e-9 * a, 1e-9 * b))
    assert distance(a, a) == 0 and distance(a, -a) == 2
    assert distance(a, np.where(a > 0, np.nan, a)) == np.inf
    assert distance(-0.5, -0.25, floor=100.0) == pytest.approx(0.0025)
