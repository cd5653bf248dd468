r"""Powers ``B^-alpha`` of symmetric positive definite blocks: standardization per position.

:func:`block_power` is the definition (docs/model.md §2, "Standardizing a position as a
whole"): ``B = E Diag(lambda) E^T`` by LAPACK's ``eigh``, ``B^-alpha = E Diag(lambda **
-alpha) E^T``, for stacks of blocks of any size. :func:`sym3_power` computes the same for
3 x 3 blocks in closed form, elementwise over arrays of blocks, which the spectral path
needs at every position and step (50 000 blocks a step at 150 000 sources, where batched
``eigh`` takes 0.3 s a step):

- the eigenvalues ``l1 >= l2 >= l3`` from the trigonometric solution of the characteristic
  polynomial, after scaling ``B`` by ``q = trace(B) / 3`` so that nothing under- or
  overflows: ``B = q I + p C`` with ``p^2 = tr((B - q I)^2) / 6``; ``r = det(C) / 2`` lies
  in [-1, 1]; ``phi = arccos(r) / 3``; ``l1 = q + 2 p cos(phi)``,
  ``l3 = q + 2 p cos(phi + 2 pi / 3)``, ``l2 = 3 q - l1 - l3``;
- ``B^-alpha = f1 I + f12 (B - l1 I) + f123 (B - l1 I)(B - l2 I)``, the Newton form of the
  polynomial that interpolates ``f(x) = x^-alpha`` at the eigenvalues (with multiplicity),
  which is exact for any eigenvalues, repeated or not, since ``B`` is diagonalizable. The
  divided differences are taken without cancellation: for ``a >= b``,
  ``f[a, b] = f(b) expm1(-alpha log1p(d)) / (a - b)`` with ``d = (a - b) / b``, and for
  ``alpha = 1/2`` in square roots only,
  ``f[a, b] = -1 / (sa sb (sa + sb))``,
  ``f[a, b, c] = (sa + sb + sc) / (sa sb sc (sa + sb)(sb + sc)(sa + sc))`` (``sa = a^(1/2)``).
  ``f[l1, l2, l3] = (f[l1, l2] - f[l2, l3]) / (l1 - l3)`` cancels only when ``l1 - l3`` is
  small, and then it multiplies ``(B - l1 I)(B - l2 I)``, of norm at most ``(l1 - l3)^2``: the
  error stays at rounding.

The trigonometric eigenvalues lose accuracy when ``l3`` is small against ``l1``, as
``eps (l1 / l3)^2`` relative (the angle ``phi`` is then ill-conditioned); blocks with
``l3 < RCOND l1`` are therefore computed by :func:`block_power` instead. Lead-field blocks
of EEG sit far inside this (condition numbers below 35 on the sphere and the sample
subject's BEM heads). Against a 40-digit evaluation of the same blocks the closed form's
normwise error is at most 800 eps on blocks with eigenvalues within two decades
(tests/test_block_powers.py), against LAPACK's 75.

Where numba is installed, arrays of at least ``MIN_BLOCKS`` blocks at the exponents
``m / 4`` go to the same closed form compiled into one vectorized loop
(``skf_ref.method._sym3_compiled``), 6 to 10 times faster; the two agree to rounding.
"""

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._sym3_compiled import apply_power, power, use_compiled

__all__ = ["RCOND", "SYM3_ENTRIES", "block_power", "sym3_apply", "sym3_power", "sym3_times"]

_Array = NDArray[np.float64]

#: The (row, column) of each of the six entries of a symmetric 3 x 3 block, in the order
#: :func:`sym3_power` takes and returns them.
SYM3_ENTRIES = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
#: Blocks whose smallest eigenvalue is below RCOND times the largest go to LAPACK.
RCOND = 1e-2
_DIAGONAL = (0, 3, 5)
# B^2 in the six entries: (B^2)_ij = sum_k B_ik B_kj, as index triples into SYM3_ENTRIES
_SQUARE = (
    ((0, 0), (1, 1), (2, 2)),
    ((0, 1), (1, 3), (2, 4)),
    ((0, 2), (1, 4), (2, 5)),
    ((1, 1), (3, 3), (4, 4)),
    ((1, 2), (3, 4), (4, 5)),
    ((2, 2), (4, 4), (5, 5)),
)


def block_power(B: ArrayLike, exponent: float) -> _Array:
    """``B^-exponent`` of each symmetric positive definite block, by ``eigh`` (the definition).

    Parameters
    ----------
    B : ndarray, shape (..., k, k)
        Symmetric blocks.
    exponent : float

    Returns
    -------
    ndarray, shape (..., k, k)
        Symmetric. An eigenvalue <= 0 gives a non-finite power (the result type refuses it
        with its cause).

    Examples
    --------
    >>> block_power(np.diag([4.0, 0.25])[None], 0.5).round(12).tolist()
    [[[0.5, 0.0], [0.0, 2.0]]]
    """
    eigenvalues, E = np.linalg.eigh(np.asarray(B, dtype=float))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        F = (E * eigenvalues[..., None, :] ** -exponent) @ np.swapaxes(E, -1, -2)
    return (F + np.swapaxes(F, -1, -2)) / 2


def sym3_power(
    b: ArrayLike, exponent: float, out: _Array | None = None, n_blocks: int | None = None
) -> _Array:
    """``B^-exponent`` of symmetric positive definite 3 x 3 blocks given by their entries.

    Parameters
    ----------
    b : ndarray, shape (6, ...)
        The entries ``B[i, j]`` of :data:`SYM3_ENTRIES`, each an array of blocks.
    exponent : float
    out : ndarray, shape (6, ...), optional
        Where to write the result (not ``b``).
    n_blocks : int, optional
        The blocks of the whole job this call is part of (default those of ``b``): many
        take the compiled loop where numba is installed, however the job is cut.

    Returns
    -------
    ndarray, shape (6, ...)
        The entries of ``B^-exponent``, in the same order.

    Examples
    --------
    >>> B = np.array([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 4.0]])
    >>> b = np.array([B[i, j] for i, j in SYM3_ENTRIES])
    >>> F = sym3_power(b, 0.5)
    >>> expected = block_power(B, 0.5)
    >>> bool(np.allclose(F, [expected[i, j] for i, j in SYM3_ENTRIES], rtol=1e-14))
    True
    """
    b = np.asarray(b, dtype=float)
    result = np.empty_like(b) if out is None else out
    flat, F = b.reshape(6, -1), result.reshape(6, -1)  # views (a copy only for 0-d blocks)
    if exponent == 0:  # the identity, NaN kept (a missing step has no weights)
        F[...] = 0.0 * flat
        F[list(_DIAGONAL)] += 1.0
    elif (m := use_compiled(n_blocks or flat.shape[1], exponent)) is not None:
        power(np.ascontiguousarray(flat), m, RCOND, F)
        _by_lapack(flat, exponent, F, ~np.isfinite(F[0]))
    else:
        _closed_form(flat, exponent, F)
    if not np.shares_memory(F, result):
        result[...] = F.reshape(result.shape)
    return result


def _closed_form(b: _Array, exponent: float, out: _Array) -> _Array:
    """:func:`sym3_power` in numpy passes over (6, N) arrays ``b`` into ``out``."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
        scale = (b[0] + b[3] + b[5]) / 3
        c = b / scale  # B / q: eigenvalues about 1, nothing under- or overflows
        l1, l2, l3 = _eigenvalues(c)
        f1, f12, f123 = _newton(l1, l2, l3, exponent)
        # B^-alpha = f1 I + f12 (B - l1) + f123 (B - l1)(B - l2) = c0 I + c1 B + c2 B^2
        c1 = f12 - f123 * (l1 + l2)
        c0 = f1 - f12 * l1 + f123 * l1 * l2
        for k, ((i0, j0), (i1, j1), (i2, j2)) in enumerate(_SQUARE):
            square = c[i0] * c[j0] + c[i1] * c[j1] + c[i2] * c[j2]
            np.multiply(c1, c[k], out=out[k])
            out[k] += f123 * square
        for k in _DIAGONAL:
            out[k] += c0
        out *= np.exp(-exponent * np.log(scale))  # (q C)^-alpha = q^-alpha C^-alpha
    return _by_lapack(b, exponent, out, ~(l3 >= RCOND * l1))  # not positive, or not finite


def sym3_apply(
    b: ArrayLike,
    v: ArrayLike,
    exponent: float,
    out: _Array | None = None,
    n_blocks: int | None = None,
) -> _Array:
    """``B^-exponent v`` for symmetric positive definite 3 x 3 blocks and 3-vectors.

    Parameters
    ----------
    b : ndarray, shape (6, ...)
        The entries of the blocks (:data:`SYM3_ENTRIES`).
    v : ndarray, shape (3, ...)
        One vector per block.
    exponent : float
    out : ndarray, shape (3, ...), optional
        Where to write the result (not ``v``).
    n_blocks : int, optional
        As :func:`sym3_power`.

    Returns
    -------
    ndarray, shape (3, ...)

    Examples
    --------
    >>> b = np.array([4.0, 0.0, 0.0, 1.0, 0.0, 0.25])  # Diag(4, 1, 1/4)
    >>> sym3_apply(b, np.ones(3), 0.5).round(12).tolist()
    [0.5, 1.0, 2.0]
    """
    b = np.asarray(b, dtype=float).reshape(6, -1)
    v = np.asarray(v, dtype=float)
    result = np.empty_like(v) if out is None else out
    flat_v = v.reshape(3, -1)
    z = np.empty_like(flat_v)
    m = use_compiled(n_blocks or b.shape[1], exponent)
    if m is None:
        sym3_times(sym3_power(b, exponent), flat_v, z)
    else:
        apply_power(np.ascontiguousarray(b), np.ascontiguousarray(flat_v), m, RCOND, z)
        far = ~np.isfinite(z[0])  # left to LAPACK
        if far.any():
            z[:, far] = sym3_times(_by_lapack(b[:, far], exponent, None), flat_v[:, far])
    result[...] = z.reshape(v.shape)
    return result


def sym3_times(F: _Array, v: _Array, out: _Array | None = None) -> _Array:
    """``F v`` for the entries ``F`` (6, ...) of symmetric blocks and vectors ``v`` (3, ...).

    Examples
    --------
    >>> F = np.array([2.0, 1.0, 0.0, 2.0, 0.0, 1.0])[:, None]  # [[2, 1, 0], [1, 2, 0], [0, 0, 1]]
    >>> sym3_times(F, np.array([1.0, 0.0, 3.0])[:, None]).ravel().tolist()
    [2.0, 1.0, 3.0]
    """
    out = np.empty_like(v) if out is None else out
    for i, (k0, k1, k2) in enumerate(((0, 1, 2), (1, 3, 4), (2, 4, 5))):
        np.multiply(F[k0], v[0], out=out[i])
        out[i] += F[k1] * v[1]
        out[i] += F[k2] * v[2]
    return out


def _by_lapack(
    b: _Array, exponent: float, out: _Array | None, far: NDArray[np.bool_] | None = None
) -> _Array:
    """``out`` with the blocks ``far`` (ill-conditioned) computed by :func:`block_power`;
    with ``out=None``, every block of ``b`` (6, N), into a new array."""
    if out is None:
        out, far = np.empty_like(b), np.ones(b.shape[1], bool)
    assert far is not None
    undefined = far & ~np.isfinite(b).all(axis=0)  # a missing step's NaN stays NaN
    out[:, undefined] = np.nan
    far = far & ~undefined
    if far.any():
        blocks = np.empty((int(far.sum()), 3, 3))
        for k, (i, j) in enumerate(SYM3_ENTRIES):
            blocks[:, i, j] = blocks[:, j, i] = b[k][far]
        powers = block_power(blocks, exponent)
        for k, (i, j) in enumerate(SYM3_ENTRIES):
            out[k][far] = powers[:, i, j]
    return out


def _eigenvalues(c: _Array) -> tuple[_Array, _Array, _Array]:
    """``l1 >= l2 >= l3`` of blocks ``c`` (6, ...) with trace 3, trigonometric form."""
    d0, d1, d2 = c[0] - 1, c[3] - 1, c[5] - 1
    c01, c02, c12 = c[1], c[2], c[4]
    p2 = (d0 * d0 + d1 * d1 + d2 * d2 + 2 * (c01 * c01 + c02 * c02 + c12 * c12)) / 6
    p = np.sqrt(p2)
    # det(B - q I) / (2 p^3), in [-1, 1] up to rounding
    det = d0 * (d1 * d2 - c12 * c12) - c01 * (c01 * d2 - c12 * c02) + c02 * (c01 * c12 - d1 * c02)
    r = np.divide(det, 2 * p2 * p, out=np.zeros_like(p), where=p > 0)
    phi = np.arccos(np.clip(r, -1.0, 1.0, out=r)) / 3
    l1 = 1 + 2 * p * np.cos(phi)
    l3 = 1 + 2 * p * np.cos(phi + 2 * np.pi / 3)
    return l1, 3 - l1 - l3, l3


def _newton(l1: _Array, l2: _Array, l3: _Array, exponent: float) -> tuple[_Array, _Array, _Array]:
    """``f(l1), f[l1, l2], f[l1, l2, l3]`` for ``f(x) = x^-exponent``, ``l1 >= l2 >= l3 > 0``."""
    if exponent == 0.5:
        s1, s2, s3 = np.sqrt(l1), np.sqrt(l2), np.sqrt(l3)
        s12, s23, s13 = s1 + s2, s2 + s3, s1 + s3
        f1 = 1 / s1
        f12 = -f1 / (s2 * s12)
        return f1, f12, (s1 + s2 + s3) * f1 / (s2 * s3 * s12 * s23 * s13)
    if exponent == 1:
        f1 = 1 / l1
        f12 = -f1 / l2
        return f1, f12, -f12 / l3
    f3 = np.exp(-exponent * np.log(l3))
    # f[a, b] = f(b) expm1(-alpha log1p((a - b) / b)) / (a - b)
    d23, d12 = l2 - l3, l1 - l2
    e23 = np.expm1(-exponent * np.log1p(d23 / l3))
    f2 = f3 * (1 + e23)
    e12 = np.expm1(-exponent * np.log1p(d12 / l2))
    f1 = f2 * (1 + e12)
    f12 = np.where(d12 > 0, f2 * e12 / d12, -exponent * f2 / l2)
    f23 = np.where(d23 > 0, f3 * e23 / d23, -exponent * f3 / l3)
    d13 = l1 - l3
    second = exponent * (exponent + 1) / 2 * f2 / (l2 * l2)  # f''(l2) / 2, when l1 = l3
    return f1, f12, np.where(d13 > 0, (f12 - f23) / d13, second)
