"""The spectral path equals the dense reference on random small models (hypothesis)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skf_ref import priors_from_snr, reconstruct
from skf_ref.spectral import SpectralModel

# Both paths are exact; the dense one rounds through eigh and Cholesky solves of matrices
# whose condition numbers stay below ~1e6 here. Measured worst case ~1e-12.
EQUALITY_RTOL = 1e-8
QUANTITIES = ("z", "x", "z_filtered", "x_filtered", "weights")


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@st.composite
def models(draw):
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    m = draw(st.integers(2, 9))
    n = draw(st.integers(1, 14))
    T = draw(st.integers(1, 7))
    L = draw(st.sampled_from([1e-3, 1.0, 1e3])) * rng.standard_normal((m, n))
    if draw(st.booleans()) and m > 2:
        L -= L.mean(axis=0)  # average reference: rank m - 1
    if draw(st.booleans()) and n > 2:
        L[:, -1] = L[:, 0] + L[:, 1]  # a dependent column
    sigma = draw(st.sampled_from([1e-6, 1.0]))
    Y = sigma * 3 * rng.standard_normal((m, T))
    if draw(st.booleans()):
        noise = dict(noise_std=sigma)
    else:
        B = rng.standard_normal((m, m))
        noise = dict(noise_cov=sigma**2 * (B @ B.T / m + 0.3 * np.eye(m)))
    theta0, q = priors_from_snr(
        L,
        sigma,
        pm_snr_db=draw(st.sampled_from([-20.0, 0.0, 20.0])),
        ep_snr_db=draw(st.sampled_from([-20.0, 0.0, 20.0, 40.0])),
        n_steps=T,
    )
    return dict(
        L=L,
        Y=Y,
        theta0=theta0,
        q=draw(st.sampled_from([0.0, q])),
        transition=draw(st.sampled_from([1.0, 0.8, -0.5])),
        exponent=draw(st.sampled_from([0.0, 0.5, 1.0, 1.25, 1.5, 2.0])),
        smoother=draw(st.sampled_from([None, "rts-standardized", "rts-state"])),
        **noise,
    )


@settings(max_examples=150, deadline=None)
@given(models())
def test_spectral_equals_dense(model):
    dense = reconstruct(**model, method="dense")
    spectral = reconstruct(**model, method="spectral")
    for name in QUANTITIES:
        assert relative(getattr(spectral, name), getattr(dense, name)) <= EQUALITY_RTOL, name
    assert np.isclose(spectral.log_likelihood, dense.log_likelihood, rtol=EQUALITY_RTOL)


def test_auto_takes_spectral_when_the_model_qualifies():
    rng = np.random.default_rng(0)
    L, Y = rng.standard_normal((5, 8)), rng.standard_normal((5, 4))
    kwargs = dict(noise_std=1.0, theta0=1.0, q=0.1)
    assert reconstruct(L, Y, **kwargs).method == "spectral"
    assert reconstruct(L, Y, **kwargs, transition=0.5 * np.eye(8)).method == "spectral"
    assert reconstruct(L, Y, **kwargs, transition=np.diag(np.arange(1.0, 9))).method == "dense"


@pytest.mark.parametrize(
    "name, value",
    [
        ("transition", np.diag(np.arange(1.0, 9))),
        ("q", np.diag(np.arange(1.0, 9))),
        ("theta0", np.diag(np.arange(1.0, 9))),
    ],
)
def test_forcing_spectral_on_a_model_that_does_not_qualify(name, value):
    rng = np.random.default_rng(1)
    L, Y = rng.standard_normal((5, 8)), rng.standard_normal((5, 4))
    kwargs = dict(noise_std=1.0, theta0=1.0, q=0.1) | {name: value}
    with pytest.raises(ValueError, match=f"method='spectral'.*{name} is not a scalar multiple"):
        reconstruct(L, Y, **kwargs, method="spectral")


def test_prepared_model_applied_many_times_equals_fresh_runs():
    rng = np.random.default_rng(2)
    L = rng.standard_normal((6, 12))
    L -= L.mean(axis=0)
    model = SpectralModel(L, np.eye(6), 1.0, 0.05, 1.0, n_times=5)
    for exponent, smoother in [(0.5, None), (1.25, "rts-standardized"), (1.5, "rts-state")]:
        Y = rng.standard_normal((6, 5))
        prepared = model.apply(Y, exponent, smoother)
        fresh = reconstruct(
            L, Y, noise_std=1.0, theta0=1.0, q=0.05, exponent=exponent, smoother=smoother
        )
        for name in QUANTITIES:
            np.testing.assert_array_equal(getattr(prepared, name), getattr(fresh, name))
    assert model.rank == 5
    with pytest.raises(ValueError, match=r"Y must have shape \(6, 5\)"):
        model.apply(rng.standard_normal((6, 4)), 0.5, None)


def test_outputs_are_computed_on_access_only():
    rng = np.random.default_rng(3)
    rec = reconstruct(
        rng.standard_normal((4, 30)), rng.standard_normal((4, 3)), noise_std=1.0, theta0=1.0, q=1.0
    )
    assert all(callable(v) for v in rec._arrays.values())
    assert rec.z.shape == (30, 3)
    assert not callable(rec._arrays["z"]) and callable(rec._arrays["weights"])
    assert rec.z is rec.z  # computed once, then kept
