"""What a bug report needs: the machine, Python, the dependencies' versions and the BLAS.

:func:`sys_info` prints it, as ``mne.sys_info()`` does for MNE-Python; ``skf-ref
sys-info`` is the same on the command line. It reads what :mod:`.provenance` records in
every result (:func:`~skf_ref._utils.provenance.machine`), and adds the memory and every
optional dependency.
"""

import os
import platform
import sys
from typing import TextIO

from .memory import available_memory
from .provenance import blas_threads, package_versions

__all__ = ["OPTIONAL", "REQUIRED", "sys_info"]

#: What ``python -m pip install .`` installs from the source tree (``install_requires``).
REQUIRED = ("numpy", "scipy", "filterpy", "threadpoolctl", "matplotlib", "pandas")
#: What the extras add (``mne``, ``study``, ``zarr``, ``dask``, ``parquet``).
OPTIONAL = (
    "mne",
    "h5io",
    "pymatreader",
    "nibabel",
    "joblib",
    "tqdm",
    "filelock",
    "zarr",
    "dask",
    "distributed",
    "pyarrow",
)

_WIDTH = 16  # the label column


def _total_memory() -> int | None:
    """Bytes of physical memory, or None where the platform does not say."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # Windows has no sysconf
        return None


def _gib(nbytes: int | None) -> str:
    return "unknown" if nbytes is None else f"{nbytes / 2**30:.1f} GiB"


def _memory() -> str:
    try:
        available = available_memory()
    except (AttributeError, ValueError, OSError):
        available = None
    return f"{_gib(_total_memory())} total, {_gib(available)} available"


def _blas_lines() -> list[str]:
    """One line per BLAS library loaded, with its threads and the folder it came from."""
    import numpy  # noqa: F401  (loads numpy's BLAS, so that threadpoolctl sees it)
    import scipy.linalg  # noqa: F401  (and scipy's, when it has its own)
    from threadpoolctl import threadpool_info

    # the folder tells numpy's copy from scipy's (numpy.libs, scipy.libs, a system lib dir)
    folders = {
        (entry.get("internal_api"), entry.get("version")): os.path.basename(
            os.path.dirname(entry.get("filepath") or "")
        )
        for entry in threadpool_info()
    }
    lines = []
    for entry in blas_threads():
        threads = f"{entry['threads']} thread{'s' * (entry['threads'] != 1)}"
        layer = entry["threading_layer"]
        if layer not in (None, "", "unknown"):
            threads += f", {layer}"
        folder = folders.get((entry["library"], entry["version"])) or "?"
        lines.append(f"{entry['library']} {entry['version']} ({threads}) from {folder}")
    return lines or ["none loaded"]


def _section(title: str, rows: dict[str, str]) -> list[str]:
    return ["", title, *(f"{name:<{_WIDTH}} {value}" for name, value in rows.items())]


def sys_info(fid: TextIO | None = None) -> None:
    """Print the machine, Python, the dependencies' versions and the BLAS threads.

    What a bug report needs: the platform, Python and its executable, the CPU count and
    the memory, skf_ref's version, each required and optional dependency's version
    (``not installed`` where absent) and the BLAS libraries numpy and scipy load, with
    their threads (threadpoolctl). ``skf-ref sys-info`` prints the same; every output folder
    and results file of the package records the same facts with the numbers it holds.

    Parameters
    ----------
    fid : file-like, optional
        Where to print (anything with ``write``); default ``sys.stdout``.

    Examples
    --------
    >>> import skf_ref
    >>> skf_ref.sys_info()  # doctest: +ELLIPSIS
    Platform         ...
    Python           ...
    ...
    Required dependencies
    numpy            ...
    ...
    BLAS (threadpoolctl)
    ...
    """
    fid = sys.stdout if fid is None else fid
    versions = package_versions(("skf_ref", *REQUIRED, *OPTIONAL))
    lines = [
        f"{'Platform':<{_WIDTH}} {platform.platform()}",
        f"{'Python':<{_WIDTH}} {sys.version.splitlines()[0]}",
        f"{'Executable':<{_WIDTH}} {sys.executable}",
        f"{'CPUs':<{_WIDTH}} {os.cpu_count()} ({platform.machine() or 'unknown'})",
        f"{'Memory':<{_WIDTH}} {_memory()}",
        f"{'skf_ref':<{_WIDTH}} {versions['skf_ref']}",
        *_section("Required dependencies", {name: versions[name] for name in REQUIRED}),
        *_section("Optional dependencies", {name: versions[name] for name in OPTIONAL}),
        "",
        "BLAS (threadpoolctl)",
        *_blas_lines(),
    ]
    print("\n".join(lines), file=fid)
