"""Variables of NumPy (``.npy``, ``.npz``) and MATLAB (``.mat`` v5 and v7.3) files.

Read as the files hold them, and only what is asked for: :func:`read_variables` lists a
file's variables from its directory (the ``.npz`` archive's members, the ``.mat`` file's
variable headers) and reads each one when it is first used, so an unused 200 MB array of an
outputs file is never decompressed. Pickled Python objects are never loaded: a file that
holds them, or that is not the format its name says, is refused with an
:class:`~skf_ref.InputError` that says so.

MATLAB has no 0-D or 1-D arrays: a 1 x 1 array comes back as a number, text as ``str``,
cell arrays of text as arrays of ``str``; a numeric matrix keeps both its dimensions, so a
32 x 1 lead field (one source) or data matrix (one sample) stays (32, 1).
"""

from __future__ import annotations

import contextlib
import warnings
import zipfile
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._utils.checks import InputError, check_path

__all__ = ["Variables", "existing_file", "not_a_file", "read_npy", "read_variables", "reading"]

_NPY_MAGIC = b"\x93NUMPY"
_ZIP_MAGIC = b"PK\x03\x04"
#: What to do with a .mat file no reader takes: Octave saves text by default (or HDF5 of
#: its own layout with ``-hdf5``), which only Octave reads.
_SAVE_V7 = (
    ". If Octave wrote it (its default format is text, and -hdf5 is a layout of its own), "
    "save it as a MATLAB v7 file: save('-v7', 'mine.mat', ...)"
)
_NO_PICKLES = (
    "holds Python objects (a pickle), which skf_ref never loads: save numbers, and text as "
    "np.array(names, dtype=str)"
)
# MATLAB classes -> numpy dtype kinds (what _pick and the readers ask of a variable)
_MATLAB_KINDS = {
    "double": "f",
    "single": "f",
    "logical": "b",
    "char": "U",
    **{f"int{bits}": "i" for bits in (8, 16, 32, 64)},
    **{f"uint{bits}": "u" for bits in (8, 16, 32, 64)},
}


def existing_file(path: object, name: str = "path") -> Path:
    """``path`` as a :class:`~pathlib.Path` if it names an existing file, else a clear error.

    Parameters
    ----------
    path : path-like
    name : str
        The parameter, for the message when ``path`` is no file name.

    Returns
    -------
    Path
    """
    path = check_path(name, path)
    if path.is_dir():
        raise InputError(f"{path} is a folder, not a file")
    if not path.is_file():
        raise InputError(f"{path}: {not_a_file(path)}")
    return path


def not_a_file(path: Path) -> str:
    """Why ``path``, which is no regular file, cannot be read as one (in words).

    A named pipe or a device is not "no such file": reading it would wait for a writer,
    or never end (``/dev/zero``).

    Examples
    --------
    >>> not_a_file(Path("/dev/null"))
    'not a regular file but a character device: give a file'
    >>> not_a_file(Path("/no/such/file.npy"))
    'no such file'
    """
    import os
    import stat

    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        if path.is_symlink():
            return f"no such file (a link to {os.readlink(path)}, which does not exist)"
        return "no such file"
    except OSError as err:
        return f"cannot be read: {err.strerror}"
    kinds = (
        (stat.S_ISFIFO, "a named pipe (FIFO)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    kind = next((words for test, words in kinds if test(mode)), "not a file")
    link = f" (a link to {os.readlink(path)})" if path.is_symlink() else ""
    return f"not a regular file but {kind}{link}: give a file"


@contextlib.contextmanager
def reading(path: Path, what: str) -> Iterator[None]:
    """Turn a reader's own exceptions into one :class:`~skf_ref.InputError` naming the file.

    MNE's advice on file names (``-ave.fif`` and the like) is not shown: the readers here
    take any name and say what they read the file as.

    Parameters
    ----------
    path : Path
    what : str
        What the file is read as (``"a NumPy array"``), for the message.
    """
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "This filename .* does not conform to MNE")
            yield
    except InputError:
        raise
    except Exception as err:  # each reader (numpy, scipy, h5py, pandas, MNE) has its own
        raise InputError(f"{path}: cannot be read as {what}: {err}") from err


def _magic(path: Path) -> bytes:
    with open(path, "rb") as stream:
        return stream.read(len(_NPY_MAGIC))


def _npy_header(stream: Any) -> tuple[tuple[int, ...], np.dtype]:
    """The shape and dtype of the ``.npy`` data in ``stream``, its header read only."""
    version = np.lib.format.read_magic(stream)
    read = {
        (1, 0): np.lib.format.read_array_header_1_0,
        (2, 0): np.lib.format.read_array_header_2_0,
    }.get(version)
    if read is None:
        raise ValueError(f".npy format version {version} is not read here")
    shape, _, dtype = read(stream)
    return shape, dtype


def read_npy(path: object, name: str = "path") -> np.ndarray:
    """The array of a ``.npy`` file; anything else named ``.npy`` is refused as such.

    Parameters
    ----------
    path : path-like
    name : str
        The parameter, for messages.

    Returns
    -------
    ndarray
    """
    path = existing_file(path, name)
    magic = _magic(path)
    if magic != _NPY_MAGIC:
        hint = ": it is a zip archive (an .npz?)" if magic.startswith(_ZIP_MAGIC) else ""
        raise InputError(f"{path}: not a NumPy .npy file{hint}")
    with reading(path, "a NumPy array"):
        with open(path, "rb") as stream:
            _, dtype = _npy_header(stream)
        if dtype.hasobject:
            raise InputError(f"{path} {_NO_PICKLES}")
        return np.load(path, allow_pickle=False)


class Variables(Mapping):
    """A file's variables by name, each read when first asked for (then kept).

    Parameters
    ----------
    kinds : dict
        ``{name: numpy dtype kind}`` of every variable, read from the file's directory.
    load : callable
        ``load(name)`` reads one variable.
    """

    def __init__(self, kinds: dict[str, str], load: Callable[[str], Any]) -> None:
        self._kinds, self._load = kinds, load
        self._values: dict[str, Any] = {}

    def __getitem__(self, name: str) -> Any:
        if name not in self._kinds:
            raise KeyError(name)
        if name not in self._values:
            self._values[name] = self._load(name)
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._kinds)

    def __len__(self) -> int:
        return len(self._kinds)

    def kind(self, name: str) -> str:
        """The numpy dtype kind of a variable (``"f"``, ``"U"`` ...), read without it."""
        return self._kinds[name]

    def __repr__(self) -> str:
        return f"<variables {sorted(self._kinds)}>"


def _npz(path: Path) -> Variables:
    if not zipfile.is_zipfile(path):
        hint = ": it is a NumPy .npy array (name it .npy)" if _magic(path) == _NPY_MAGIC else ""
        raise InputError(f"{path}: not an .npz archive (a zip file of NumPy arrays){hint}")
    kinds, dtypes = {}, {}
    with reading(path, "a NumPy .npz archive"), np.load(path, allow_pickle=False) as npz:
        for name in npz.files:
            member = name if name in npz.zip.namelist() else f"{name}.npy"
            if not member.endswith(".npy"):
                kinds[name] = "V"  # a file in the archive that is no array
                continue
            with npz.zip.open(member) as stream:
                _, dtypes[name] = _npy_header(stream)
            kinds[name] = dtypes[name].kind

    def load(name: str) -> Any:
        if name in dtypes and dtypes[name].hasobject:
            raise InputError(f"{path}: {name} {_NO_PICKLES}")
        with reading(path, "a NumPy .npz archive"), np.load(path, allow_pickle=False) as npz:
            return npz[name]

    return Variables(kinds, load)


def _matrix(value: Any, shape: tuple[int, ...], kind: str) -> Any:
    """A numeric MATLAB matrix with the dimensions the reader squeezed away put back."""
    if kind in "fiub" and isinstance(value, np.ndarray) and len(shape) >= 2:
        if value.shape != tuple(shape) and value.size == int(np.prod(shape)) > 1:
            return value.reshape(shape)
    return value


def _mat_v5(path: Path) -> Variables:
    from scipy.io import loadmat, whosmat

    with reading(path, "a MATLAB v5 file"):
        listed = whosmat(path)
    shapes = {name: shape for name, shape, _ in listed}
    kinds = {name: _MATLAB_KINDS.get(cls, "O") for name, _, cls in listed}

    def load(name: str) -> Any:
        with reading(path, "a MATLAB v5 file"):
            value = loadmat(path, squeeze_me=True, variable_names=[name])[name]
        return _matrix(value, shapes[name], kinds[name])

    return Variables(kinds, load)


def _mat_v73(path: Path) -> Variables:
    import h5py
    from pymatreader import read_mat

    kinds, shapes = {}, {}
    with reading(path, "a MATLAB v7.3 (HDF5) file"), h5py.File(path, "r") as f:
        for name, item in f.items():
            if name.startswith("#"):
                continue  # MATLAB's own references
            cls = item.attrs.get("MATLAB_class", b"struct")
            cls = cls.decode() if isinstance(cls, bytes) else str(cls)
            complex_ = isinstance(item, h5py.Dataset) and item.dtype.names == ("real", "imag")
            kinds[name] = "c" if complex_ else _MATLAB_KINDS.get(cls, "O")
            shapes[name] = item.shape[::-1] if isinstance(item, h5py.Dataset) else ()

    def load(name: str) -> Any:
        with reading(path, "a MATLAB v7.3 (HDF5) file"):
            value = read_mat(str(path), variable_names=[name])[name]
        return _matrix(value, shapes[name], kinds[name])

    return Variables(kinds, load)


def read_variables(path: object) -> Variables:
    """The variables of a ``.npz`` or ``.mat`` (v5 or v7.3) file, by name, read when used.

    The names come from the file's directory; a variable's data are read (and
    decompressed) only when it is first looked up, then kept. ``dict(read_variables(p))``
    reads them all.

    Parameters
    ----------
    path : path-like
        Ends in ``.npz`` or ``.mat``.

    Returns
    -------
    Variables
        A mapping ``{name: value}``: NumPy's arrays as they were saved; MATLAB's 1 x 1 arrays as
        numbers, text as ``str``, matrices with both their dimensions (module docstring).

    Raises
    ------
    skf_ref.InputError
        The file is missing, is not what its name says (a non-archive named ``.npz``),
        or holds pickled objects (when such a variable is read).
    """
    path = existing_file(path)
    if path.suffix not in (".npz", ".mat"):
        raise InputError(f"{path}: expected a .npz or .mat file, got {path.suffix!r}")
    if path.suffix == ".npz":
        return _npz(path)
    if _magic(path).startswith(_ZIP_MAGIC):
        raise InputError(f"{path}: not a MATLAB file: it is a zip archive (an .npz?)")
    try:
        return _mat_v5(path)
    except InputError as err:
        if "v7.3" not in str(err) and "HDF" not in str(err):
            raise InputError(f"{err}{_SAVE_V7}") from err
    try:
        return _mat_v73(path)
    except InputError as err:
        raise InputError(f"{err}{_SAVE_V7}") from err
