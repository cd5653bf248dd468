"""Files that appear whole or not at all, and no temporaries left behind."""

import contextlib
import glob
import os
import re
import tempfile
from pathlib import Path

__all__ = ["atomic_path", "remove_stale_temporaries", "stale_temporaries", "temporary_prefix"]

_TAG = ".skf-tmp-"
_PID = re.compile(r"\.skf-[a-z]+-(\d+)-")


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: alive
        return True
    return True


def temporary_prefix(path, tag="tmp"):
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


def stale_temporaries(path, tag="tmp"):
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


def remove_stale_temporaries(path):
    """Delete temporaries of ``path`` left by :func:`atomic_path` in a process that died.

    A temporary carries the id of the process writing it; one whose process no longer
    runs (killed before it could rename or delete it) is removed. Returns the paths removed.

    Parameters
    ----------
    path : path-like
        The final file name.

    Returns
    -------
    list of Path
    """
    path = Path(path)
    removed = []
    pattern = f".{glob.escape(path.stem)}{_TAG}*{glob.escape(path.suffix)}"
    for tmp in path.parent.glob(pattern):
        match = _PID.search(tmp.name)
        if match and not _alive(int(match.group(1))):
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
                removed.append(tmp)
    return removed


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it to ``path`` only on success.

    The temporary is hidden (its name starts with a dot), carries this process's id, and is
    deleted if the block raises; temporaries of ``path`` left by a killed process are
    deleted first (:func:`remove_stale_temporaries`).

    Parameters
    ----------
    path : path-like
        Final file name; its suffix is kept so writers can pick the format from it.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> with atomic_path(target) as tmp:
    ...     _ = tmp.write_text("whole")
    >>> target.read_text()
    'whole'
    """
    path = Path(path)
    remove_stale_temporaries(path)
    fd, tmp = tempfile.mkstemp(
        dir=path.parent, prefix=f".{path.stem}{_TAG}{os.getpid()}-", suffix=path.suffix
    )
    os.close(fd)
    try:
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # the mode of an ordinary new file, not mkstemp's 0600
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
