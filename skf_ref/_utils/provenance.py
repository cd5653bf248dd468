"""What produced a result: package versions, the BLAS library and its threads.

Every output folder and results file of the package records these (the demo's
``settings.json``, sweep rows, the reproduction report's manifest, the benchmark header),
so a number can be traced to the code and the machine configuration that computed it.
"""

import os
import platform
from collections.abc import Iterable
from importlib import metadata
from typing import Any

from .._version import __version__

__all__ = ["PACKAGES", "blas_threads", "machine", "package_versions"]

#: The packages results depend on.
PACKAGES = ("skf_ref", "numpy", "scipy", "filterpy", "mne")


def package_versions(packages: Iterable[str] = PACKAGES) -> dict[str, str]:
    """Versions of the packages results depend on, by name.

    skf_ref's own comes from the package itself, so it is known when run from a checkout.

    Parameters
    ----------
    packages : sequence of str

    Returns
    -------
    dict
        ``{name: version}``; ``"not installed"`` for a missing package.

    Examples
    --------
    >>> package_versions(("skf_ref", "no-such-package"))
    {'skf_ref': '...', 'no-such-package': 'not installed'}
    """
    versions = {}
    for package in packages:
        try:
            versions[package] = __version__ if package == "skf_ref" else metadata.version(package)
        except metadata.PackageNotFoundError:
            versions[package] = "not installed"
    return versions


def blas_threads() -> list[dict[str, Any]]:
    """The BLAS libraries loaded in this process and their thread counts (threadpoolctl).

    Returns
    -------
    list of dict
        One per library: ``library`` (e.g. ``"openblas"``), ``version``, ``threads``,
        ``threading_layer``.

    Examples
    --------
    >>> import numpy  # loads numpy's BLAS
    >>> all(entry["threads"] >= 1 for entry in blas_threads())
    True
    """
    from threadpoolctl import threadpool_info

    entries = [
        {
            "library": entry.get("internal_api"),
            "version": entry.get("version"),
            "threads": entry.get("num_threads"),
            "threading_layer": entry.get("threading_layer"),
        }
        for entry in threadpool_info()
        if entry.get("user_api") == "blas"
    ]
    # threadpoolctl's order follows the interpreter's hash seed: sort, so that the same
    # libraries always read the same (sweep rows, manifests)
    return sorted(entries, key=lambda entry: (str(entry["library"]), str(entry["version"])))


def machine() -> dict[str, Any]:
    """This machine and process: CPUs, platform, Python, BLAS threads, package versions.

    Returns
    -------
    dict
        ``cpus``, ``platform``, ``python``, ``blas`` (see :func:`blas_threads`),
        ``versions`` (see :func:`package_versions`).
    """
    return {
        "cpus": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "blas": blas_threads(),
        "versions": package_versions(),
    }
