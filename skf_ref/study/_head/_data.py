"""Where the realistic head's inputs come from: MNE's testing dataset, and the disk cache.

The realistic head is MNE's "sample" subject from MNE's testing dataset. It is never
downloaded: :func:`find_testing_data` takes a folder given by the user (the dataset's root,
the folder that ``mne.datasets.testing.data_path()`` returns) or asks MNE's own lookup with
``download=False``, and checks that the files the head needs are there.

The forward computations are cached on disk (:func:`cache_dir`), keyed by a digest of every
input (:func:`input_digest`): the dataset files' contents, the parameters and the MNE version.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..._utils.checks import InputError, InputTypeError, describe

__all__ = [
    "CACHE_ENV",
    "SUBJECT",
    "SENSOR_FILES",
    "TESTING_FILES",
    "cache_dir",
    "find_testing_data",
    "input_digest",
]

SUBJECT = "sample"
#: Files of MNE's testing dataset the realistic head reads, relative to its root.
TESTING_FILES = {
    "bem": "subjects/sample/bem/sample-1280-1280-1280-bem.fif",
    "aseg": "subjects/sample/mri/aseg.mgz",
    "t1": "subjects/sample/mri/T1.mgz",
    "talairach": "subjects/sample/mri/transforms/talairach.xfm",
    "trans": "MEG/sample/sample_audvis_trunc-trans.fif",
}
#: Files of the same dataset that the subject's own electrodes and noise need (montage
#: ``"sample"``, ``SUBJECT_MONTAGE``): one second of the subject's recording
#: (its info holds the 60 EEG electrodes digitized on the subject's head) and the noise
#: covariance estimated from it.
SENSOR_FILES = {
    "raw": "SSS/sample_audvis_trunc_raw_sss.fif",
    "cov": "MEG/sample/sample_audvis_trunc-cov.fif",
}
#: Environment variable naming the cache folder (overrides the platform default).
CACHE_ENV = "SKF_REF_CACHE_DIR"


def find_testing_data(path: str | os.PathLike | None = None) -> Path | None:
    """The root of MNE's testing dataset, or None where it is not present.

    Parameters
    ----------
    path : path-like or None
        The dataset's root folder (where ``MEG/`` and ``subjects/`` are). None: ask MNE
        (``mne.datasets.testing.data_path(download=False)``), which never downloads.

    Returns
    -------
    pathlib.Path or None
        None only when ``path`` is None and MNE finds no dataset.

    Raises
    ------
    skf_ref.InputError
        ``path`` was given but lacks a file the realistic head needs.
    """
    if path is None:
        found = _mne_lookup()
        return found if found is not None and _missing(found) == [] else None
    if not isinstance(path, (str, os.PathLike)):
        raise InputTypeError(f"testing_data must be a folder path, got {describe(path)}")
    root = Path(path).expanduser()
    missing = _missing(root)
    if missing:
        raise InputError(
            f"testing_data must be MNE's testing dataset folder (the one "
            f"mne.datasets.testing.data_path() returns), got {str(path)!r}, which lacks "
            f"{missing[0]}"
        )
    return root.resolve()


def _missing(root: Path) -> list[str]:
    return [name for name in TESTING_FILES.values() if not (root / name).is_file()]


def _mne_lookup() -> Path | None:
    import mne

    try:
        found = mne.datasets.testing.data_path(download=False, update_path=False, verbose=False)
    except Exception:  # noqa: BLE001  (any failure of the lookup means: not here)
        return None
    found = Path(found) if found else None
    if found is None or str(found) in ("", "."):
        return None
    return found


def cache_dir(path: str | os.PathLike | None = None) -> Path:
    """The folder the realistic head's forward models are cached in.

    Parameters
    ----------
    path : path-like or None
        A folder; None: ``$SKF_REF_CACHE_DIR`` if set, else the user's cache folder
        (``$XDG_CACHE_HOME/skf_ref`` or ``~/.cache/skf_ref`` on Linux,
        ``~/Library/Caches/skf_ref`` on macOS, ``%LOCALAPPDATA%\\skf_ref\\Cache`` on Windows).

    Returns
    -------
    pathlib.Path
        The folder (not created here).

    Examples
    --------
    >>> str(cache_dir("/tmp/x"))
    '/tmp/x'
    """
    if path is not None:
        if not isinstance(path, (str, os.PathLike)):
            raise InputTypeError(f"cache_dir must be a folder path, got {describe(path)}")
        return Path(path).expanduser()
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV]).expanduser()
    home = Path.home()
    if sys.platform == "darwin":
        return home / "Library" / "Caches" / "skf_ref"
    if sys.platform.startswith("win"):
        base = os.environ.get("LOCALAPPDATA") or str(home / "AppData" / "Local")
        return Path(base) / "skf_ref" / "Cache"
    base = os.environ.get("XDG_CACHE_HOME") or str(home / ".cache")
    return Path(base) / "skf_ref"


def input_digest(files: Mapping[str, str | os.PathLike], parameters: Any) -> str:
    """SHA-256 (hex, 20 characters) of files' contents and JSON-ready parameters.

    Parameters
    ----------
    files : dict
        Name -> path of every input file.
    parameters : dict
        Everything else the result depends on (JSON-serializable).

    Returns
    -------
    str
        20 hexadecimal digits.

    Examples
    --------
    >>> input_digest({}, {"a": 1}) == input_digest({}, {"a": 1}) != input_digest({}, {"a": 2})
    True
    """
    digest = hashlib.sha256(json.dumps(parameters, sort_keys=True).encode())
    for name in sorted(files):
        digest.update(name.encode() + b"\0")
        with open(files[name], "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                digest.update(block)
    return digest.hexdigest()[:20]
