"""Lead fields, data and results in the formats people bring.

Readers return the arrays with what the format knows about them (channel names, source
positions, times) and, for MNE files, the MNE object; a file that cannot be used raises an
:class:`~skf_ref.InputError` naming the file and what is wrong; channel names are one per
row, none twice. Writers check their path first and go through a temporary file and a
rename, so a result is whole or absent.

=============  =========================================================================
format         read as
=============  =========================================================================
``.npy``       the array
``.npz``       the array under ``key`` (or the only one, or a conventional name);
               ``ch_names``, ``positions`` and ``times`` when present; nothing else is
               read (:mod:`skf_ref.io._variables`)
``.mat``       MATLAB v5 (``scipy.io.loadmat``) and v7.3 (HDF5, ``pymatreader``), the
               variable ``key`` (or the only one, or a conventional name); a matrix keeps
               both dimensions (32 x 1 stays 32 x 1)
``.csv``       data only: channels in rows, times in columns; optionally channel names
               (or row labels) in the first column and times in seconds in the first row
               (as ``DataFrame(Y, index=names, columns=times).to_csv()`` writes it), or
               numbers only (``np.savetxt``), cut by commas, semicolons, tabs or spaces;
               the layout is read off the content, on evidence, and what could be read
               two ways is refused saying how to tell (:mod:`skf_ref.io._tables`)
``-fwd.fif``   lead field: ``mne.read_forward_solution`` (free orientation in MNE's x, y,
               z head coordinates); channel names and source positions kept
``-ave.fif``   data: ``mne.read_evokeds`` (``condition``: name or index)
``-epo.fif``   data: ``mne.read_epochs``, averaged
other          data: anything ``mne.io.read_raw`` reads (EDF, BDF, BrainVision, EEGLAB,
               FIF raw), as one evoked-like segment, and the recording itself
               (``Recording.raw``, for :func:`skf_ref.apply_skf_raw`, which skips its
               bad segments)
=============  =========================================================================
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._utils.atomic_files import atomic_path, check_output_path, temporary_folder
from .._utils.checks import (
    InputError,
    InputTypeError,
    check_array,
    check_names,
    check_path,
    describe,
)
from .._utils.extras import optional
from ._tables import read_csv
from ._variables import Variables, existing_file, read_npy, read_variables, reading

__all__ = [
    "LeadField",
    "Recording",
    "read_data",
    "read_leadfield",
    "stc_files",
    "takes_option",
    "write_reconstruction",
    "write_stc",
]

_LEADFIELD_KEYS = ("L", "leadfield", "lead_field", "G", "gain")
_DATA_KEYS = ("Y", "data", "eeg")
_MNE_DATA = (".fif", ".edf", ".bdf", ".vhdr", ".set", ".gdf", ".cnt", ".gz")
#: The files that hold conditions (MNE's evoked files): ``condition`` chooses one.
_EVOKED_FILES = ("-ave.fif", "_ave.fif", "-ave.fif.gz")
_NAMED = (".npz", ".mat")  # the formats whose variables ``key`` names


def takes_option(path: str | os.PathLike, option: str) -> bool:
    """Whether the file ``path`` names is one that ``option`` of :func:`read_data` (or
    :func:`read_leadfield`) applies to: ``"key"`` (.npz, .mat), ``"condition"`` (an MNE
    ``-ave.fif``) or ``"sfreq"`` (.csv). An option given for another file is refused,
    never dropped.

    Examples
    --------
    >>> takes_option("Y.npz", "key"), takes_option("Y.npy", "key")
    (True, False)
    >>> takes_option("sample-ave.fif", "condition"), takes_option("s-epo.fif", "condition")
    (True, False)
    """
    path = Path(path)
    if option == "key":
        return path.suffix in _NAMED
    if option == "condition":
        return path.name.lower().endswith(_EVOKED_FILES)
    return path.suffix == ".csv"


def _refuse_options(path: Path, **given: Any) -> None:
    """Refuse an option ``path``'s format does not take (it would be dropped)."""
    what = {
        "key": "names a variable of .npz and .mat files",
        "condition": "chooses among the conditions of an MNE -ave.fif",
        "sfreq": "gives the sampling frequency of a .csv file, whose times are not in it",
    }
    for option, value in given.items():
        if value is not None and not takes_option(path, option):
            raise InputError(
                f"{option}={value!r} {what[option]}, and {path} is not one: give no {option} "
                "for it (it would be left unused)"
            )


@dataclass(frozen=True, eq=False)
class LeadField:
    """A lead field read from a file.

    Parameters
    ----------
    data : ndarray, shape (n_channels, n_sources)
    ch_names : list of str or None
    positions : ndarray, shape (n_positions, 3) or None
        Source positions in metres (head coordinates for MNE forwards).
    forward : mne.Forward or None
        The forward solution, when read from ``-fwd.fif``.
    """

    data: np.ndarray
    ch_names: list[str] | None = None
    positions: np.ndarray | None = None
    forward: Any = None


@dataclass(frozen=True, eq=False)
class Recording:
    """EEG data read from a file.

    Parameters
    ----------
    data : ndarray, shape (n_channels, n_times)
    ch_names : list of str or None
    times : ndarray, shape (n_times,) or None
        Seconds.
    evoked : mne.Evoked or None
        The data as an MNE evoked, when the file is one of MNE's formats.
    raw : mne.io.Raw or None
        The continuous recording, when the file is one (not an evoked or epochs): its bad
        segments (``BAD_`` annotations) are in it, not in ``data`` or ``evoked``; give it
        to :func:`skf_ref.apply_skf_raw`, which skips them.
    """

    data: np.ndarray
    ch_names: list[str] | None = None
    times: np.ndarray | None = None
    evoked: Any = None
    raw: Any = None


def _pick(variables: Variables, key: str | None, conventional: Sequence[str], path: Path) -> Any:
    """The array under ``key``, the only numeric array, or the first conventional name.

    Only the array picked is read (:func:`~skf_ref.io._variables.read_variables` is lazy).
    """
    if key is not None:
        if key not in variables:
            raise InputError(f"{path}: no variable {key!r}; it holds {sorted(variables)}")
        return variables[key]
    numeric = [name for name in variables if variables.kind(name) in "fiu"]
    if len(numeric) == 1:
        return variables[numeric[0]]
    for name in conventional:
        if name in variables:
            return variables[name]
    raise InputError(
        f"{path} holds {sorted(variables)}: say which is meant (key=..., or --key on the "
        f"command line); looked for {list(conventional)}"
    )


def _matrix(value: Any, path: Path) -> Any:
    """A MATLAB number where a matrix is wanted is the 1 x 1 matrix it was."""
    return np.reshape(value, (1, 1)) if path.suffix == ".mat" and np.ndim(value) == 0 else value


def _vector(value: Any) -> np.ndarray:
    """A MATLAB row or column (1 x n, n x 1) as the vector it is."""
    value = np.asarray(value)
    return value.ravel() if value.ndim == 2 and 1 in value.shape else value


def _names(variables: Mapping[str, Any], key: str, path: Path, n: int) -> list[str] | None:
    """The channel names stored under ``key``: one per row, none twice."""
    if key not in variables:
        return None
    names = check_names(f"{path}: {key}", np.atleast_1d(_vector(variables[key])))
    if len(names) != n:
        raise InputError(f"{path}: {len(names)} names in {key} for {n} rows")
    return names


def read_leadfield(path: str | os.PathLike, *, key: str | None = None) -> LeadField:
    """Read a lead field (n_channels, n_sources).

    Parameters
    ----------
    path : path-like
        ``.npy``, ``.npz``, ``.mat`` or MNE ``-fwd.fif`` (see the module docstring).
    key : str, optional
        The variable holding the lead field in ``.npz`` and ``.mat`` files (refused for
        another format, which has no variables).

    Returns
    -------
    LeadField

    Raises
    ------
    skf_ref.InputError
        The file is missing, not of its format, holds no lead field, names a channel
        twice, or holds pickled objects.
    """
    path = existing_file(path)
    _refuse_options(path, key=key)
    name = path.name.lower()
    if name.endswith(".fif") or name.endswith(".fif.gz"):
        return _forward(path)
    if path.suffix == ".npy":
        return LeadField(check_array(f"{path}", read_npy(path), ("n_channels", "n_sources")))
    if path.suffix not in (".npz", ".mat"):
        raise InputError(
            f"{path}: unknown lead-field format {path.suffix!r}; give .npy, .npz, .mat or an "
            "MNE -fwd.fif"
        )
    variables = read_variables(path)
    data = _matrix(_pick(variables, key, _LEADFIELD_KEYS, path), path)
    data = check_array(f"{path}", data, (None, None))
    positions = variables.get("positions")
    if positions is not None:
        positions = check_array(f"{path} positions", positions, ("n_positions", 3))
    return LeadField(data, _names(variables, "ch_names", path, data.shape[0]), positions)


def _forward(path: Path) -> LeadField:
    mne = optional("mne", "mne", "reading an MNE forward (-fwd.fif)")

    with reading(path, "an MNE forward solution"):
        forward = mne.read_forward_solution(path, verbose=False)
    if not mne.forward.is_fixed_orient(forward):
        forward = mne.convert_forward_solution(
            forward, surf_ori=False, force_fixed=False, verbose=False
        )
    positions = np.concatenate([s["rr"][s["vertno"]] for s in forward["src"]])
    return LeadField(
        np.asarray(forward["sol"]["data"], dtype=float),
        list(forward["sol"]["row_names"]),
        positions,
        forward,
    )


def read_data(
    path: str | os.PathLike,
    *,
    key: str | None = None,
    condition: str | int | None = None,
    sfreq: float | None = None,
) -> Recording:
    """Read EEG data (n_channels, n_times).

    Parameters
    ----------
    path : path-like
        ``.npy``, ``.npz``, ``.mat``, ``.csv``, MNE ``-ave.fif``/``-epo.fif``, or anything
        ``mne.io.read_raw`` reads (see the module docstring).
    key : str, optional
        The variable holding the data in ``.npz`` and ``.mat`` files.
    condition : str or int, optional
        The evoked of an ``-ave.fif`` file that holds several: its comment or its index.
        Each of ``key``, ``condition`` and ``sfreq`` is refused for a file it does not
        apply to (``takes_option``): it is never left unused silently.
    sfreq : float, optional
        ``.csv`` only: the sampling frequency (Hz). A first row that steps by ``1 / sfreq``
        is the times, any other first row is data (:mod:`skf_ref.io._tables`).

    Returns
    -------
    Recording

    Raises
    ------
    skf_ref.InputError
        The file is missing, not of its format, holds no data or a layout that cannot
        be told (CSV: the message says how to say it), names a channel twice, or holds
        pickled objects.
    """
    path = existing_file(path)
    _refuse_options(path, key=key, condition=condition, sfreq=sfreq)
    name = path.name.lower()
    if path.suffix == ".npy":
        return Recording(check_array(f"{path}", read_npy(path), ("n_channels", "n_times")))
    if path.suffix in (".npz", ".mat"):
        variables = read_variables(path)
        data = _matrix(_pick(variables, key, _DATA_KEYS, path), path)
        data = check_array(f"{path}", data, (None, None))
        times = variables.get("times")
        if times is not None:
            times = check_array(f"{path} times", _vector(times), (data.shape[1],))
        return Recording(data, _names(variables, "ch_names", path, data.shape[0]), times)
    if path.suffix == ".csv":
        data, names, times = read_csv(path, sfreq=sfreq)
        return Recording(data, names, times)
    if any(name.endswith(suffix) for suffix in _MNE_DATA):
        evoked, raw = _mne_evoked(path, name, condition)
        return Recording(evoked.data, list(evoked.ch_names), evoked.times.copy(), evoked, raw)
    raise InputError(
        f"{path}: unknown data format {path.suffix!r}; give .npy, .npz, .mat, .csv, an MNE "
        "-ave.fif or -epo.fif, or a recording MNE reads (EDF, BDF, BrainVision, EEGLAB)"
    )


def _mne_evoked(path: Path, name: str, condition: str | int | None) -> tuple[Any, Any]:
    """The file as an evoked, and the recording (None for an evoked or epochs file)."""
    mne = optional("mne", "mne", "reading an MNE evoked (-ave.fif)")

    if name.endswith(_EVOKED_FILES):
        with reading(path, "MNE evoked data"):
            evokeds = mne.read_evokeds(path, proj=False, verbose=False)
        return _condition(evokeds, condition, path), None
    if name.endswith(("-epo.fif", "_epo.fif", "-epo.fif.gz")):
        with reading(path, "MNE epochs"):
            return mne.read_epochs(path, proj=False, verbose=False).average(), None
    with reading(path, "a recording MNE reads"):
        raw = mne.io.read_raw(path, preload=True, verbose=False)
    evoked = mne.EvokedArray(
        raw.get_data(), raw.info, tmin=raw.times[0], nave=1, comment=path.name, verbose=False
    )
    return evoked, raw


def _condition(evokeds: list, condition: str | int | None, path: Path) -> Any:
    names = [evoked.comment for evoked in evokeds]
    if condition is None:
        if len(evokeds) > 1:
            raise InputError(f"{path} holds {len(evokeds)} conditions {names}: choose one")
        return evokeds[0]
    if isinstance(condition, str) and condition in names:
        return evokeds[names.index(condition)]
    if str(condition).isdigit() and int(condition) < len(evokeds):
        return evokeds[int(condition)]
    raise InputError(f"{path}: no condition {condition!r}; it holds {names}")


def write_reconstruction(
    path: str | os.PathLike,
    reconstruction: Any,
    *,
    times: ArrayLike | None = None,
    positions: ArrayLike | None = None,
    extra: Mapping[str, Any] | None = None,
    overwrite: bool = True,
) -> Path:
    """Write a reconstruction, its settings and the package versions to a ``.npz`` file.

    The file appears whole or not at all (written under a temporary name, then renamed);
    an existing file is replaced (through a symbolic link, the file it points to) unless
    ``overwrite=False``.

    Parameters
    ----------
    path : path-like
        Ends in ``.npz``.
    reconstruction : skf_ref.Reconstruction
    times : ndarray, shape (n_times,), optional
    positions : ndarray, shape (n_positions, 3), optional
        With them the file also holds ``amplitude`` (n_positions, n_times).
    extra : dict, optional
        More scalar settings to record (e.g. ``pm_snr_db``).
    overwrite : bool
        Replace a file at ``path``. False: a file there is refused before any work, and
        one that appears while this one is written is left as it is (an error).

    Returns
    -------
    Path

    Raises
    ------
    skf_ref.InputTypeError
        ``path`` is no file name, or ``reconstruction`` no Reconstruction (the arguments
        swapped?).
    skf_ref.InputError
        ``path`` does not end in ``.npz``, is a folder, or its folder does not exist.
    """
    from .._utils.provenance import package_versions
    from ..method import Reconstruction

    path = check_output_path(path, suffixes=(".npz",), overwrite=overwrite)
    if not isinstance(reconstruction, Reconstruction):
        raise InputTypeError(
            f"reconstruction must be an skf_ref.Reconstruction, got {describe(reconstruction)}"
        )
    arrays: dict[str, Any] = {
        name: getattr(reconstruction, name) for name in ("z", "x", "weights")
    }
    if times is not None:
        arrays["times"] = np.asarray(times, dtype=float)
    if positions is not None:
        positions = np.asarray(positions, dtype=float)
        arrays["positions"] = positions
        components = reconstruction.n_sources // max(len(positions), 1)
        if components in (1, 3) and components * len(positions) == reconstruction.n_sources:
            arrays["amplitude"] = reconstruction.amplitude(components)
    settings = {**reconstruction.settings, **(extra or {})}
    settings |= {f"{k}_version": v for k, v in package_versions().items()}
    scalars: dict[str, Any] = {
        k: np.asarray("none" if v is None else v) for k, v in settings.items()
    }
    scalars["log_likelihood"] = np.asarray(reconstruction.log_likelihood)
    with atomic_path(path, overwrite=overwrite) as tmp:
        np.savez_compressed(tmp, **arrays, **scalars)
    return path


#: MNE's source-estimate classes whose .stc writer exists (a single volume, or a surface).
_STC_WRITERS = ("SourceEstimate", "VolSourceEstimate")
_STC_CLASSES = (
    *_STC_WRITERS,
    "MixedSourceEstimate",
    "VectorSourceEstimate",
    "VolVectorSourceEstimate",
    "MixedVectorSourceEstimate",
)


def _stc_stem(path: Path) -> str:
    """``NAME`` of ``NAME.stc``, ``NAME-vl.stc``, ``NAME-stc.h5`` ... (MNE adds the tags)."""
    if path.suffix not in (".h5", ".stc"):
        raise InputError(f"a source estimate is written to .stc or .h5, got {str(path)!r}")
    stem = path.name[: -len(path.suffix)]
    for tag in ("-vl", "-lh", "-rh", "-stc"):
        stem = stem.removesuffix(tag)
    return stem


def stc_files(path: str | os.PathLike, class_name: str, n_volumes: int = 1) -> list[Path]:
    """The files :func:`write_stc` writes for ``path``, or why it cannot.

    Parameters
    ----------
    path : path-like
        ``.stc`` or ``.h5``.
    class_name : str
        The MNE source estimate's class (``"VolSourceEstimate"`` ...).
    n_volumes : int
        Volume source spaces of a ``VolSourceEstimate`` (MNE's ``.stc`` holds one).

    Returns
    -------
    list of Path
        ``NAME-stc.h5``; ``NAME-lh.stc`` and ``NAME-rh.stc``; or ``NAME-vl.stc``.

    Raises
    ------
    skf_ref.InputError
        ``path`` is neither, or the estimate cannot be written as ``.stc`` (a vector or
        mixed estimate, several volumes: MNE writes them to ``.h5`` only).
    """
    path = check_path("path", path)
    stem = _stc_stem(path)
    if path.suffix == ".h5":
        return [path.with_name(f"{stem}-stc.h5")]
    if class_name not in _STC_WRITERS or n_volumes > 1:
        what = "several volumes" if class_name in _STC_WRITERS else f"a {class_name}"
        raise InputError(
            f"{path}: MNE writes {what} to .h5 only (an .stc file holds one value per position "
            "of one source space): give a name ending in .h5"
        )
    tags = ("-lh", "-rh") if class_name == "SourceEstimate" else ("-vl",)
    return [path.with_name(f"{stem}{tag}.stc") for tag in tags]


def write_stc(path: str | os.PathLike, stc: Any, *, overwrite: bool = True) -> list[Path]:
    """Write an MNE source estimate with MNE's writer, every file whole or absent.

    Parameters
    ----------
    path : path-like
        ``.h5`` or ``.stc``, named as MNE names them: ``NAME-stc.h5``; ``NAME-lh.stc`` and
        ``NAME-rh.stc`` for a surface estimate, ``NAME-vl.stc`` for a volume one (a given
        ``NAME.stc`` or ``NAME.h5`` becomes these). A vector or mixed estimate is written
        to ``.h5`` only.
    stc : mne.SourceEstimate or mne.VolSourceEstimate or mne.MixedSourceEstimate or vector kin
    overwrite : bool
        Replace files at those names. False: an existing one is refused before any work,
        and one that appears while they are written is left as it is (an error).

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    skf_ref.InputTypeError
        ``path`` is no file name, or ``stc`` no MNE source estimate (the arguments
        swapped?).
    skf_ref.InputError
        The format cannot hold the estimate (a vector or mixed estimate, several volumes,
        to ``.stc``), or a file's folder is missing or the file a folder.
    """
    path = check_path("path", path)
    mne = optional("mne", "mne", "write_stc")
    if type(stc).__name__ not in _STC_CLASSES or not isinstance(
        stc, getattr(mne, type(stc).__name__)
    ):
        raise InputTypeError(f"stc must be an MNE source estimate, got {describe(stc)}")
    volumes = len(stc.vertices) if type(stc).__name__ == "VolSourceEstimate" else 1
    finals = [
        check_output_path(f, overwrite=overwrite)
        for f in stc_files(path, type(stc).__name__, volumes)
    ]
    with temporary_folder(finals[0]) as tmp:
        try:
            stc.save(tmp / _stc_stem(path), path.suffix[1:], overwrite=True, verbose=False)
        except (ValueError, RuntimeError, OSError) as err:  # MNE's writers' own errors
            raise InputError(f"{path}: MNE cannot write this source estimate: {err}") from err
        for final in finals:
            with atomic_path(final, overwrite=overwrite) as target:
                os.replace(tmp / final.name, target)
    return finals
