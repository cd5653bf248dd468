"""Case files (``.npz``, MATLAB v5 ``.mat``): written the same bytes every time, read back."""

from __future__ import annotations

import io
import os
import zipfile
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .._utils.atomic_files import atomic_path, check_output_path
from .._utils.checks import InputError, check_array, check_choice, check_instance
from ..method._result import readonly
from ..method._settings import check_smoother
from ._cases import EXTRAS, INPUTS, OPTIONS, OUTPUTS, Case, as_value
from ._intermediates import NAMES

__all__ = ["FORMATS", "read_case", "write_case"]

FORMATS = ("npz", "mat")
_ABOUT = (
    "case",
    "description",
    "exercises",
    "tolerance",
    "conformance_version",
    "skf_ref_version",
)
#: The expected intermediates a case file may carry (its inputs theta0 and q aside).
_CARRIED = tuple(name for name in NAMES if name not in (*OUTPUTS, *INPUTS))
_ZIP_DATE = (1980, 1, 1, 0, 0, 0)  # the earliest date a zip file can hold
# the 116 bytes of text that open a MATLAB v5 file; scipy writes the time of writing there
_MAT_HEADER = b"MATLAB 5.0 MAT-file, skf_ref conformance case".ljust(116)


def _write_npz(path, variables):
    """An uncompressed ``.npz`` with fixed zip dates: the same bytes for the same arrays."""
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_STORED) as archive:
        for name, value in variables.items():
            member = zipfile.ZipInfo(f"{name}.npy", date_time=_ZIP_DATE)
            member.external_attr = 0o644 << 16
            with archive.open(member, "w") as stream:
                np.lib.format.write_array(stream, np.asarray(value), allow_pickle=False)


def _write_mat(path, variables):
    """A MATLAB v5 ``.mat``, its header text naming the set instead of the time of writing."""
    from scipy.io import savemat

    buffer = io.BytesIO()
    savemat(buffer, variables, format="5", oned_as="column", do_compression=False)
    data = bytearray(buffer.getvalue())
    data[: len(_MAT_HEADER)] = _MAT_HEADER
    with atomic_path(path) as tmp:
        tmp.write_bytes(bytes(data))


def write_case(case: Case, path: str | os.PathLike) -> Path:
    """Write one case to ``.npz`` or MATLAB v5 ``.mat``, the same bytes every time.

    Parameters
    ----------
    case : Case
    path : path-like
        Ends in ``.npz`` or ``.mat``.

    Returns
    -------
    Path
    """
    path = check_output_path(path, suffixes=(".npz", ".mat"))
    check_instance("case", case, Case, "a conformance Case")
    (_write_npz if path.suffix == ".npz" else _write_mat)(path, case.variables())
    return path


def _text(variables, name, path):
    value = np.asarray(variables[name])
    if value.dtype.kind != "U" or value.ndim != 0:
        raise InputError(f"{path}: {name} must be text, got {value.dtype} of shape {value.shape}")
    return str(value)


def _scalar_or_square(variables, name, path, n):
    value = variables[name]
    if np.ndim(value) == 0:
        return float(check_array(f"{path}: {name}", value, ()))
    return readonly(check_array(f"{path}: {name}", value, (n, n)))


def _options(variables, path, n):
    """``standardize`` and ``n_orient`` (version 3 on); a file of version 2 has neither."""
    found = dict(OPTIONS)
    if "standardize" in variables:
        found["standardize"] = check_choice(
            f"{path}: standardize", _text(variables, "standardize", path), ("column", "position")
        )
    if "n_orient" in variables:
        n_orient = int(check_array(f"{path}: n_orient", variables["n_orient"], ()))
        if n_orient not in (1, 3) or n % n_orient:
            raise InputError(
                f"{path}: n_orient must be 1 or 3 and divide n_sources ({n}), got {n_orient}"
            )
        found["n_orient"] = n_orient
    return found


def read_case(path: str | os.PathLike) -> Case:
    """Read a case written by :func:`write_case` (or :func:`export`).

    Parameters
    ----------
    path : path-like
        A case's ``.npz`` or ``.mat`` file.

    Returns
    -------
    Case

    Raises
    ------
    skf_ref.InputError
        If the file is not a conformance case: names the missing variable or the shape.
    """
    from ..io._variables import read_variables

    variables = read_variables(path)
    missing = [name for name in (*_ABOUT, *INPUTS, *OUTPUTS) if name not in variables]
    if missing:
        raise InputError(f"{path}: not a conformance case: no variable {missing[0]!r}")
    L = readonly(check_array(f"{path}: L", variables["L"], ("n_channels", "n_sources")))
    Y = readonly(check_array(f"{path}: Y", variables["Y"], (L.shape[0], "n_times")))
    (m, n), T = L.shape, Y.shape[1]
    inputs = {"L": L, "Y": Y, "noise_cov": _scalar_or_square(variables, "noise_cov", path, m)}
    for name in ("theta0", "q", "transition"):
        inputs[name] = _scalar_or_square(variables, name, path, n)
    inputs["exponent"] = float(check_array(f"{path}: exponent", variables["exponent"], ()))
    try:
        inputs["smoother"] = check_smoother(_text(variables, "smoother", path))
    except InputError as err:
        raise InputError(f"{path}: {err}") from None
    inputs |= _options(variables, path, n)
    expected: dict[str, NDArray[np.float64] | float] = {
        name: readonly(check_array(f"{path}: {name}", variables[name], (n, T)))
        for name in OUTPUTS
        if name != "log_likelihood"
    }
    log_likelihood = variables["log_likelihood"]
    expected["log_likelihood"] = float(check_array(f"{path}: log_likelihood", log_likelihood, ()))
    extras = {
        name: _text(variables, name, path) if name == "convention" else as_value(variables[name])
        for name in EXTRAS
        if name in variables
    }
    carried = {name: as_value(variables[name]) for name in variables if name in _CARRIED}
    return Case(
        name=_text(variables, "case", path),
        description=_text(variables, "description", path),
        exercises=tuple(_text(variables, "exercises", path).split("; ")),
        inputs=inputs,
        expected=expected,
        extras=extras,
        tolerance=float(check_array(f"{path}: tolerance", variables["tolerance"], ())),
        conformance_version=int(
            check_array(f"{path}: version", variables["conformance_version"], ())
        ),
        skf_ref_version=_text(variables, "skf_ref_version", path),
        intermediates=carried,
    )
