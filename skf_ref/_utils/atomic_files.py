"""Files that appear whole or not at all, output paths checked first, no temporary left behind.

Every writer of the package goes through here:

- :func:`check_output_path` refuses, before any work, an output that could not be written
  or should not be: a missing folder, a folder where a file goes, an unknown extension, an
  input of the same run, an existing file the caller may not replace;
- :func:`atomic_path` (one file) and :func:`temporary_folder` (a writer that makes several
  files, MNE's ``.stc`` writer) write under a hidden temporary name beside the result and
  rename it into place when whole. Writing through a symbolic link writes the file it
  points to, as ``open(path, "w")`` would; errors name the user's path, not the
  temporary;
- every temporary carries the id of the process writing it (``.NAME.skf-tmp-PID-XXXX``), so
  that the next writer of the same result removes what a killed one left
  (:func:`remove_stale_temporaries`);
- :func:`rename_noreplace` publishes a folder (a zarr store) only where nothing is: it
  fails if anything appeared at the destination meanwhile, even an empty folder;
  ``atomic_path(path, overwrite=False)`` publishes a file the same way (a hard link,
  which never replaces), so that a file that appeared while it was written (a second run
  of the same command) is never replaced.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import glob
import os
import re
import shutil
import sys
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from .checks import InputError, check_path

__all__ = [
    "atomic_path",
    "check_output_path",
    "remove_stale_temporaries",
    "rename_noreplace",
    "same_file",
    "stale_temporaries",
    "temporary_folder",
    "temporary_prefix",
]

_TAG = ".skf-tmp-"
_PID = re.compile(r"\.skf-[a-z]+-(\d+)-")
#: A file in every folder :func:`temporary_folder` makes: only such a folder (or an empty
#: one) is ever removed as a killed writer's leftover.
_FOLDER_MARK = ".skf_ref_temporary"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: alive
        return True
    return True


def temporary_prefix(path: str | os.PathLike, tag: str = "tmp") -> str:
    """The name a temporary folder of ``path`` starts with: hidden, tagged, this process's id.

    (:func:`atomic_path`'s files keep the suffix of ``path``, for the writers that read the
    format from it: ``.STEM.skf-tmp-PID-XXXX.SUFFIX``.)

    Parameters
    ----------
    path : path-like
        The final name.
    tag : str
        What kind of temporary (``"tmp"``: being written; ``"old"``: being replaced).

    Returns
    -------
    str

    Examples
    --------
    >>> temporary_prefix("out/skf.zarr").startswith(".skf.zarr.skf-tmp-")
    True
    """
    return f".{Path(path).name}.skf-{tag}-{os.getpid()}-"


def stale_temporaries(path: str | os.PathLike, tag: str = "tmp") -> list[Path]:
    """Temporary folders of ``path`` (:func:`temporary_prefix`) whose process no longer runs.

    Parameters
    ----------
    path : path-like
    tag : str

    Returns
    -------
    list of Path
        Files or folders beside ``path``, left by a process killed before it could rename
        or delete them.
    """
    path = Path(path)
    found = []
    for tmp in path.parent.glob(f".{glob.escape(path.name)}.skf-{tag}-*"):
        match = _PID.search(tmp.name)
        if match and not _alive(int(match.group(1))):
            found.append(tmp)
    return sorted(found)


def remove_stale_temporaries(path: str | os.PathLike) -> list[Path]:
    """Delete the temporaries of ``path`` that a process killed while writing left behind.

    A temporary carries the id of the process writing it; one whose process no longer
    runs is removed: the files of :func:`atomic_path`, and the folders of
    :func:`temporary_folder` (only those holding its mark, or nothing: a folder of the
    user's that merely looks like one is kept).

    Parameters
    ----------
    path : path-like
        The final file name.

    Returns
    -------
    list of Path
        The temporaries removed.
    """
    path = Path(path)
    removed = []
    pattern = f".{glob.escape(path.stem)}{_TAG}*{glob.escape(path.suffix)}"
    for tmp in path.parent.glob(pattern):
        match = _PID.search(tmp.name)
        if match and not _alive(int(match.group(1))) and not tmp.is_dir():
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
                removed.append(tmp)
    for tmp in stale_temporaries(path):
        if tmp.is_dir() and not tmp.is_symlink():
            if (tmp / _FOLDER_MARK).is_file() or not any(tmp.iterdir()):
                shutil.rmtree(tmp, ignore_errors=True)
                removed.append(tmp)
    return removed


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether two names lead to one file: the same path once links are followed, or (for
    files that exist) the same file on disk, hard links included.

    Examples
    --------
    >>> same_file("data/../Y.npy", "Y.npy")
    True
    """
    with contextlib.suppress(OSError):
        return os.path.samefile(a, b)
    return os.path.realpath(a) == os.path.realpath(b)


def check_output_path(
    path: object,
    *,
    name: str | None = None,
    suffixes: Iterable[str] | None = None,
    inputs: dict[str, str | os.PathLike | None] | None = None,
    overwrite: bool = True,
    overwrite_hint: str = "give overwrite=True to replace it",
) -> Path:
    """Refuse, before any work, an output file that cannot or should not be written.

    Parameters
    ----------
    path : path-like
        The file to write.
    name : str, optional
        How messages name it: ``"argument --out"``, ``"path"``. Messages start with
        ``"NAME: PATH: "`` (or ``"PATH: "``).
    suffixes : iterable of str, optional
        The extensions the writer knows (``".npz"``), compared without case: the extension
        decides the format, and any other is refused.
    inputs : dict, optional
        ``{name: path}`` of the files the same run reads: the output may be none of them
        (by name, through a link, or as a hard link).
    overwrite : bool
        Whether an existing file may be replaced.
    overwrite_hint : str
        What the message says to do when it may not (``"give --overwrite to replace it"``).

    Returns
    -------
    Path

    Raises
    ------
    skf_ref.InputError
        The folder does not exist; the path is a folder; the extension is not one of
        ``suffixes``; the path is one of ``inputs``; the file exists and ``overwrite`` is
        False. An :class:`~skf_ref.InputTypeError` if ``path`` is no file name.

    Examples
    --------
    >>> check_output_path("out.txt", name="argument --out", suffixes=(".npz",))
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: argument --out: out.txt: must end in .npz, got '.txt'
    """
    path = check_path(name or "path", path)
    where = f"{name}: {path}" if name else f"{path}"
    if suffixes is not None:
        suffixes = tuple(suffixes)
        if path.suffix.lower() not in suffixes:
            raise InputError(f"{where}: must end in {' or '.join(suffixes)}, got {path.suffix!r}")
    parent = Path(os.path.realpath(path)).parent if path.is_symlink() else path.parent
    if not parent.is_dir():
        raise InputError(f"{where}: the folder {parent} does not exist")
    if path.is_dir():
        raise InputError(f"{where} is a folder; give a file name")
    for input_name, given in (inputs or {}).items():
        if given is not None and same_file(path, given):
            raise InputError(
                f"{where} is the input {input_name} ({given}): it would be overwritten"
            )
    if not overwrite and (path.exists() or path.is_symlink()):
        raise InputError(f"{where} exists: {overwrite_hint}")
    return path


def _writable(path: Path) -> Path:
    """The file a write to ``path`` replaces (a symbolic link's target), checked writable."""
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    if not target.parent.is_dir():
        raise InputError(f"{path}: the folder {target.parent} does not exist")
    if target.is_dir():
        raise InputError(f"{path} is a folder; give a file name")
    return target


def _named(err: OSError, tmp: str, path: Path) -> OSError:
    """``err`` naming ``path`` where it named the temporary ``tmp``."""
    if os.fspath(err.filename or "") != tmp and os.fspath(err.filename2 or "") != tmp:
        return err
    renamed = type(err)(err.errno, err.strerror, str(path))
    return renamed


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, overwrite: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it to ``path`` only on success.

    The temporary is hidden (its name starts with a dot), carries this process's id, and is
    deleted if the block raises; temporaries of ``path`` left by a killed process are
    deleted first (:func:`remove_stale_temporaries`). A ``path`` that is a symbolic link
    gets the new file where the link points (the link stays). An error about the
    temporary names ``path``.

    Parameters
    ----------
    path : path-like
        Final file name; its suffix is kept so writers can pick the format from it.
    overwrite : bool
        Whether the file may replace one at ``path``. False: it is published only where
        nothing is, at the very moment it is published (a hard link, or a rename that never
        replaces): a file that appeared while it was written (another run writing the
        same name) stays as it is, and this one is not kept.

    Yields
    ------
    Path
        The temporary to write.

    Raises
    ------
    skf_ref.InputError
        The folder of ``path`` does not exist, or ``path`` is a folder; without
        ``overwrite``, a file at ``path`` (one that appeared while this one was written).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> with atomic_path(target) as tmp:
    ...     _ = tmp.write_text("whole")
    >>> target.read_text()
    'whole'
    """
    given = check_path("path", path)
    path = _writable(given)
    remove_stale_temporaries(path)
    try:
        fd, tmp = tempfile.mkstemp(
            dir=path.parent, prefix=f".{path.stem}{_TAG}{os.getpid()}-", suffix=path.suffix
        )
    except OSError as err:
        raise InputError(f"{given}: cannot write in {path.parent}: {err.strerror}") from err
    os.close(fd)
    try:
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # the mode of an ordinary new file, not mkstemp's 0600
        if overwrite:
            os.replace(tmp, path)
        else:
            _publish_new(Path(tmp), path, given)
    except OSError as err:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        named = _named(err, tmp, given)
        if named is err:
            raise
        raise named from err
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _publish_new(tmp: Path, path: Path, given: Path) -> None:
    """Give the whole file ``tmp`` the name ``path`` only if nothing has it: never replace.

    A hard link fails if the name exists, whatever appeared there meanwhile; where the file
    system has no hard links, a rename that never replaces (:func:`rename_noreplace`).
    """
    try:
        os.link(tmp, path)
    except FileExistsError:
        raise InputError(
            f"{given} appeared while it was written (another process?): it is left as it is "
            "and this file is not kept; write it again, or to another name"
        ) from None
    except OSError as err:
        if err.errno not in _NO_LINKS:
            raise
        try:
            rename_noreplace(tmp, path)
        except FileExistsError:
            raise InputError(
                f"{given} appeared while it was written (another process?): it is left as "
                "it is and this file is not kept; write it again, or to another name"
            ) from None
    else:
        os.unlink(tmp)


#: What ``os.link`` answers on a file system without hard links.
_NO_LINKS = {
    getattr(errno, name)
    for name in ("EPERM", "ENOTSUP", "EOPNOTSUPP", "EXDEV", "EMLINK", "ENOSYS", "EACCES")
    if hasattr(errno, name)
}


@contextlib.contextmanager
def temporary_folder(path: str | os.PathLike) -> Iterator[Path]:
    """A hidden folder beside ``path`` for a writer that makes several files; removed after.

    Named ``.NAME.skf-tmp-PID-XXXX`` and marked as this package's, so that a rerun for the
    same ``path`` removes what a killed process left (:func:`remove_stale_temporaries`).
    The caller moves the files it keeps out of it.

    Parameters
    ----------
    path : path-like
        The result the folder is for.

    Yields
    ------
    Path
    """
    given = check_path("path", path)
    path = _writable(given)
    remove_stale_temporaries(path)
    try:
        tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=temporary_prefix(path)))
    except OSError as err:
        raise InputError(f"{given}: cannot write in {path.parent}: {err.strerror}") from err
    try:
        (tmp / _FOLDER_MARK).touch()
        yield tmp
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


_AT_FDCWD = -100
_RENAME_NOREPLACE = 1  # Linux renameat2
_RENAME_EXCL = 4  # macOS renamex_np


def _libc_rename(name: str) -> Callable[..., int] | None:
    try:
        function = getattr(ctypes.CDLL(None, use_errno=True), name)
    except (OSError, AttributeError):  # no such C library call here
        return None
    return function


def rename_noreplace(src: str | os.PathLike, dst: str | os.PathLike) -> None:
    """Rename ``src`` to ``dst``, failing if anything is at ``dst``, even an empty folder.

    ``os.rename`` replaces an empty folder (and, on POSIX, a file); this asks the system
    for a rename that never replaces (Linux ``renameat2(RENAME_NOREPLACE)``, macOS
    ``renamex_np(RENAME_EXCL)``), so of two processes publishing the same name exactly one
    succeeds. Where the system cannot, the destination is checked just before renaming.

    Parameters
    ----------
    src, dst : path-like

    Raises
    ------
    FileExistsError
        Something is at ``dst``.
    """
    source, target = os.fsencode(src), os.fsencode(dst)
    code = None
    if sys.platform.startswith("linux"):
        function = _libc_rename("renameat2")
        if function is not None:
            code = function(_AT_FDCWD, source, _AT_FDCWD, target, _RENAME_NOREPLACE)
    elif sys.platform == "darwin":
        function = _libc_rename("renamex_np")
        if function is not None:
            code = function(source, target, _RENAME_EXCL)
    if code == 0:
        return
    if code is not None:
        number = ctypes.get_errno()
        if number not in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):
            raise OSError(number, os.strerror(number), os.fsdecode(src), None, os.fsdecode(dst))
    if os.path.lexists(dst):  # the file system cannot rename exclusively: check, then rename
        raise FileExistsError(
            errno.EEXIST, os.strerror(errno.EEXIST), os.fsdecode(src), None, os.fsdecode(dst)
        )
    os.rename(src, dst)
