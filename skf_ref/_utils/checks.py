"""Input checks for every public entry point, and the error types they raise.

Every check names the parameter, says what was expected and shows what was received:
``"exponent must be a real number, got '1' (str)"``. A wrong *kind* of object raises
:class:`InputTypeError` (a ``TypeError``), a wrong *value* or shape :class:`InputError` (a
``ValueError``). Both are :class:`InputError`, so the command line can tell a user's mistake
(one line, exit status 2) from a bug in this package (a traceback). Nothing is transposed,
reshaped or cast silently.
"""

import functools
import numbers
import os
from collections.abc import Callable, Collection, Iterable, Sequence
from pathlib import Path
from typing import Any, ParamSpec, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import linalg

__all__ = [
    "MAX_DB",
    "InputError",
    "InputTypeError",
    "check_array",
    "check_choice",
    "check_db",
    "check_instance",
    "check_int",
    "check_leadfield",
    "check_memory_limit",
    "check_names",
    "check_path",
    "check_real",
    "check_scalar_or_spd",
    "check_spd",
    "check_transition",
    "check_vector",
    "describe",
    "path_renamed",
]

_P = ParamSpec("_P")
_R = TypeVar("_R")

#: What ``method=`` given to an SKF function (its computational path until 0.6.0) hears.
PATH_RENAMED = (
    "method= was renamed path= in skf_ref 0.6.0: it chooses the computational path ('auto', "
    "'dense', 'filterpy', 'spectral'), not an inverse method as MNE's method= does (for "
    "MNE, dSPM, sLORETA or eLORETA beside the SKF, see skf_ref.study.apply_minimum_norm)"
)


class InputError(ValueError):
    """A user input has a wrong value, shape or combination; a ``ValueError``."""


class InputTypeError(InputError, TypeError):
    """A user input is the wrong kind of object; a ``TypeError`` (and an :class:`InputError`)."""


def path_renamed(func: Callable[_P, _R]) -> Callable[_P, _R]:
    """``func``, refusing ``method=`` with :data:`PATH_RENAMED` (for one release, 0.6.x).

    Examples
    --------
    >>> @path_renamed
    ... def run(path="auto"):
    ...     return path
    >>> run(method="dense")
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputTypeError: method= was renamed path= in skf_ref 0.6.0: ...
    """

    @functools.wraps(func)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        if "method" in kwargs:
            raise InputTypeError(PATH_RENAMED)
        return func(*args, **kwargs)

    return wrapper


def describe(value: object) -> str:
    """A short description of a received value for error messages.

    Examples
    --------
    >>> describe(2.5), describe("20"), describe(np.zeros((3, 4)))
    ('2.5 (float)', "'20' (str)", 'an array of shape (3, 4)')
    """
    if isinstance(value, np.ndarray) and value.ndim > 0:
        return f"an array of shape {value.shape}"
    text = repr(value.item() if isinstance(value, np.ndarray) else value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def check_choice(name: str, value: Any, allowed: Collection[Any]) -> Any:
    """Return ``value`` if it is one of ``allowed``, else raise naming all of them.

    Examples
    --------
    >>> check_choice("smoother", "rts", (None, "rts-state"))
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: smoother must be one of [None, 'rts-state'], got 'rts'
    """
    try:
        known = value in allowed and not isinstance(value, bool)
    except TypeError:  # unhashable
        known = False
    if not known:
        raise InputError(f"{name} must be one of {list(allowed)!r}, got {value!r}")
    return value


def check_real(
    name: str,
    value: Any,
    *,
    positive: bool = False,
    nonnegative: bool = False,
    minimum: float | None = None,
    maximum: float | None = None,
) -> float:
    """A finite real scalar (``bool`` excluded), optionally > 0, >= 0 and in [min, max].

    Examples
    --------
    >>> check_real("snr_db", 20)
    20.0
    >>> check_real("snr_db", "20")
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputTypeError: snr_db must be a real number, got '20' (str)
    """
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputTypeError(f"{name} must be a real number, got {describe(value)}")
    value = float(value)
    if not np.isfinite(value):
        raise InputError(f"{name} must be finite, got {value!r}")
    if positive and value <= 0:
        raise InputError(f"{name} must be > 0, got {value!r}")
    if nonnegative and value < 0:
        raise InputError(f"{name} must be >= 0, got {value!r}")
    if minimum is not None and value < minimum:
        raise InputError(f"{name} must be >= {minimum:g}, got {value!r}")
    if maximum is not None and value > maximum:
        raise InputError(f"{name} must be <= {maximum:g}, got {value!r}")
    return value


#: Largest |level| in dB a parameter may have: 10**(dB/10) stays far inside double range.
MAX_DB = 300.0


def check_db(name: str, value: Any) -> float:
    """A level in dB (an SNR): finite and within +-:data:`MAX_DB`.

    Examples
    --------
    >>> check_db("pm_snr_db", -4000)
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: pm_snr_db must be >= -300 dB, got -4000.0
    """
    value = check_real(name, value)
    if abs(value) > MAX_DB:
        bound = f">= {-MAX_DB:g}" if value < 0 else f"<= {MAX_DB:g}"
        raise InputError(f"{name} must be {bound} dB, got {value!r}")
    return value


def check_int(
    name: str, value: Any, *, minimum: int | None = 1, maximum: int | None = None
) -> int:
    """An integer (``bool`` excluded) in ``[minimum, maximum]``.

    Examples
    --------
    >>> check_int("n_positions", 2.5)
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputTypeError: n_positions must be an integer, got 2.5 (float)
    """
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise InputTypeError(f"{name} must be an integer, got {describe(value)}")
    value = int(value)
    if minimum is not None and value < minimum:
        raise InputError(f"{name} must be >= {minimum}, got {value!r}")
    if maximum is not None and value > maximum:
        raise InputError(f"{name} must be <= {maximum}, got {value!r}")
    return value


def check_instance(
    name: str, value: Any, cls: type | tuple[type, ...], what: str | None = None
) -> Any:
    """``value`` if it is an instance of ``cls``, else an :class:`InputTypeError`."""
    if not isinstance(value, cls):
        what = what or getattr(cls, "__name__", str(cls))
        raise InputTypeError(f"{name} must be {what}, got {describe(value)}")
    return value


def check_array(
    name: str, value: ArrayLike, shape: Sequence[int | str | None], *, finite: bool = True
) -> NDArray[np.float64]:
    """A float array of exactly ``shape``, finite unless ``finite=False``.

    Entries of ``shape`` that are ``None`` or a name (``"n_times"``) match any length; the
    error message shows the names. Masked arrays are refused: their mask would be lost.

    Examples
    --------
    >>> check_array("Y", np.zeros((3, 2)), (4, "n_times"))
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: Y must have shape (4, n_times), got (3, 2)
    """
    if isinstance(value, np.ma.MaskedArray):
        raise InputTypeError(
            f"{name} must be a plain array, got a masked array: fill or drop the masked "
            "samples first (np.ma.filled, or select the columns to keep)"
        )
    if np.iscomplexobj(value):
        raise InputTypeError(f"{name} must be real, got a complex array")
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise InputTypeError(f"{name} must be a numeric array, got {describe(value)}") from err
    names = ["any" if s is None else str(s) for s in shape]
    wanted = f"({names[0]},)" if len(names) == 1 else f"({', '.join(names)})"
    if array.ndim != len(shape) or any(
        isinstance(s, int) and s != got for s, got in zip(shape, array.shape, strict=False)
    ):
        raise InputError(f"{name} must have shape {wanted}, got {array.shape}")
    if finite and not np.all(np.isfinite(array)):
        raise InputError(f"{name} contains NaN or Inf")
    return array


def check_vector(name: str, value: ArrayLike, length: int) -> NDArray[np.float64]:
    """``length`` finite numbers as a float array of shape (length,).

    Examples
    --------
    >>> check_vector("deep_position_mm", (1, 2), 3)
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: deep_position_mm must have shape (3,), got (2,)
    """
    return check_array(name, value, (length,))


def check_leadfield(L: ArrayLike, name: str = "L") -> NDArray[np.float64]:
    """Lead field (n_channels, n_sources), finite, at least one column, no all-zero column."""
    L = check_array(name, L, ("n_channels", "n_sources"))
    if 0 in L.shape:
        raise InputError(
            f"{name} must have at least one channel and one source, got shape {L.shape}"
        )
    zero = np.flatnonzero(~np.any(L, axis=0))
    if zero.size:
        raise InputError(
            f"{name} has zero sensitivity (an all-zero column) at column {zero[0]}"
            + (f" and {zero.size - 1} more" if zero.size > 1 else "")
            + "; the standardization weights are undefined there: remove the column"
        )
    return L


def check_spd(name: str, value: ArrayLike, n: int) -> NDArray[np.float64]:
    """A symmetric positive definite (n, n) matrix; returns it symmetrized.

    Positive definite to double precision: a matrix whose smallest eigenvalue is within
    rounding of zero (an average-referenced noise covariance, rank n - 1) is refused even
    when a Cholesky factorization happens to pass, since inverting it would amplify rounding.
    """
    matrix = check_array(name, value, (n, n))
    scale = np.max(np.abs(matrix))
    if not np.allclose(matrix, matrix.T, rtol=0, atol=1e-12 * scale):
        raise InputError(f"{name} must be symmetric")
    matrix = (matrix + matrix.T) / 2
    eigenvalues = linalg.eigvalsh(matrix)
    rounding = 10 * n * np.finfo(float).eps * max(eigenvalues[-1], 0.0)
    if eigenvalues[0] < -rounding:
        raise InputError(
            f"{name} must be positive definite, got eigenvalues from {eigenvalues[0]:.3g} to "
            f"{eigenvalues[-1]:.3g}: a negative variance, so no covariance"
        )
    if not eigenvalues[0] > rounding:
        raise InputError(
            f"{name} must be positive definite, got eigenvalues from {eigenvalues[0]:.3g} to "
            f"{eigenvalues[-1]:.3g} (singular to double precision); a rank-deficient covariance "
            "(e.g. of average-referenced data) must be whitened to its rank (MNE's whitener "
            "does: skf_ref.apply_skf, or skf-ref reconstruct --forward --evoked) or regularized"
        )
    return matrix


def check_scalar_or_spd(
    name: str, value: Any, n: int, *, allow_zero: bool = False
) -> float | NDArray[np.float64]:
    """An isotropic variance (positive scalar, meaning value * I) or an SPD (n, n) matrix."""
    if np.ndim(value) == 0:
        if allow_zero:
            return check_real(name, value, nonnegative=True)
        return check_real(name, value, positive=True)
    return check_spd(name, value, n)


def check_transition(value: Any, n: int) -> float | NDArray[np.float64]:
    """Transition: a scalar a (A = a I) or a finite (n, n) matrix."""
    if np.ndim(value) == 0:
        return check_real("transition", value)
    return check_array("transition", value, (n, n))


def check_path(name: str, value: object) -> Path:
    """``value`` as a :class:`~pathlib.Path` if it is a file name (``str`` or path-like).

    Anything else (an array, a source estimate, ``bytes``, ``None``) raises an
    :class:`InputTypeError` naming the parameter: a writer given its arguments in the
    wrong order says so instead of failing inside :mod:`pathlib`.

    Examples
    --------
    >>> check_path("path", "out/est.stc").name
    'est.stc'
    >>> check_path("path", 3.5)
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputTypeError: path must be a file name (str or ...), got 3.5 (float)
    """
    if isinstance(value, str | os.PathLike) and not isinstance(value, bytes):
        path = Path(value)
        if str(path) not in ("", "."):
            return path
        raise InputError(f"{name} must be a file name, got {str(value)!r}")
    raise InputTypeError(f"{name} must be a file name (str or path-like), got {describe(value)}")


def check_memory_limit(value: object, name: str = "memory_limit") -> float | None:
    """A memory budget in bytes: ``None`` (the default budget) or a finite number > 0.

    One check for every ``memory_limit`` argument: ``"1G"`` is refused as text (give
    ``2**30``), NaN and infinity as not finite, zero and negative budgets as such.

    Examples
    --------
    >>> check_memory_limit(2**30)
    1073741824.0
    >>> check_memory_limit("1G")
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputTypeError: memory_limit must be a real number, got '1G' (str)
    """
    if value is None:
        return None
    return check_real(name, value, positive=True)


def check_names(name: str, names: Iterable[object], unit: str = "position") -> list[str]:
    """Channel names as a list of ``str``: none empty, none given twice.

    ``unit`` is what the message calls a name's place (``"position"``, ``"row"``).

    Examples
    --------
    >>> check_names("ch_names", ["Fp1", "Cz", "Fp1"])
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: ch_names holds 'Fp1' twice (positions 1 and 3): ...
    """
    labels = [str(label).strip() for label in names]
    seen: dict[str, int] = {}
    for position, label in enumerate(labels, start=1):
        if not label:
            raise InputError(f"{name} has an empty name at {unit} {position}")
        if label in seen:
            raise InputError(
                f"{name} holds {label!r} twice ({unit}s {seen[label]} and {position}): each "
                "channel needs a name of its own"
            )
        seen[label] = position
    return labels
