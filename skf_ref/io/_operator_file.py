"""Prepared SKF operators on disk, as MNE's ``write_inverse_operator`` / ``read_inverse_operator``.

The file is HDF5 (written by h5io, as MNE writes its objects that FIF does not hold), one
group ``skf_ref`` with, in format version 2:

=================  ==================================================================
``format``         ``"skf_ref.SKFOperator"``: what the file holds
``version``        the format's version, an integer (:data:`OPERATOR_FORMAT_VERSION`)
``skf_ref``        the version of skf_ref that wrote it
``info``           the ``mne.Info`` of the channels used, with the projectors the whitener
                   applies (MNE's own dict of it; ``mne.Info(**info)`` restores it)
``ch_names``       the channels used, in order
``dropped``        the channels left out, by reason
``whitener``       float64 (rank, n_channels): MNE's whitener of the noise covariance of
                   one trial
``gain``           float64 (n_channels, n_sources): the forward's lead field, unwhitened
``fixed``          whether the forward has fixed orientation
``forward_fif``    uint8: the forward restricted to the channels used, as MNE's
                   ``write_forward_solution`` writes it (its source space, transforms and
                   info; MNE stores the lead field in float32 there, so ``gain`` holds it)
``pm_snr_db``,     the priors: a number (dB), ``"auto"``, or a range ``[low, high]``
``ep_snr_db``
``sha256``         the digest of every other field as read back (:func:`content_digest`),
                   new in version 2
=================  ==================================================================

Format version 2 also holds an operator with the stationary AR(1) prior
(:func:`skf_ref.ar1_priors`): ``time_constant_ms`` (a number of ms, ``"auto"``, or a range
``[low, high]``) in place of ``ep_snr_db``.

Nothing is pickled. Reading checks the digest (a changed byte of an array, a name, a
prior is refused as a damaged file), then every field and that they agree with each other
(shapes, and the channels of ``ch_names``, ``info`` and the forward, in one order), and
recomputes what the operator derives (the whitened lead field and its SVD) from the
stored float64 arrays, so a read operator gives the estimates of the one written, bit for
bit. A file of a later format version than this skf_ref reads is refused, naming both
versions (upgrade skf_ref to read it); every earlier version stays readable: version 1
(skf_ref 0.3.0) is version 2 without ``sha256`` and without a time constant, and is read
with every check but the digest's, and a warning that a change to it cannot be detected.
"""

from __future__ import annotations

import datetime
import hashlib
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from .._utils.atomic_files import atomic_path
from .._utils.checks import InputError, InputTypeError, check_instance, describe
from .._utils.extras import optional
from .._version import __version__
from ..method._search import check_time_constant
from ._operator import SKFOperator, check_prior

__all__ = [
    "OPERATOR_FORMAT",
    "OPERATOR_FORMAT_VERSION",
    "content_digest",
    "read_skf_operator",
    "write_skf_operator",
]

#: What an operator file says it holds.
OPERATOR_FORMAT = "skf_ref.SKFOperator"
#: The format version this skf_ref writes (and the latest it reads): 2 adds ``sha256``, and
#: ``time_constant_ms`` in place of ``ep_snr_db`` for the AR(1) prior.
OPERATOR_FORMAT_VERSION = 2
_TITLE = "skf_ref"
#: The fields of every format version (version 2 adds ``sha256``).
_FIELDS = (
    *("format", "version", "skf_ref", "info", "ch_names", "dropped", "whitener", "gain"),
    *("fixed", "forward_fif", "pm_snr_db"),
)
#: The evolution prior: the random walk's EP-SNR or the AR(1) prior's time constant (one).
_EVOLUTION = ("ep_snr_db", "time_constant_ms")
_DIGEST = "sha256"
_DIGEST_SINCE = 2  # the first format version with a digest


def _feed(h: Any, value: Any) -> None:
    """Feed ``value`` to the hash ``h``, its kind and its structure included: a number by
    its value (an int, a float, a numpy scalar alike), so that the digest does not depend
    on which of them a reader returns."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, dict):
        h.update(b"{%d" % len(value))
        for key in sorted(value, key=str):
            _feed(h, str(key))
            _feed(h, value[key])
    elif isinstance(value, (list, tuple)):
        h.update(b"[%d" % len(value))
        for item in value:
            _feed(h, item)
    elif isinstance(value, np.ndarray):
        h.update(f"a{value.dtype.str}{value.shape}".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, str):
        text = value.encode("utf-8", "surrogatepass")
        h.update(b"s%d:" % len(text))
        h.update(text)
    elif isinstance(value, bytes):
        h.update(b"b%d:" % len(value))
        h.update(value)
    elif value is None or isinstance(value, bool):
        h.update(f"{value!r};".encode())
    elif isinstance(value, int):
        h.update(f"int:{value};".encode())
    elif isinstance(value, float):
        h.update(f"float:{value.hex()};".encode())
    elif isinstance(value, complex):
        h.update(f"complex:{value.real.hex()},{value.imag.hex()};".encode())
    elif isinstance(value, (datetime.date, datetime.time, datetime.timedelta)):
        h.update(f"{type(value).__name__}:{value!r};".encode())
    else:  # what h5io reads is one of the above; anything else by its type and text
        h.update(f"{type(value).__module__}.{type(value).__name__}:{value!r};".encode())


def content_digest(content: dict[str, Any]) -> str:
    """The sha256 of an operator file's fields (all but ``sha256``), as h5io reads them.

    Every array by its type, shape and bytes, every name and number by its kind and
    text, in an order that does not depend on the dict's.

    Parameters
    ----------
    content : dict
        What ``h5io.read_hdf5`` returns for the file's group.

    Returns
    -------
    str
        Hexadecimal.

    Examples
    --------
    >>> a = content_digest({"gain": np.eye(2), "ch_names": ["Fz", "Cz"]})
    >>> a == content_digest({"ch_names": ["Fz", "Cz"], "gain": np.eye(2)})
    True
    >>> a == content_digest({"gain": np.eye(2), "ch_names": ["Cz", "Fz"]})
    False
    """
    h = hashlib.sha256()
    _feed(h, {key: value for key, value in content.items() if key != _DIGEST})
    return h.hexdigest()


def _file_name(fname: Any) -> Path:
    if not isinstance(fname, (str, Path)):
        raise InputTypeError(f"fname must be a path (str or Path), got {describe(fname)}")
    path = Path(fname)
    if path.suffix != ".h5":
        raise InputError(
            f"fname must end in .h5 (an HDF5 file, e.g. 'sample-skf.h5'), got {str(path)!r}"
        )
    return path


def _forward_bytes(forward: Any) -> np.ndarray:
    """The forward as MNE's ``-fwd.fif`` file, in bytes."""
    mne = optional("mne", "mne", "write_skf_operator")
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        # MNE stores a fixed forward made from a free one as the free one: the reader
        # converts it again (fixed, surface oriented) and puts the gain in place
        warnings.filterwarnings("ignore", "This forward solution is based on", RuntimeWarning)
        path = Path(folder) / "operator-fwd.fif"
        mne.write_forward_solution(path, forward, verbose=False)
        return np.frombuffer(path.read_bytes(), dtype=np.uint8)


def _forward_from_bytes(data: np.ndarray, gain: np.ndarray, fixed: bool, path: Path) -> Any:
    """The forward of :func:`_forward_bytes`, oriented as the operator holds it, its lead
    field the float64 ``gain``."""
    mne = optional("mne", "mne", "read_skf_operator")
    with tempfile.TemporaryDirectory() as folder:
        fif = Path(folder) / "operator-fwd.fif"
        fif.write_bytes(np.asarray(data, dtype=np.uint8).tobytes())
        with warnings.catch_warnings():  # MNE's notes on bytes it cannot read: ours instead
            warnings.simplefilter("ignore", RuntimeWarning)
            forward = mne.read_forward_solution(fif, verbose=False)
    forward = mne.convert_forward_solution(
        forward, surf_ori=fixed, force_fixed=fixed, copy=False, verbose=False
    )
    if forward["sol"]["data"].shape != gain.shape:
        raise _damaged(
            path,
            f"its forward has a lead field of shape {forward['sol']['data'].shape}, its gain "
            f"{gain.shape}",
        )
    forward["sol"]["data"] = gain
    return forward


def write_skf_operator(fname: str | Path, operator: SKFOperator, overwrite: bool = False) -> Path:
    """Write a prepared SKF operator to an HDF5 file, as MNE's ``write_inverse_operator``.

    The format is documented, versioned and free of pickles (:mod:`skf_ref.io._operator_file`);
    :func:`read_skf_operator` reads it back, and the estimates of the operator read equal
    those of the one written, bit for bit.

    Parameters
    ----------
    fname : path-like
        Ends in ``.h5`` (e.g. ``"sample-skf.h5"``).
    operator : SKFOperator
    overwrite : bool
        Replace a file at ``fname``.

    Returns
    -------
    Path
        The file written.

    Examples
    --------
    >>> import mne, pathlib, tempfile
    >>> montage = mne.channels.make_standard_montage("biosemi16")
    >>> info = mne.create_info(montage.ch_names, 500.0, "eeg").set_montage(montage)
    >>> sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    >>> src = mne.setup_volume_source_space(sphere=sphere, pos=40.0, verbose=False)
    >>> forward = mne.make_forward_solution(info, None, src, sphere, verbose=False)
    >>> from skf_ref import make_skf_operator
    >>> operator = make_skf_operator(info, forward, noise_std=1e-6, verbose=False)
    >>> fname = pathlib.Path(tempfile.mkdtemp()) / "demo-skf.h5"
    >>> read = read_skf_operator(write_skf_operator(fname, operator))
    >>> read  # doctest: +ELLIPSIS
    <SKFOperator | 16 channels, rank 15, ... positions x 3, PM-SNR 0 dB, time constant auto>
    >>> bool(np.array_equal(read.leadfield, operator.leadfield))
    True
    """
    h5io = optional("h5io", "mne", "write_skf_operator")
    path = _file_name(fname)
    check_instance("operator", operator, SKFOperator, "an SKFOperator (make_skf_operator)")
    if not isinstance(overwrite, bool):
        raise InputTypeError(f"overwrite must be True or False, got {describe(overwrite)}")
    if not path.parent.is_dir():
        raise InputError(f"{path}: the folder {path.parent} does not exist")
    if path.is_dir() or (path.exists() and not overwrite):
        raise InputError(
            f"{path} exists: give overwrite=True to replace it"
            if not path.is_dir()
            else f"{path} is a folder: give a file name ending in .h5"
        )
    if operator.time_constant_ms is None:  # the paper's random walk
        held = {"ep_snr_db": operator.ep_snr_db}
    else:  # the stationary AR(1) prior
        held = {"time_constant_ms": operator.time_constant_ms}
    priors = {
        name: list(value) if isinstance(value, tuple) else value
        for name, value in {"pm_snr_db": operator.pm_snr_db, **held}.items()
    }
    content = {
        "format": OPERATOR_FORMAT,
        "version": OPERATOR_FORMAT_VERSION,
        "skf_ref": __version__,
        "info": operator.info,
        "ch_names": list(operator.ch_names),
        "dropped": {reason: list(names) for reason, names in operator.dropped.items()},
        "whitener": np.asarray(operator.whitener, dtype=np.float64),
        "gain": np.asarray(operator.forward["sol"]["data"], dtype=np.float64),
        "fixed": operator.n_components == 1,
        "forward_fif": _forward_bytes(operator.forward),
        **priors,
    }
    # without overwrite, a file that appeared since the check above (another process writing
    # the same name) is never replaced: the file is published only where nothing is
    with atomic_path(path, overwrite=overwrite) as tmp:
        # the digest of the fields as a reader gets them back (h5io's own types)
        h5io.write_hdf5(tmp, content, overwrite=True, title=_TITLE, slash="replace")
        read = h5io.read_hdf5(tmp, title=_TITLE, slash="replace")
        content[_DIGEST] = content_digest(read)
        h5io.write_hdf5(tmp, content, overwrite=True, title=_TITLE, slash="replace")
    return path


def read_skf_operator(fname: str | Path) -> SKFOperator:
    """Read an operator that :func:`write_skf_operator` wrote, as MNE's ``read_inverse_operator``.

    Parameters
    ----------
    fname : path-like
        An ``.h5`` file of format version ``OPERATOR_FORMAT_VERSION`` or earlier.

    Returns
    -------
    SKFOperator
        Its estimates equal those of the operator written, bit for bit.
    """
    h5io = optional("h5io", "mne", "read_skf_operator")
    optional("mne", "mne", "read_skf_operator")
    path = _file_name(fname)
    if not path.is_file():
        from ._variables import not_a_file

        raise InputError(f"{path}: {not_a_file(path)}")
    try:
        content = h5io.read_hdf5(path, title=_TITLE, slash="replace")
    except Exception as err:  # h5py's and h5io's own errors for a file that is no operator
        raise InputError(f"{path} is not an SKF operator file written by skf_ref: {err}") from err
    if not isinstance(content, dict) or content.get("format") != OPERATOR_FORMAT:
        raise InputError(f"{path} is not an SKF operator file written by skf_ref")
    version = content.get("version")
    if not isinstance(version, int) or version < 1:
        raise InputError(f"{path}: its operator format version {version!r} is not one")
    if version > OPERATOR_FORMAT_VERSION:
        raise InputError(
            f"{path} holds an operator of format version {version} (written by skf_ref "
            f"{content.get('skf_ref')}); this skf_ref ({__version__}) reads versions up to "
            f"{OPERATOR_FORMAT_VERSION}: upgrade skf_ref to read it"
        )
    _check_digest(path, content, version)
    return _operator(path, content)


def _check_digest(path: Path, content: dict[str, Any], version: int) -> None:
    """Refuse a file whose fields are not those its digest was made of."""
    if version < _DIGEST_SINCE:
        warnings.warn(
            f"{path}: operator format version {version}, written without a digest (skf_ref "
            "0.3.0): a change to its arrays cannot be detected; write the operator again "
            "(write_skf_operator) to add one",
            UserWarning,
            stacklevel=3,
        )
        return
    stored = content.get(_DIGEST)
    if not isinstance(stored, str):
        raise InputError(
            f"{path}: an operator file of format version {version} holds its sha256, and this "
            f"one has {'none' if stored is None else describe(stored)}: the file is damaged"
        )
    if content_digest(content) != stored:
        raise InputError(
            f"{path}: its contents are not those written (their sha256 differs from the one "
            "stored with them): the file was changed or damaged after it was written; write "
            "the operator again"
        )


def _damaged(path: Path, what: str) -> InputError:
    return InputError(f"{path}: {what}: the file is damaged (not as write_skf_operator writes it)")


def _names(path: Path, value: Any, field: str) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(name, str) for name in value):
        raise _damaged(path, f"{field} must be a list of channel names, got {describe(value)}")
    return value


def _matrix(path: Path, value: Any, field: str, shape: tuple[int | None, int]) -> np.ndarray:
    """``value``, a finite float64 matrix of ``shape`` (None: any positive count)."""
    if not isinstance(value, np.ndarray) or value.dtype != np.float64 or value.ndim != 2:
        raise _damaged(path, f"{field} must be a float64 matrix, got {describe(value)}")
    rows, columns = shape
    if (
        (rows is not None and value.shape[0] != rows)
        or value.shape[1] != columns
        or not len(value)
    ):
        expected = f"({'rank' if rows is None else rows}, {columns})"
        raise _damaged(path, f"{field} has shape {value.shape}, expected {expected}")
    if not np.all(np.isfinite(value)):
        raise _damaged(path, f"{field} is not finite")
    return value


def _operator(path: Path, content: dict[str, Any]) -> SKFOperator:
    """The operator of a file's fields, each checked, and checked against the others."""
    mne = optional("mne", "mne", "read_skf_operator")
    missing = [field for field in _FIELDS if field not in content]
    if missing:
        raise _damaged(path, f"it lacks {', '.join(missing)}")
    evolution = [field for field in _EVOLUTION if field in content]
    if len(evolution) != 1:
        raise _damaged(path, f"it must hold one of {' and '.join(_EVOLUTION)}, got {evolution}")
    ch_names = _names(path, content["ch_names"], "ch_names")
    if not ch_names or len(set(ch_names)) != len(ch_names):
        raise _damaged(path, f"ch_names must name each channel once, got {len(ch_names)} names")
    n = len(ch_names)
    whitener = _matrix(path, content["whitener"], "whitener", (None, n))
    if len(whitener) > n:
        raise _damaged(path, f"whitener has {len(whitener)} rows, more than its {n} channels")
    gain = content["gain"]
    n_sources = gain.shape[1] if isinstance(gain, np.ndarray) and gain.ndim == 2 else 0
    gain = _matrix(path, gain, "gain", (n, n_sources))
    fixed = content["fixed"]
    if not isinstance(fixed, (bool, int, np.bool_, np.integer)) or fixed not in (0, 1):
        raise _damaged(path, f"fixed must be True or False, got {describe(fixed)}")
    if not fixed and n_sources % 3:
        raise _damaged(
            path, f"gain has {n_sources} columns, not 3 per position (free orientation)"
        )
    dropped = content["dropped"]
    if not isinstance(dropped, dict) or not all(isinstance(k, str) for k in dropped):
        raise _damaged(path, f"dropped must map reasons to channel names, got {describe(dropped)}")
    dropped = {
        reason: _names(path, names, f"dropped[{reason!r}]") for reason, names in dropped.items()
    }
    fif = content["forward_fif"]
    if not isinstance(fif, np.ndarray) or fif.dtype != np.uint8 or fif.ndim != 1:
        raise _damaged(path, f"forward_fif must be the bytes of a -fwd.fif, got {describe(fif)}")
    if not isinstance(content["info"], dict):
        raise _damaged(
            path, f"info must be MNE's dict of an mne.Info, got {describe(content['info'])}"
        )
    try:
        info = mne.Info(**content["info"])
        info._check_consistency()
    except Exception as err:  # MNE's own errors for a dict that is no info
        raise _damaged(path, f"its info is not an mne.Info ({err})") from err
    if list(info["ch_names"]) != ch_names:
        raise _damaged(
            path,
            f"ch_names ({n}: {ch_names[:3]} ...) are not the channels of its info in order "
            f"({len(info['ch_names'])}: {list(info['ch_names'][:3])} ...)",
        )
    try:
        forward = _forward_from_bytes(fif, gain, bool(fixed), path)
    except InputError:
        raise
    except Exception as err:  # MNE's reader raises several types for bytes that are no forward
        raise _damaged(path, f"its forward_fif is not a forward MNE reads ({err})") from err
    if list(forward["sol"]["row_names"]) != ch_names:
        raise _damaged(path, "ch_names are not the channels of its forward, in order")
    try:
        pm = check_prior("pm_snr_db", content["pm_snr_db"])
        if evolution == ["time_constant_ms"]:  # the AR(1) prior
            ep, tau = None, check_time_constant(content["time_constant_ms"])
        else:
            ep, tau = check_prior("ep_snr_db", content["ep_snr_db"]), None
    except InputError as err:
        raise _damaged(path, str(err)) from None
    return SKFOperator(
        info=info,
        ch_names=ch_names,
        dropped=dropped,
        whitener=whitener,
        forward=forward,
        fixed=bool(fixed),
        pm=pm,
        ep=ep,
        time_constant=tau,
    )
