r"""The 3 x 3 closed form of ``skf_ref.method._powers``, compiled by numba when it is installed.

The same algebra as ``skf_ref.method._powers.sym3_power``, element by element in one
loop that the compiler turns into vector instructions: 6 to 10 times faster than numpy's
passes over whole arrays (20-25 ns a block against 120-290 ns, measured on this project's
benchmark machine), which is what standardizing 50 000 positions at each of 1000 steps
needs. Two changes make the loop vectorizable, neither changes the result beyond rounding:

- ``cos(phi)`` and ``sin(phi)`` with ``phi = arccos(r) / 3`` come from two polynomials in
  ``t = ((1 + r) / 2)^(1/2)`` in place of ``arccos`` and ``cos`` (which compile to calls
  that stop vectorization): ``cos(phi) = C(t)`` and ``sin(phi) = (1 - t)^(1/2) H(t)`` with
  ``C`` and ``H`` analytic on [0, 1] (``phi = (2/3) arccos(t)``, and ``sin(2x/3) / x`` is even
  in ``x``), fitted at import to 2 ulp by Chebyshev interpolation of degree 18;
- exponents ``alpha = m / 4`` only (0.25, 0.5, ..., 2, the paper's and the package's
  defaults among them): ``x^-alpha = y^-m`` with ``y = x^(1/4)``, two square roots, and
  ``f[a, b] = -(sum_k ya^k yb^(m-1-k)) / (ya^m yb^m (ya + yb)(ya^2 + yb^2))``, a sum of
  positive terms (no cancellation, no ``exp`` or ``log``).

A block the closed form leaves to LAPACK (``rcond``, ``skf_ref.method._powers.RCOND``) comes out
as NaN here, and the caller computes it by numpy. Each exponent compiles once per process
(about a second; cached on disk by numba where it can write), so the spectral path calls
this only for many blocks (:data:`MIN_BLOCKS`).
"""

import functools
import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["AVAILABLE", "MIN_BLOCKS", "apply_power", "compiled_exponent", "power", "use_compiled"]

try:
    import numba
except ImportError:  # pragma: no cover - depends on the environment
    numba = None

#: Whether numba is installed.
AVAILABLE = numba is not None
#: Blocks below which compiling (about a second per exponent) costs more than it saves.
MIN_BLOCKS = 2_000_000
_DEGREE = 18


def compiled_exponent(exponent: float) -> int | None:
    """``4 * exponent`` if it is an integer from 1 to 8 (the compiled exponents), else None.

    Examples
    --------
    >>> compiled_exponent(1.25), compiled_exponent(0.7)
    (5, None)
    """
    m = 4 * float(exponent)
    return int(m) if m == int(m) and 1 <= m <= 8 else None


def use_compiled(n_blocks: int, exponent: float) -> int | None:
    """``m`` (exponent ``m / 4``) if the compiled loop should take ``n_blocks`` blocks at
    ``exponent``, else None: numba missing, too few blocks to pay for compiling, or an
    exponent that is not one of the compiled ones.

    Examples
    --------
    >>> use_compiled(10, 0.5) is None  # too few blocks
    True
    """
    if not AVAILABLE or n_blocks < MIN_BLOCKS:
        return None
    return compiled_exponent(exponent)


def _trisection_polynomials() -> list[NDArray[np.float64]]:
    """Monomial coefficients of ``C(t) = cos(2/3 arccos t)`` and
    ``H(t) = sin(2/3 arccos t) / (1 - t)^(1/2)`` on [0, 1], degree :data:`_DEGREE`."""
    nodes = (np.cos(np.pi * (np.arange(4 * _DEGREE) + 0.5) / (4 * _DEGREE)) + 1) / 2
    angle = 2 / 3 * np.arccos(nodes)
    fits = []
    for values in (np.cos(angle), np.sin(angle) / np.sqrt(1 - nodes)):
        series = np.polynomial.Chebyshev.fit(nodes, values, _DEGREE, domain=[0, 1])
        monomial = series.convert(kind=np.polynomial.Polynomial, domain=[0, 1], window=[0, 1])
        fits.append(np.asarray(monomial.coef, dtype=np.float64))
    return fits


if AVAILABLE:
    _COS, _SIN = _trisection_polynomials()  # arrays: constants of the compiled loops
    _SQRT3 = math.sqrt(3.0)

    _jit = functools.partial(numba.njit, inline="always", cache=True)

    @_jit
    def horner(coef, t):
        acc = coef[_DEGREE]
        for k in range(_DEGREE - 1, -1, -1):
            acc = acc * t + coef[k]
        return acc

    @_jit
    def power_m(y, m):  # y^m, 1 <= m <= 8, by squaring: no loop the compiler cannot unroll
        y2 = y * y
        y4 = y2 * y2
        out = y if m & 1 else 1.0
        out = out * y2 if m & 2 else out
        out = out * y4 if m & 4 else out
        return out * (y4 * y4) if m & 8 else out

    @_jit
    def first(ya, yb, m):  # f[a, b] of f = x^-(m/4), a = ya^4, b = yb^4
        # sum_{k<m} ya^k yb^(m-1-k) by P_1 = 1, P_(j+1) = ya P_j + yb^j: positive terms
        total, yb_power = 1.0, yb
        for j in range(1, 8):
            total = ya * total + yb_power if j < m else total
            yb_power *= yb
        return -total / (power_m(ya, m) * power_m(yb, m) * (ya + yb) * (ya * ya + yb * yb))

    @_jit
    def first_half(sa, sb, k):  # f[a, b] of f = x^-(k/2), a = sa^2, b = sb^2
        total, sb_power = 1.0, sb
        for j in range(1, 4):
            total = sa * total + sb_power if j < k else total
            sb_power *= sb
        return -total / (power_m(sa, k) * power_m(sb, k) * (sa + sb))

    @_jit
    def eigenvalues(b0, b1, b2, b3, b4, b5):
        """``c`` = B / q, ``q`` and the eigenvalues l1 >= l2 >= l3 of ``c``."""
        q = (b0 + b3 + b5) * (1.0 / 3.0)
        iq = 1.0 / q
        c00, c01, c02, c11, c12, c22 = b0 * iq, b1 * iq, b2 * iq, b3 * iq, b4 * iq, b5 * iq
        d0, d1, d2 = c00 - 1.0, c11 - 1.0, c22 - 1.0
        p2 = (d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * (c01 * c01 + c02 * c02 + c12 * c12)) / 6.0
        p = math.sqrt(p2)
        det = (
            d0 * (d1 * d2 - c12 * c12)
            - c01 * (c01 * d2 - c12 * c02)
            + c02 * (c01 * c12 - d1 * c02)
        )
        den = 2.0 * p2 * p
        r = det / den if den > 0.0 else 0.0
        r = min(max(r, -1.0), 1.0)
        t = math.sqrt(0.5 * (1.0 + r))
        cosine = horner(_COS, t)
        sine = math.sqrt(0.5 * (1.0 - r) / (1.0 + t)) * horner(_SIN, t)
        l1 = 1.0 + 2.0 * p * cosine
        l2 = 1.0 - p * (cosine - _SQRT3 * sine)
        l3 = 1.0 - p * (cosine + _SQRT3 * sine)
        return c00, c01, c02, c11, c12, c22, q, l1, l2, l3

    @_jit
    def polynomial(q, l1, l2, l3, f1, f12, f23, second, scale, rcond):
        """(k0, k1, k2) with B^-alpha = k0 I + k1 c + k2 c^2 from the Newton form; NaN k0
        when the block is left to LAPACK."""
        d13 = l1 - l3
        f123 = (f12 - f23) / d13 if d13 > 0.0 else second
        k0 = (f1 - f12 * l1 + f123 * l1 * l2) * scale
        k0 = k0 if l3 >= rcond * l1 else math.nan
        return k0, (f12 - f123 * (l1 + l2)) * scale, f123 * scale

    @_jit
    def coefficients(b0, b1, b2, b3, b4, b5, m, rcond):
        """``c`` = B / q and (k0, k1, k2): exponent m / 4 in fourth roots."""
        c00, c01, c02, c11, c12, c22, q, l1, l2, l3 = eigenvalues(b0, b1, b2, b3, b4, b5)
        y1, y2, y3 = math.sqrt(math.sqrt(l1)), math.sqrt(math.sqrt(l2)), math.sqrt(math.sqrt(l3))
        alpha = m / 4.0
        second = alpha * (alpha + 1.0) / 2.0 / (power_m(y2, m) * l2 * l2)  # f''(l2) / 2
        scale = 1.0 / power_m(math.sqrt(math.sqrt(q)), m)  # (q C)^-alpha = q^-alpha C^-alpha
        f1, f12, f23 = 1.0 / power_m(y1, m), first(y1, y2, m), first(y2, y3, m)
        k0, k1, k2 = polynomial(q, l1, l2, l3, f1, f12, f23, second, scale, rcond)
        return c00, c01, c02, c11, c12, c22, k0, k1, k2

    @_jit
    def coefficients_half(b0, b1, b2, b3, b4, b5, k, rcond):
        """The same for an even m = 2 k, in square roots only (exponent k / 2)."""
        c00, c01, c02, c11, c12, c22, q, l1, l2, l3 = eigenvalues(b0, b1, b2, b3, b4, b5)
        s1, s2, s3 = math.sqrt(l1), math.sqrt(l2), math.sqrt(l3)
        alpha = k / 2.0
        second = alpha * (alpha + 1.0) / 2.0 / (power_m(s2, k) * l2 * l2)
        scale = 1.0 / power_m(math.sqrt(q), k)
        f1, f12, f23 = 1.0 / power_m(s1, k), first_half(s1, s2, k), first_half(s2, s3, k)
        k0, k1, k2 = polynomial(q, l1, l2, l3, f1, f12, f23, second, scale, rcond)
        return c00, c01, c02, c11, c12, c22, k0, k1, k2

    _OPTIONS = dict(nogil=True, error_model="numpy", fastmath={"contract"}, cache=True)

    @_jit
    def store_power(i, c, o0, o1, o2, o3, o4, o5):
        """``B^-alpha = k0 I + k1 c + k2 c^2`` into the six outputs at ``i``, ``c`` the
        entries of ``B / q`` and ``k`` (:func:`coefficients`)."""
        c00, c01, c02, c11, c12, c22, k0, k1, k2 = c
        o0[i] = k0 + k1 * c00 + k2 * (c00 * c00 + c01 * c01 + c02 * c02)
        o1[i] = k1 * c01 + k2 * (c00 * c01 + c01 * c11 + c02 * c12) + 0.0 * k0
        o2[i] = k1 * c02 + k2 * (c00 * c02 + c01 * c12 + c02 * c22) + 0.0 * k0
        o3[i] = k0 + k1 * c11 + k2 * (c01 * c01 + c11 * c11 + c12 * c12)
        o4[i] = k1 * c12 + k2 * (c01 * c02 + c11 * c12 + c12 * c22) + 0.0 * k0
        o5[i] = k0 + k1 * c22 + k2 * (c02 * c02 + c12 * c12 + c22 * c22)

    @_jit
    def store_applied(i, c, v0, v1, v2, o0, o1, o2):
        """``B^-alpha v = k0 v + k1 c v + k2 c (c v)`` into the three outputs at ``i``."""
        c00, c01, c02, c11, c12, c22, k0, k1, k2 = c
        x0, x1, x2 = v0[i], v1[i], v2[i]
        u0 = c00 * x0 + c01 * x1 + c02 * x2
        u1 = c01 * x0 + c11 * x1 + c12 * x2
        u2 = c02 * x0 + c12 * x1 + c22 * x2
        o0[i] = k0 * x0 + k1 * u0 + k2 * (c00 * u0 + c01 * u1 + c02 * u2)
        o1[i] = k0 * x1 + k1 * u1 + k2 * (c01 * u0 + c11 * u1 + c12 * u2)
        o2[i] = k0 * x2 + k1 * u2 + k2 * (c02 * u0 + c12 * u1 + c22 * u2)

    # Each loop comes twice, for an even m (square roots) and an odd one (fourth roots): the
    # choice is made once, outside the loop, so that each loop vectorizes.

    @numba.njit(**_OPTIONS)
    def _run(b0, b1, b2, b3, b4, b5, m, rcond, o0, o1, o2, o3, o4, o5):
        if m % 2 == 0:
            for i in range(b0.shape[0]):
                c = coefficients_half(b0[i], b1[i], b2[i], b3[i], b4[i], b5[i], m // 2, rcond)
                store_power(i, c, o0, o1, o2, o3, o4, o5)
        else:
            for i in range(b0.shape[0]):
                c = coefficients(b0[i], b1[i], b2[i], b3[i], b4[i], b5[i], m, rcond)
                store_power(i, c, o0, o1, o2, o3, o4, o5)

    @numba.njit(**_OPTIONS)
    def _run_fused(b0, b1, b2, b3, b4, b5, v0, v1, v2, m, rcond, o0, o1, o2):
        if m % 2 == 0:
            for i in range(b0.shape[0]):
                c = coefficients_half(b0[i], b1[i], b2[i], b3[i], b4[i], b5[i], m // 2, rcond)
                store_applied(i, c, v0, v1, v2, o0, o1, o2)
        else:
            for i in range(b0.shape[0]):
                c = coefficients(b0[i], b1[i], b2[i], b3[i], b4[i], b5[i], m, rcond)
                store_applied(i, c, v0, v1, v2, o0, o1, o2)


def power(
    b: NDArray[np.float64], m: int, rcond: float, out: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``out = B^-(m/4)`` for contiguous ``b``, ``out`` of shape (6, N); NaN in the blocks
    whose smallest eigenvalue is below ``rcond`` times the largest (left to LAPACK)."""
    _run(*b, m, rcond, *out)
    return out


def apply_power(
    b: NDArray[np.float64],
    v: NDArray[np.float64],
    m: int,
    rcond: float,
    out: NDArray[np.float64],
) -> NDArray[np.float64]:
    """``out = B^-(m/4) v`` for contiguous ``b`` (6, N), ``v`` and ``out`` (3, N); NaN
    where the block is left to LAPACK (as :func:`power`)."""
    _run_fused(*b, *v, m, rcond, *out)
    return out
