"""Prepared SKF operators on disk, as MNE's ``write_inverse_operator`` / ``read_inverse_operator``.

The file is HDF5 (written by h5io, as MNE writes its objects that FIF does not hold), one
group ``skf_ref`` with, in format version 1:

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
=================  ==================================================================

Nothing is pickled. Reading recomputes what the operator derives (the whitened lead field
and its SVD) from the stored float64 arrays, so a read operator gives the estimates of the
one written, bit for bit. A file of a later format version than this skf_ref reads is
refused, naming both versions (upgrade skf_ref to read it); every earlier version stays
readable.
"""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from .._utils.atomic_files import atomic_path
from .._utils.checks import InputError, InputTypeError, check_instance, describe
from .._utils.extras import optional
from ..version import __version__
from .operator import SKFOperator, check_prior

__all__ = ["OPERATOR_FORMAT", "OPERATOR_FORMAT_VERSION", "read_skf_operator", "write_skf_operator"]

#: What an operator file says it holds.
OPERATOR_FORMAT = "skf_ref.SKFOperator"
#: The format version this skf_ref writes (and the latest it reads).
OPERATOR_FORMAT_VERSION = 1
_TITLE = "skf_ref"


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


def _forward_from_bytes(data: np.ndarray, gain: np.ndarray, fixed: bool) -> Any:
    """The forward of :func:`_forward_bytes`, oriented as the operator holds it, its lead
    field the float64 ``gain``."""
    mne = optional("mne", "mne", "read_skf_operator")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "operator-fwd.fif"
        path.write_bytes(np.asarray(data, dtype=np.uint8).tobytes())
        forward = mne.read_forward_solution(path, verbose=False)
    forward = mne.convert_forward_solution(
        forward, surf_ori=fixed, force_fixed=fixed, copy=False, verbose=False
    )
    if forward["sol"]["data"].shape != gain.shape:
        raise InputError(
            f"the operator file's forward has a lead field of shape {forward['sol']['data'].shape}"
            f", its gain {gain.shape}: the file is damaged"
        )
    forward["sol"]["data"] = gain
    return forward


def write_skf_operator(fname: str | Path, operator: SKFOperator, overwrite: bool = False) -> Path:
    """Write a prepared SKF operator to an HDF5 file, as MNE's ``write_inverse_operator``.

    The format is documented, versioned and free of pickles (:mod:`skf_ref.io.operator_file`);
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
    <SKFOperator | 16 channels, rank 15, ... positions x 3, PM-SNR and EP-SNR 0 dB, 0 dB>
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
    priors = {
        name: list(value) if isinstance(value, tuple) else value
        for name, value in (("pm_snr_db", operator.pm_snr_db), ("ep_snr_db", operator.ep_snr_db))
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
    mne = optional("mne", "mne", "read_skf_operator")
    path = _file_name(fname)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    try:
        content = h5io.read_hdf5(path, title=_TITLE, slash="replace")
    except (OSError, ValueError, KeyError) as err:
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
    gain = np.asarray(content["gain"], dtype=np.float64)
    fixed = bool(content["fixed"])
    return SKFOperator(
        info=mne.Info(**content["info"]),
        ch_names=[str(name) for name in content["ch_names"]],
        dropped={str(k): [str(n) for n in v] for k, v in content["dropped"].items()},
        whitener=np.asarray(content["whitener"], dtype=np.float64),
        forward=_forward_from_bytes(content["forward_fif"], gain, fixed),
        fixed=fixed,
        pm=check_prior("pm_snr_db", content["pm_snr_db"]),
        ep=check_prior("ep_snr_db", content["ep_snr_db"]),
    )
