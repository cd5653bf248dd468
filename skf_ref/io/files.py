"""Lead fields, data and results in the formats people bring.

Readers return the arrays with what the format knows about them (channel names, source
positions, times) and, for MNE files, the MNE object; a file that cannot be used raises an
:class:`~skf_ref.InputError` naming the file and what is wrong. Writers go through a
temporary file and a rename, so a result is whole or absent.

=============  =========================================================================
format         read as
=============  =========================================================================
``.npy``       the array
``.npz``       the array under ``key`` (or the only one, or a conventional name);
               ``ch_names``, ``positions`` and ``times`` when present
``.mat``       MATLAB v5 (``scipy.io.loadmat``) and v7.3 (HDF5, ``pymatreader``), the
               variable ``key`` (or the only one, or a conventional name)
``.csv``       data only: channels in rows, times in columns; optionally channel names
               in the first column and times in seconds in the first row (as
               ``DataFrame(Y, index=names, columns=times).to_csv()`` writes it), or
               numbers only (``np.savetxt``); the layout is read off the content and a
               file that fits none is refused (:mod:`skf_ref.io.tables`)
``-fwd.fif``   lead field: ``mne.read_forward_solution`` (free orientation in MNE's x, y,
               z head coordinates); channel names and source positions kept
``-ave.fif``   data: ``mne.read_evokeds`` (``condition``: name or index)
``-epo.fif``   data: ``mne.read_epochs``, averaged
other          data: anything ``mne.io.read_raw`` reads (EDF, BDF, BrainVision, EEGLAB,
               FIF raw), as one evoked-like segment
=============  =========================================================================
"""

import contextlib
import os
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._utils.atomic_files import atomic_path
from .._utils.checks import InputError, check_array
from .._utils.extras import optional
from .tables import read_csv

__all__ = [
    "LeadField",
    "Recording",
    "read_data",
    "read_leadfield",
    "read_variables",
    "write_reconstruction",
    "write_stc",
]

_LEADFIELD_KEYS = ("L", "leadfield", "lead_field", "G", "gain")
_DATA_KEYS = ("Y", "data", "eeg")
_MNE_DATA = (".fif", ".edf", ".bdf", ".vhdr", ".set", ".gdf", ".cnt", ".gz")


@dataclass(frozen=True, eq=False)
class LeadField:
    """A lead field read from a file.

    Attributes
    ----------
    data : ndarray, shape (n_channels, n_sources)
    ch_names : list of str or None
    positions : ndarray, shape (n_positions, 3) or None
        Source positions in metres (head coordinates for MNE forwards).
    forward : mne.Forward or None
        The forward solution, when read from ``-fwd.fif``.
    """

    data: np.ndarray
    ch_names: list | None = None
    positions: np.ndarray | None = None
    forward: object = None


@dataclass(frozen=True, eq=False)
class Recording:
    """EEG data read from a file.

    Attributes
    ----------
    data : ndarray, shape (n_channels, n_times)
    ch_names : list of str or None
    times : ndarray, shape (n_times,) or None
        Seconds.
    evoked : mne.Evoked or None
        The data as an MNE evoked, when the file is one of MNE's formats.
    """

    data: np.ndarray
    ch_names: list | None = None
    times: np.ndarray | None = None
    evoked: object = None


def _existing(path):
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    return path


@contextlib.contextmanager
def _reading(path, what):
    """Turn a reader's own exceptions into one InputError naming the file.

    MNE's advice on file names (``-ave.fif`` and the like) is not shown: the readers here
    take any name and say what they read the file as.
    """
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "This filename .* does not conform to MNE")
            yield
    except InputError:
        raise
    except Exception as err:  # each reader (numpy, scipy, h5py, pandas, MNE) has its own
        raise InputError(f"{path}: cannot be read as {what}: {err}") from err


def _pick(variables, key, conventional, path):
    """The array under ``key``, the only array, or the first conventional name."""
    arrays = {k: v for k, v in variables.items() if not k.startswith("__")}
    if key is not None:
        if key not in arrays:
            raise InputError(f"{path}: no variable {key!r}; it holds {sorted(arrays)}")
        return arrays[key]
    numeric = [k for k, v in arrays.items() if np.asarray(v).dtype.kind in "fiu"]
    if len(numeric) == 1:
        return arrays[numeric[0]]
    for name in conventional:
        if name in arrays:
            return arrays[name]
    raise InputError(
        f"{path} holds {sorted(arrays)}: say which is meant (key=..., or --key on the command "
        f"line); looked for {list(conventional)}"
    )


def read_variables(path):
    """Every variable of a ``.npz`` or ``.mat`` (v5 or v7.3) file, by name.

    MATLAB's 1 x 1 and 1 x n arrays come back squeezed (a number, a vector), text as
    ``str``; NumPy's arrays as they were saved.

    Parameters
    ----------
    path : path-like
        Ends in ``.npz`` or ``.mat``.

    Returns
    -------
    dict
        ``{name: value}``; MATLAB's own header entries (``__header__`` ...) included.
    """
    path = _existing(path)
    if path.suffix not in (".npz", ".mat"):
        raise InputError(f"{path}: expected a .npz or .mat file, got {path.suffix!r}")
    if path.suffix == ".npz":
        with _reading(path, "a NumPy .npz archive"), np.load(path, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}
    from scipy.io import loadmat

    try:
        with _reading(path, "a MATLAB v5 file"):
            return loadmat(path, squeeze_me=True)
    except InputError as err:
        if "v7.3" not in str(err) and "HDF" not in str(err):
            raise
    from pymatreader import read_mat

    with _reading(path, "a MATLAB v7.3 (HDF5) file"):
        return read_mat(str(path))


def _names(variables, key):
    value = variables.get(key)
    return None if value is None else [str(name) for name in np.atleast_1d(value)]


def read_leadfield(path, *, key=None):
    """Read a lead field (n_channels, n_sources).

    Parameters
    ----------
    path : path-like
        ``.npy``, ``.npz``, ``.mat`` or MNE ``-fwd.fif`` (see the module docstring).
    key : str, optional
        The variable holding the lead field in ``.npz`` and ``.mat`` files.

    Returns
    -------
    LeadField
    """
    path = _existing(path)
    name = path.name.lower()
    if name.endswith(".fif") or name.endswith(".fif.gz"):
        return _forward(path)
    if path.suffix == ".npy":
        with _reading(path, "a NumPy array"):
            data = np.load(path, allow_pickle=False)
        return LeadField(check_array(f"{path}", data, ("n_channels", "n_sources")))
    if path.suffix not in (".npz", ".mat"):
        raise InputError(
            f"{path}: unknown lead-field format {path.suffix!r}; give .npy, .npz, .mat or an "
            "MNE -fwd.fif"
        )
    variables = read_variables(path)
    data = check_array(f"{path}", _pick(variables, key, _LEADFIELD_KEYS, path), (None, None))
    positions = variables.get("positions")
    if positions is not None:
        positions = check_array(f"{path} positions", positions, ("n_positions", 3))
    return LeadField(data, _names(variables, "ch_names"), positions)


def _forward(path):
    mne = optional("mne", "mne", "reading an MNE forward (-fwd.fif)")

    with _reading(path, "an MNE forward solution"):
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


def read_data(path, *, key=None, condition=None):
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

    Returns
    -------
    Recording
    """
    path = _existing(path)
    name = path.name.lower()
    if path.suffix == ".npy":
        with _reading(path, "a NumPy array"):
            data = np.load(path, allow_pickle=False)
        return Recording(check_array(f"{path}", data, ("n_channels", "n_times")))
    if path.suffix in (".npz", ".mat"):
        variables = read_variables(path)
        data = check_array(f"{path}", _pick(variables, key, _DATA_KEYS, path), (None, None))
        times = variables.get("times")
        return Recording(
            data,
            _names(variables, "ch_names"),
            None if times is None else check_array(f"{path} times", times, (data.shape[1],)),
        )
    if path.suffix == ".csv":
        data, names, times = read_csv(path)
        return Recording(data, names, times)
    if any(name.endswith(suffix) for suffix in _MNE_DATA):
        evoked = _mne_evoked(path, name, condition)
        return Recording(evoked.data, list(evoked.ch_names), evoked.times.copy(), evoked)
    raise InputError(
        f"{path}: unknown data format {path.suffix!r}; give .npy, .npz, .mat, .csv, an MNE "
        "-ave.fif or -epo.fif, or a recording MNE reads (EDF, BDF, BrainVision, EEGLAB)"
    )


def _mne_evoked(path, name, condition):
    mne = optional("mne", "mne", "reading an MNE evoked (-ave.fif)")

    if name.endswith(("-ave.fif", "_ave.fif", "-ave.fif.gz")):
        with _reading(path, "MNE evoked data"):
            evokeds = mne.read_evokeds(path, proj=False, verbose=False)
        return _condition(evokeds, condition, path)
    if name.endswith(("-epo.fif", "_epo.fif", "-epo.fif.gz")):
        with _reading(path, "MNE epochs"):
            return mne.read_epochs(path, proj=False, verbose=False).average()
    with _reading(path, "a recording MNE reads"):
        raw = mne.io.read_raw(path, preload=True, verbose=False)
    return mne.EvokedArray(
        raw.get_data(), raw.info, tmin=raw.times[0], nave=1, comment=path.name, verbose=False
    )


def _condition(evokeds, condition, path):
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


def write_reconstruction(path, reconstruction, *, times=None, positions=None, extra=None):
    """Write a reconstruction, its settings and the package versions to a ``.npz`` file.

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

    Returns
    -------
    Path
    """
    from .._utils.provenance import package_versions

    path = Path(path)
    if path.suffix != ".npz":
        raise InputError(f"a reconstruction is written to .npz, got {str(path)!r}")
    arrays = {name: getattr(reconstruction, name) for name in ("z", "x", "weights")}
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
    scalars = {k: np.asarray("none" if v is None else v) for k, v in settings.items()}
    scalars["log_likelihood"] = np.asarray(reconstruction.log_likelihood)
    with atomic_path(path) as tmp:
        np.savez_compressed(tmp, **arrays, **scalars)
    return path


def write_stc(path, stc):
    """Write an MNE source estimate with MNE's writer, every file whole or absent.

    Parameters
    ----------
    path : path-like
        ``.h5`` or ``.stc``, named as MNE names them: ``NAME-stc.h5``; ``NAME-lh.stc`` and
        ``NAME-rh.stc`` for a surface estimate, ``NAME-vl.stc`` for a volume one (a given
        ``NAME.stc`` or ``NAME.h5`` becomes these).

    Returns
    -------
    list of Path
        The files written.
    """
    path = Path(path)
    ftype = {".h5": "h5", ".stc": "stc"}.get(path.suffix)
    if ftype is None:
        raise InputError(f"a source estimate is written to .stc or .h5, got {str(path)!r}")
    stem = path.name[: -len(path.suffix)]
    for tag in ("-vl", "-lh", "-rh", "-stc"):
        stem = stem.removesuffix(tag)
    written = []
    with tempfile.TemporaryDirectory(dir=path.parent, prefix=".skf-stc-") as tmp:
        with _reading(path, "an MNE source estimate (writing)"):
            stc.save(Path(tmp) / stem, ftype=ftype, overwrite=True, verbose=False)
        for produced in sorted(Path(tmp).iterdir()):
            final = path.parent / produced.name
            os.replace(produced, final)
            written.append(final)
    return written
