"""Powers of symmetric positive definite blocks: the definition (eigh) and the 3 x 3 closed form.

The closed form (trigonometric eigenvalues, the Newton divided differences of x^-alpha,
LAPACK for blocks spanning more than two decades) is checked against a 40-digit mpmath
evaluation of the same floating-point blocks, on random and adversarial blocks: equal and
nearly equal eigenvalues, diagonal and graded blocks, ill-conditioned ones. The measure is
the normwise error ``||F_computed - F|| / ||F||``, which for LAPACK's eigh is a few eps
times the condition number kappa; the closed form is held to CLOSED_FORM_FACTOR eps kappa.
"""

import functools

import mpmath
import numpy as np
import pytest

from skf_ref.method._powers import RCOND, SYM3_ENTRIES, block_power, sym3_apply, sym3_power

EPS = np.finfo(float).eps
# the worst seen on these cases (300 blocks each, in a longer run than this one's 25): 800
# eps at kappa <= 100, where the closed form is used, and eigh's own error past it
CLOSED_FORM_FACTOR = 1e3
EXPONENTS = (0.0, 0.25, 0.5, 0.7, 1.0, 1.25, 1.5, 2.0)


def rotations(rng, n):
    Q, R = np.linalg.qr(rng.standard_normal((n, 3, 3)))
    return Q * np.sign(np.diagonal(R, axis1=1, axis2=2))[:, None, :]


def with_eigenvalues(rng, eigenvalues):
    Q = rotations(rng, len(eigenvalues))
    B = np.einsum("nij,nj,nkj->nik", Q, eigenvalues, Q)
    return (B + np.swapaxes(B, 1, 2)) / 2


def cases():
    rng = np.random.default_rng(0)
    n = 25
    out = {}
    for decades in (0, 1, 2, 4, 8):
        eigenvalues = 10 ** rng.uniform(-decades, 0, (n, 3))
        out[f"spread 1e{decades}"] = with_eigenvalues(rng, eigenvalues)
    for gap in (0.0, 1e-15, 1e-10, 1e-5):
        out[f"triple, gap {gap:g}"] = with_eigenvalues(rng, 1 + gap * rng.uniform(size=(n, 3)))
        top = np.column_stack([np.ones(n), 1 + gap * rng.uniform(size=n), rng.uniform(0.02, 1, n)])
        out[f"top pair, gap {gap:g}"] = with_eigenvalues(rng, top)
        near = 0.02 * (1 + gap * rng.uniform(size=n))
        low = np.column_stack([np.ones(n), near, np.full(n, 0.02)])
        out[f"bottom pair, gap {gap:g}"] = with_eigenvalues(rng, low)
    diagonal = np.zeros((n, 3, 3))
    diagonal[:, [0, 1, 2], [0, 1, 2]] = 10 ** rng.uniform(-4, 0, (n, 3))
    out["diagonal"] = diagonal
    out["multiple of I"] = np.eye(3) * rng.uniform(1e-3, 1, (n, 1, 1))
    scale = 10 ** rng.uniform(-3, 0, (n, 3))
    inner = with_eigenvalues(rng, 10 ** rng.uniform(-1, 0, (n, 3)))
    out["graded D C D"] = inner * scale[:, :, None] * scale[:, None, :]
    V = rng.standard_normal((n, 3, 60)) * np.array([1.0, 1.0, 0.05])[None, :, None]
    out["V Diag(omega) V^T, one weak row"] = np.einsum(
        "nak,k,nbk->nab", V, 10 ** rng.uniform(-4, 0, 60), V
    )
    out["tiny scale"] = with_eigenvalues(rng, 1e-150 * rng.uniform(0.5, 1, (n, 3)))
    return out


CASES = cases()


@functools.cache
def exact_eigen(name):
    """40-digit eigendecompositions of the blocks of case ``name`` (kept: mpmath is slow)."""
    with mpmath.workdps(40):
        return [mpmath.eigsy(mpmath.matrix(B.tolist())) for B in CASES[name]]


def exact_power(name, exponent):
    """B^-exponent of every block of case ``name``, from its 40-digit eigendecomposition."""
    powers = []
    with mpmath.workdps(40):
        for eigenvalues, E in exact_eigen(name):
            D = mpmath.diag([value ** (-mpmath.mpf(exponent)) for value in eigenvalues])
            F = E * D * E.T
            powers.append([[float(F[i, j]) for j in range(3)] for i in range(3)])
    return np.array(powers)


def entries(B):
    return np.array([B[..., i, j] for i, j in SYM3_ENTRIES])


def full(F):
    B = np.empty(F.shape[1:] + (3, 3))
    for k, (i, j) in enumerate(SYM3_ENTRIES):
        B[..., i, j] = B[..., j, i] = F[k]
    return B


@pytest.mark.parametrize("name", sorted(CASES))
@pytest.mark.parametrize("exponent", EXPONENTS)
def test_closed_form_against_forty_digits(name, exponent):
    B = CASES[name]
    exact = exact_power(name, exponent)
    closed = full(sym3_power(entries(B), exponent))
    eigenvalues = np.linalg.eigvalsh(B)
    kappa = eigenvalues[:, 2] / eigenvalues[:, 0]
    error = np.linalg.norm(closed - exact, 2, axis=(1, 2)) / np.linalg.norm(exact, 2, axis=(1, 2))
    assert np.all(error <= CLOSED_FORM_FACTOR * EPS * np.maximum(kappa, 1.0))


@pytest.mark.parametrize("exponent", EXPONENTS)
def test_definition_is_eigh(exponent):
    rng = np.random.default_rng(1)
    for k in (1, 2, 3):
        A = rng.standard_normal((5, k, 2 * k))
        B = A @ np.swapaxes(A, 1, 2)
        F = block_power(B, exponent)
        eigenvalues, E = np.linalg.eigh(B)
        expected = np.einsum("nij,nj,nkj->nik", E, eigenvalues**-exponent, E)
        np.testing.assert_allclose(F, expected, rtol=1e-13, atol=1e-13 * np.abs(expected).max())
        np.testing.assert_array_equal(F, np.swapaxes(F, 1, 2))  # symmetric


def test_closed_form_equals_the_definition_on_lead_field_blocks():
    # blocks as the spectral path forms them, B = V_i Diag(omega) V_i^T, any shape of stack
    rng = np.random.default_rng(2)
    V = rng.standard_normal((4, 7, 3, 40))
    omega = rng.uniform(1e-3, 1, 40)
    B = np.einsum("...ak,k,...bk->...ab", V, omega, V)
    for exponent in EXPONENTS:
        closed = full(sym3_power(entries(B), exponent))
        expected = block_power(B, exponent)
        np.testing.assert_allclose(closed, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_closed_form_writes_into_out_and_leaves_its_input():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((10, 3, 5))
    b = entries(A @ np.swapaxes(A, 1, 2))
    before = b.copy()
    out = np.empty_like(b)
    result = sym3_power(b, 1.25, out=out)
    assert result is out
    np.testing.assert_array_equal(b, before)


def test_a_singular_block_gives_a_non_finite_power():
    # MEG's silent radial orientation: the result type refuses it with its cause
    B = np.diag([1.0, 0.5, 0.0])[None]
    with np.errstate(all="ignore"):
        assert not np.isfinite(sym3_power(entries(B), 0.5)).all()
        assert not np.isfinite(block_power(B, 0.5)).all()


@pytest.mark.parametrize("name", sorted(CASES))
@pytest.mark.parametrize("exponent", [e for e in EXPONENTS if 0 < e and (4 * e) % 1 == 0])
def test_compiled_closed_form_against_forty_digits(name, exponent):
    # the numba loop (polynomial trisection, square roots only), where numba is installed
    compiled = pytest.importorskip("skf_ref.method._sym3_compiled")
    if not compiled.AVAILABLE:
        pytest.skip("numba is not installed")
    B = CASES[name]
    b = np.ascontiguousarray(entries(B))
    m = compiled.compiled_exponent(exponent)
    F = compiled.power(b, m, RCOND, np.empty_like(b))
    left = ~np.isfinite(F[0])  # blocks the closed form leaves to LAPACK
    F[:, left] = sym3_power(b[:, left], exponent)
    exact = exact_power(name, exponent)
    eigenvalues = np.linalg.eigvalsh(B)
    kappa = eigenvalues[:, 2] / eigenvalues[:, 0]
    error = np.linalg.norm(full(F) - exact, 2, axis=(1, 2)) / np.linalg.norm(exact, 2, axis=(1, 2))
    assert np.all(error <= CLOSED_FORM_FACTOR * EPS * np.maximum(kappa, 1.0))
    v = np.random.default_rng(4).standard_normal((3, len(B)))
    z = compiled.apply_power(b, v, m, RCOND, np.empty_like(v))
    expected = np.einsum("nij,jn->in", exact, v)
    kept = ~left
    assert np.all(np.isnan(z[:, left]))
    np.testing.assert_allclose(
        z[:, kept], expected[:, kept], rtol=0, atol=1e-10 * np.abs(expected).max()
    )


@pytest.mark.parametrize("exponent", [0.5, 0.7, 1.25])
def test_apply_is_the_power_times_the_vector(exponent, monkeypatch):
    # both ways: numpy, and the compiled loop where numba is installed (any size)
    from skf_ref.method import _sym3_compiled

    rng = np.random.default_rng(5)
    A = rng.standard_normal((40, 3, 6))
    B = A @ np.swapaxes(A, 1, 2)
    B[0] = np.diag([1.0, 1e-4, 1e-4])  # left to LAPACK
    b, v = entries(B), rng.standard_normal((3, 40))
    expected = np.einsum("nij,jn->in", block_power(B, exponent), v)
    for threshold in (10**9, 1):
        monkeypatch.setattr(_sym3_compiled, "MIN_BLOCKS", threshold)
        z = sym3_apply(b, v, exponent)
        np.testing.assert_allclose(z, expected, rtol=0, atol=1e-11 * np.abs(expected).max())
        F = sym3_power(b, exponent)
        np.testing.assert_allclose(full(F), block_power(B, exponent), rtol=0, atol=1e-10)
