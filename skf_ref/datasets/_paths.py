"""Where the real recordings are: a folder, an environment variable, or a download.

The feCNN recordings (:func:`skf_ref.datasets.load_fecnn_evoked`) are files of a public repository
(GitHub ``thanosDelatolas/feCNN``, MIT licence) kept, at the repository's own paths, in a
folder ``fecnn/`` of a data folder. :func:`data_path` finds that data folder, in this order:

1. the folder given (``path=``);
2. the folder named by the environment variable ``SKF_REF_DATA`` (:data:`DATA_ENV`);
3. a folder ``shared/real-data`` beside the source checkout of skf_ref (or beside the
   folder that holds the checkout), where the tests and the documentation build read it;
4. skf_ref's download cache (``pooch.os_cache("skf_ref")``), when a download filled it;
5. with ``download=True`` only: a download, with ``pooch``, of every file from the source
   repository at the pinned commit :data:`FECNN_COMMIT`, each checked against its pinned
   sha256 (:data:`FECNN_FILES`), into that cache.

Nothing is downloaded unless asked for (as ``mne.datasets.sample.data_path(download=...)``);
a folder given or named must hold the files, and is never replaced by another. The
256-channel recording (:func:`skf_ref.datasets.load_sep256_evoked`) needs no folder: it is
part of the package ``spharapy``.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from .._utils.checks import InputError, InputTypeError, describe
from .._utils.extras import optional

__all__ = [
    "DATA_ENV",
    "FECNN_COMMIT",
    "FECNN_FILES",
    "FECNN_URL",
    "data_path",
    "fecnn_file",
]

#: Environment variable naming the data folder (the one holding ``fecnn/``).
DATA_ENV = "SKF_REF_DATA"
#: The commit of ``thanosDelatolas/feCNN`` the files are pinned at.
FECNN_COMMIT = "3a78825f549ac88cad3e5f64cf58b52eace5379f"
#: Where each file is downloaded from: the repository's raw files at that commit.
FECNN_URL = f"https://raw.githubusercontent.com/thanosDelatolas/feCNN/{FECNN_COMMIT}/"
#: The files used, at the repository's paths (also their paths under ``fecnn/``), and the
#: sha256 of each at the pinned commit.
FECNN_FILES = {
    "LICENSE": "f8c22e69fac4b0ed8da75efcb1b94eb600a946576c8efc037626eafa665740cb",
    "real_data/A0206/EEG_avg.mat": (
        "d20b83bae9c7a9fff593e634cf6c2063693d8e63504d33760a6bd33e5e7cd35a"
    ),
    "real_data/A1974/EEG_avg.mat": (
        "858510cc72559846019b9a3a0529ef9e671414bf493090f2253466fe19226a73"
    ),
    "real_data/A1999/EEG_avg.mat": (
        "623c595f4f0c2189384614a9eaf48822a0a8527defcaeb3bf61352b4f9c8f4d4"
    ),
    "duneuropy/DataOut/leadfield_downsampled_5k.npy": (
        "1d236f35792880f45d98a5b32a79e3ebf14550d8d7a4255b78397df7f94db48c"
    ),
    "duneuropy/Data/dipoles_downsampled_5k.mat": (
        "804908b706cf5238aeb9f3f2759946a0d4229d69a7d6de139029bec67c2ceace"
    ),
    "duneuropy/Data/electrodes.elc": (
        "1564be288adec151789922e1ff6579fbb21c1e6fb0189113381012e5a96bab1c"
    ),
    "matlab/real_data_preproc.m": (
        "0498fff8f388e7beacf4a7bfc5fe28fa9ebf2cf83184994a759799bc27f0e005"
    ),
}
_SUBFOLDER = "fecnn"


def _complete(folder: Path) -> bool:
    return all((folder / _SUBFOLDER / name).is_file() for name in FECNN_FILES)


def _checkout_folders() -> list[Path]:
    """``shared/real-data`` beside the source checkout, or beside the folder holding it."""
    checkout = Path(__file__).resolve().parents[2]
    if not ((checkout / "setup.cfg").is_file() and (checkout / "skf_ref").is_dir()):
        return []  # an installed package: no checkout to look beside
    return [parent / "shared" / "real-data" for parent in checkout.parents[:2]]


def _cache_folder() -> Path:
    pooch = optional("pooch", "datasets", "the download of the real recordings")
    return Path(pooch.os_cache("skf_ref")) / "real-data"


def _named(path: str | os.PathLike, name: str) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise InputTypeError(f"{name} must be a folder path, got {describe(path)}")
    folder = Path(path).expanduser()
    missing = [n for n in FECNN_FILES if not (folder / _SUBFOLDER / n).is_file()]
    if missing:
        # a folder named is used as it is, never filled by a download: the way to skf_ref's
        # own copy is to name none (download=True alone would find this folder again)
        instead = "give no path" if name == "path" else f"unset ${DATA_ENV}"
        raise InputError(
            f"{name} must be a folder holding fecnn/ with the feCNN files at the repository's "
            f"paths, got {str(path)!r}, which lacks fecnn/{missing[0]}: put the files there "
            f"(the {len(FECNN_FILES)} of FECNN_FILES, from feCNN at commit "
            f"{FECNN_COMMIT[:7]}), or {instead} and call "
            "skf_ref.datasets.data_path(download=True) to download them to skf_ref's cache "
            "(a folder named is never filled by a download)"
        )
    return folder.resolve()


def _download(folder: Path) -> Path:
    """Every pinned file from the source repository into ``folder/fecnn`` (checked)."""
    pooch = optional("pooch", "datasets", "the download of the real recordings")
    fetcher = pooch.create(
        path=folder / _SUBFOLDER,
        base_url=FECNN_URL,
        registry={name: f"sha256:{digest}" for name, digest in FECNN_FILES.items()},
    )
    for name in FECNN_FILES:
        fetcher.fetch(name)
    return folder


def data_path(path: str | os.PathLike | None = None, *, download: bool = False) -> Path:
    """The folder of the real recordings: the one holding ``fecnn/``.

    Found as the module docstring lists: the folder given, ``$SKF_REF_DATA``, a
    ``shared/real-data`` folder beside the source checkout, the download cache, or (with
    ``download=True`` only) a download from the source repository at the pinned commit,
    every file checked against its sha256.

    Parameters
    ----------
    path : path-like, optional
        A folder holding ``fecnn/`` with the repository's files at its paths.
    download : bool
        Download the files (about 4 MB) when no folder holds them. Default False: nothing
        is downloaded unless asked for.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    FileNotFoundError
        No folder holds the files and ``download`` is False; the message says how to get
        them.
    skf_ref.InputError
        ``path`` or ``$SKF_REF_DATA`` names a folder that lacks a file.
    """
    if path is not None:
        return _named(path, "path")
    if os.environ.get(DATA_ENV):
        return _named(os.environ[DATA_ENV], f"${DATA_ENV}")
    for folder in _checkout_folders():
        if _complete(folder):
            return folder.resolve()
    if download or _has_pooch():
        cache = _cache_folder()
        if _complete(cache):
            return cache
        if download:
            return _download(cache)
    raise FileNotFoundError(
        "the real recordings (feCNN) were not found: give their folder (path=...), name it "
        f"in ${DATA_ENV}, or download them once with "
        "skf_ref.datasets.data_path(download=True) (about 4 MB, needs pooch)"
    )


def _has_pooch() -> bool:
    import importlib.util

    return importlib.util.find_spec("pooch") is not None


def fecnn_file(name: str, path: str | os.PathLike | None = None) -> Path:
    """One feCNN file, found by :func:`data_path` and checked against its pinned sha256.

    Parameters
    ----------
    name : str
        Its path in the repository, a key of :data:`FECNN_FILES`.
    path : path-like, optional
        The data folder (see :func:`data_path`).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    skf_ref.InputError
        The file's sha256 is not the pinned one: not the file this loader reads.
    """
    if name not in FECNN_FILES:
        raise InputError(f"name must be one of {sorted(FECNN_FILES)}, got {describe(name)}")
    file = data_path(path) / _SUBFOLDER / name
    digest = hashlib.sha256(file.read_bytes()).hexdigest()
    if digest != FECNN_FILES[name]:
        raise InputError(
            f"{file} has sha256 {digest}, expected {FECNN_FILES[name]} (the file of feCNN at "
            f"commit {FECNN_COMMIT[:7]}): a different or damaged file"
        )
    return file
