"""Bad input to ``reconstruct``: each raises ValueError or TypeError naming the parameter."""

import numpy as np
import pytest

from skf_ref import reconstruct

M, N, T = 6, 8, 5  # channels, sources, time steps (T != M so a transposed Y is detectable)


def _valid():
    rng = np.random.default_rng(3)
    L = rng.standard_normal((M, N))
    return {
        "L": L,
        "Y": L @ rng.standard_normal((N, T)),
        "noise_std": 0.1,
        "theta0": 1.0,
        "q": 0.1,
    }


def _asymmetric():
    C = np.eye(M)
    C[0, 1] = 0.5
    return C


def _indefinite():
    C = np.eye(M)
    C[0, 0] = -1.0
    return C


def _with(name, value):
    """The valid arguments with ``name`` set to ``value`` (``None`` removes it)."""

    def arguments():
        kwargs = _valid()
        kwargs[name] = value(kwargs) if callable(value) else value
        return {k: v for k, v in kwargs.items() if v is not None}

    return arguments


def _bad_entry(name, value):
    def array(kwargs):
        out = kwargs[name].copy()
        out[1, 2] = value
        return out

    return _with(name, array)


def _zero_column(kwargs):
    L = kwargs["L"].copy()
    L[:, 4] = 0.0
    return L


def _noise_cov_too():
    kwargs = _valid()
    kwargs["noise_cov"] = np.eye(M)
    return kwargs


def _no_noise():
    kwargs = _valid()
    del kwargs["noise_std"]
    return kwargs


def _noise_cov(value):
    def arguments():
        kwargs = _valid()
        del kwargs["noise_std"]
        kwargs["noise_cov"] = value
        return kwargs

    return arguments


CASES = {
    "L 1-D": (
        _with("L", lambda k: k["L"][:, 0]),
        ValueError,
        r"L must have shape \(n_channels, n_sources\), got \(6,\)",
    ),
    "L 3-D": (_with("L", lambda k: k["L"][None]), ValueError, r"L must have shape"),
    "L NaN": (_bad_entry("L", np.nan), ValueError, "L contains NaN or Inf"),
    "L Inf": (_bad_entry("L", np.inf), ValueError, "L contains NaN or Inf"),
    "L strings": (_with("L", [["a", "b"]]), TypeError, "L must be a numeric array"),
    "L zero column": (_with("L", _zero_column), ValueError, "L has zero sensitivity.*column 4"),
    "Y wrong n_channels": (
        _with("Y", lambda k: k["Y"][:-1]),
        ValueError,
        rf"Y must have shape \({M}, n_times\), got \({M - 1}, {T}\)",
    ),
    "Y transposed": (
        _with("Y", lambda k: k["Y"].T),
        ValueError,
        rf"Y must have shape \({M}, n_times\), got \({T}, {M}\)",
    ),
    "Y 1-D": (_with("Y", lambda k: k["Y"][:, 0]), ValueError, r"Y must have shape"),
    "Y no time step": (_with("Y", np.zeros((M, 0))), ValueError, "Y must have at least one"),
    "Y NaN": (
        _bad_entry("Y", np.nan),
        ValueError,
        r"Y\[:, \d+\] is NaN in 1 of its \d+ channels: a step is either measured on every",
    ),
    "Y Inf": (_bad_entry("Y", -np.inf), ValueError, r"Y contains Inf \(first in column \d+\)"),
    "noise_std zero": (_with("noise_std", 0.0), ValueError, "noise_std must be > 0"),
    "noise_std negative": (_with("noise_std", -0.1), ValueError, "noise_std must be > 0"),
    "noise_std NaN": (_with("noise_std", np.nan), ValueError, "noise_std must be finite"),
    "noise_std string": (_with("noise_std", "0.1"), TypeError, "noise_std must be a real"),
    "noise_std array": (_with("noise_std", np.ones(M)), TypeError, "noise_std must be a real"),
    "both noise_std and noise_cov": (_noise_cov_too, ValueError, "exactly one of noise_std"),
    "neither noise_std nor noise_cov": (_no_noise, ValueError, "exactly one of noise_std"),
    "noise_cov not symmetric": (
        _noise_cov(_asymmetric()),
        ValueError,
        "noise_cov must be symmetric",
    ),
    "noise_cov not positive definite": (
        _noise_cov(_indefinite()),
        ValueError,
        "noise_cov must be positive definite",
    ),
    "noise_cov singular": (
        _noise_cov(np.diag([1.0] * (M - 1) + [0.0])),
        ValueError,
        "noise_cov must be positive definite",
    ),
    "noise_cov wrong shape": (
        _noise_cov(np.eye(M + 1)),
        ValueError,
        rf"noise_cov must have shape \({M}, {M}\), got \({M + 1}, {M + 1}\)",
    ),
    "noise_cov scalar": (_noise_cov(0.01), ValueError, r"noise_cov must have shape"),
    "theta0 zero": (_with("theta0", 0.0), ValueError, "theta0 must be > 0"),
    "theta0 negative": (_with("theta0", -1.0), ValueError, "theta0 must be > 0"),
    "theta0 string": (_with("theta0", "1"), TypeError, "theta0 must be a real number"),
    "theta0 wrong shape": (
        _with("theta0", np.eye(N - 1)),
        ValueError,
        rf"theta0 must have shape \({N}, {N}\)",
    ),
    "theta0 not positive definite": (
        _with("theta0", -np.eye(N)),
        ValueError,
        "theta0 must be positive definite",
    ),
    "q negative": (_with("q", -0.1), ValueError, "q must be >= 0"),
    "q Inf": (_with("q", np.inf), ValueError, "q must be finite"),
    "q string": (_with("q", "0.1"), TypeError, "q must be a real number"),
    "q not symmetric": (
        _with("q", np.triu(np.ones((N, N)))),
        ValueError,
        "q must be symmetric",
    ),
    "exponent negative": (_with("exponent", -0.5), ValueError, "exponent must be >= 0"),
    "exponent string": (_with("exponent", "0.5"), TypeError, "exponent must be a real number"),
    "exponent bool": (_with("exponent", True), TypeError, "exponent must be a real number"),
    "unknown smoother": (
        _with("smoother", "rts"),
        ValueError,
        r"smoother must be one of \[None, 'rts-standardized', 'rts-state', "
        r"'rts-smoothed-weights', 'none'\], got 'rts'",
    ),
    "smoother True": (_with("smoother", True), ValueError, "smoother must be one of"),
    "unknown path": (
        _with("path", "cuda"),
        ValueError,
        r"path must be one of \[.*'filterpy', 'dense'.*\], got 'cuda'",
    ),
    "transition wrong shape": (
        _with("transition", np.eye(N + 1)),
        ValueError,
        rf"transition must have shape \({N}, {N}\), got \({N + 1}, {N + 1}\)",
    ),
    "transition vector": (
        _with("transition", np.ones(N)),
        ValueError,
        r"transition must have shape",
    ),
    "transition NaN": (_with("transition", np.nan), ValueError, "transition must be finite"),
    "transition string": (_with("transition", "I"), TypeError, "transition must be a real"),
}


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
@pytest.mark.parametrize("method", ["filterpy", "dense"])
def test_bad_input_raises_naming_the_parameter(case, method):
    arguments, error, match = CASES[case]
    kwargs = {"path": method, **arguments()}
    with pytest.raises(error, match=match):
        reconstruct(**kwargs)


def test_valid_arguments_pass():
    # The cases above are the valid arguments with one thing wrong: the base must work.
    for method in ("filterpy", "dense"):
        rec = reconstruct(**_valid(), path=method)
        assert rec.z.shape == (N, T)


def test_square_data_is_not_transposed():
    # With n_times == n_channels the shapes cannot tell; time must still run along axis 1.
    kwargs = _valid()
    Y = kwargs.pop("Y")[:, :1] @ np.ones((1, M))  # (M, M), constant over time
    rec = reconstruct(Y=Y, **kwargs)
    assert rec.z.shape == (N, M)
    first = reconstruct(Y=Y[:, :1], **kwargs)
    np.testing.assert_allclose(rec.z_filtered[:, :1], first.z_filtered, rtol=1e-12)


# Inputs that once slipped through: complex data cast to real, memory_limit unchecked.
@pytest.mark.parametrize(
    "arguments, error, match",
    [
        pytest.param(
            _with("Y", lambda k: k["Y"] + 1j),
            TypeError,
            "Y must be real",
            id="Y complex",
        ),
        pytest.param(
            _with("memory_limit", "1GB"),
            TypeError,
            "memory_limit must be a real number",
            id="memory_limit string",
        ),
        pytest.param(
            _with("memory_limit", -1.0),
            ValueError,
            "memory_limit must be > 0",
            id="memory_limit negative",
        ),
    ],
)
def test_inputs_that_once_slipped_through(arguments, error, match):
    with pytest.raises(error, match=match):
        reconstruct(**arguments())


@pytest.mark.parametrize(
    "exponent, error, match",
    [(-0.5, ValueError, "exponent must be >= 0"), ("1", TypeError, "exponent must be a real")],
)
def test_filter_class_checks_its_exponent(exponent, error, match):
    from skf_ref import StandardizedKalmanFilter

    with pytest.raises(error, match=match):
        StandardizedKalmanFilter(dim_x=3, dim_z=2, exponent=exponent)


def test_a_zero_transition_needs_process_noise():
    # P_{1|0} = A P_0 A^T + Q is 0 when both A and Q are: refused
    with pytest.raises(ValueError, match="q must be > 0 when transition is 0"):
        reconstruct(**_with("q", 0.0)(), transition=0.0)


def test_a_zero_transition_matrix_needs_process_noise():
    with pytest.raises(ValueError, match="q must be > 0 when transition is 0"):
        reconstruct(**_with("q", 0.0)(), transition=np.zeros((N, N)))


# Either of A and Q nonzero is a model: each case below alone (a static state, white
# sources, matrices of either) must run, and pins one clause of the guard above.


def test_a_static_state_needs_no_process_noise():
    static = reconstruct(**_with("q", 0.0)(), transition=1.0)  # q = 0, A = I
    np.testing.assert_allclose(static.x_filtered[:, -1], static.x[:, -1])


def test_a_static_state_of_a_matrix_transition_needs_no_process_noise():
    rec = reconstruct(**_with("q", 0.0)(), transition=0.5 * np.eye(N), path="dense")
    assert np.isfinite(rec.z).all()


def test_white_sources_need_no_transition():
    rec = reconstruct(**_valid(), transition=0.0)  # q > 0, A = 0
    assert np.isfinite(rec.z).all()


def test_white_sources_need_no_transition_matrix():
    rec = reconstruct(**_valid(), transition=np.zeros((N, N)), path="dense")
    np.testing.assert_allclose(rec.z, reconstruct(**_valid(), transition=0.0).z, rtol=1e-12)


def test_a_process_noise_matrix_without_transition():
    rec = reconstruct(**_with("q", 0.1 * np.eye(N))(), transition=0.0, path="dense")
    scalar = reconstruct(**_valid(), transition=0.0, path="dense")
    np.testing.assert_allclose(rec.z, scalar.z, rtol=1e-12)


def test_a_process_noise_matrix_with_a_random_walk():
    rec = reconstruct(**_with("q", 0.1 * np.eye(N))(), transition=1.0, path="dense")
    np.testing.assert_allclose(rec.z, reconstruct(**_valid(), path="dense").z, rtol=1e-12)


# --- memory_limit: one check for every entry point that takes one --------------------------

MEMORY_LIMITS = [
    ("1G", TypeError, r"memory_limit must be a real number, got '1G' \(str\)"),
    (float("nan"), ValueError, "memory_limit must be finite, got nan"),
    (float("inf"), ValueError, "memory_limit must be finite, got inf"),
    (-5, ValueError, "memory_limit must be > 0, got -5"),
    (0, ValueError, "memory_limit must be > 0, got 0"),
    (True, TypeError, "memory_limit must be a real number, got True"),
]


@pytest.mark.parametrize("value, error, match", MEMORY_LIMITS)
def test_check_memory_limit(value, error, match):
    from skf_ref._utils.checks import check_memory_limit

    with pytest.raises(error, match=match):
        check_memory_limit(value)


def test_check_memory_limit_passes_a_budget_or_none():
    from skf_ref._utils.checks import check_memory_limit

    assert check_memory_limit(None) is None and check_memory_limit(2**30) == 2.0**30


@pytest.mark.parametrize("value, error, match", MEMORY_LIMITS)
def test_apply_skf_raw_checks_memory_limit(mne_setup, value, error, match):
    import mne

    from skf_ref import apply_skf_raw, make_skf_operator

    info = mne_setup["info"]
    raw = mne.io.RawArray(np.zeros((len(info.ch_names), 50)), info, verbose=False)
    raw.set_eeg_reference("average", projection=True, verbose=False)
    operator = make_skf_operator(raw.info, mne_setup["forward"], noise_std=1e-6, verbose=False)
    with pytest.raises(error, match=match):
        apply_skf_raw(raw, operator, memory_limit=value)
