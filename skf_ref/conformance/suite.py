"""The pinned suite: the committed case files, their manifest and checksums, and export.

Version :data:`~skf_ref.conformance.CONFORMANCE_VERSION` of the suite is a folder of files
in the package, ``suite_v2/``: each case as ``.npz`` and MATLAB v5 ``.mat``, and
``manifest.json`` with the sha256 of every file. They were written once by :func:`build`
and never change: :func:`export` copies them byte for byte, and :func:`cases` reads them, so
a later ``skf_ref`` cannot change what the suite expects. A test recomputes every case
with the installed package and fails when it drifts from the pinned outputs beyond a case's
tolerance. A changed case is a new suite version in a new folder.

The runners, ``runners/run_cases.py`` and ``runners/run_cases.m``, run an implementation
on every case and save its outputs for ``skf-ref compare``; :func:`export` copies them
beside the cases.
"""

import hashlib
import json
import shutil
from functools import cache
from pathlib import Path

from .._utils.atomic_files import atomic_path
from .._utils.checks import InputError, check_choice
from ..version import __version__
from .case_files import FORMATS, read_case, write_case
from .cases import (
    CONFORMANCE_VERSION,
    FLOAT32_TOLERANCE,
    INPUTS,
    OUTPUTS,
    TOLERANCE,
    generate,
)

__all__ = ["RUNNERS", "SUITE", "build", "cases", "export", "manifest", "sha256", "verify"]

#: The folder of the pinned suite, inside the installed package.
SUITE = Path(__file__).resolve().with_name(f"suite_v{CONFORMANCE_VERSION}")
#: The runner examples :func:`export` copies beside the cases (MATLAB/Octave and Python).
RUNNERS = tuple(
    Path(__file__).resolve().parent / "runners" / f"run_cases.{ext}" for ext in ("m", "py")
)


def sha256(path):
    """The sha256 of a file, as hexadecimal text.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    str
    """
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@cache
def _pinned_manifest():
    return json.loads((SUITE / "manifest.json").read_text(encoding="utf-8"))


def manifest():
    """The suite's ``manifest.json``: versions, tolerances, layout, and each case's files.

    Returns
    -------
    dict
        ``conformance_version``; ``skf_ref_version`` (the version that computed the expected
        outputs); ``tolerance`` and ``float32_tolerance``; the variables and their layout;
        ``cases``, each with what it exercises, its sizes, its tolerance and ``files``
        (``{file name: sha256}``).

    Examples
    --------
    >>> manifest()["conformance_version"]
    2
    >>> sorted(manifest()["cases"][0]["files"])
    ['original_skf.mat', 'original_skf.npz']
    """
    return json.loads(json.dumps(_pinned_manifest()))  # a copy the caller may change


@cache
def _pinned_cases():
    return tuple(
        read_case(SUITE / f"{entry['name']}.npz") for entry in _pinned_manifest()["cases"]
    )


def cases():
    """The suite's cases, read from its pinned files (once per process).

    Returns
    -------
    list of Case

    Examples
    --------
    >>> [case.name for case in cases()][:3]
    ['original_skf', 'free_orientation', 'average_reference']
    >>> cases()[0].shape, cases()[0].skf_ref_version
    ((4, 7), '0.3.0')
    """
    return list(_pinned_cases())


def verify(directory=SUITE):
    """The files of ``directory`` whose sha256 differs from the manifest's, or that are missing.

    Parameters
    ----------
    directory : path-like
        A folder :func:`export` wrote (any of its formats), or the pinned suite itself.

    Returns
    -------
    list of str
        The names of the case files present in ``directory`` but changed, then those of
        the formats present that are missing. Empty when every file is the suite's.

    Examples
    --------
    >>> verify()
    []
    """
    directory = Path(directory)
    files = {
        name: digest for e in _pinned_manifest()["cases"] for name, digest in e["files"].items()
    }
    present = {Path(name).suffix for name in files if (directory / name).is_file()}
    changed = [
        n for n, d in files.items() if (directory / n).is_file() and sha256(directory / n) != d
    ]
    missing = [n for n in files if Path(n).suffix in present and not (directory / n).is_file()]
    return changed + missing


def export(directory, formats=FORMATS):
    """Copy the suite's files in ``formats``, its manifest and the runners to ``directory``.

    The case files and ``manifest.json`` are the pinned ones, byte for byte: the manifest
    lists every file of the suite (both formats) with its sha256.

    Parameters
    ----------
    directory : path-like
        Created if missing.
    formats : sequence of {"npz", "mat"}

    Returns
    -------
    list of Path
        The case files copied, then the runners, then ``manifest.json``.

    Examples
    --------
    >>> import tempfile
    >>> written = export(tempfile.mkdtemp(), formats=["mat"])
    >>> [path.name for path in written][:2], written[-1].name
    (['original_skf.mat', 'free_orientation.mat'], 'manifest.json')
    """
    formats = _checked_formats(formats)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    names = [f"{e['name']}.{fmt}" for e in _pinned_manifest()["cases"] for fmt in formats]
    sources = [*(SUITE / name for name in names), *RUNNERS, SUITE / "manifest.json"]
    written = []
    for source in sources:
        with atomic_path(directory / source.name) as tmp:
            shutil.copyfile(source, tmp)
        written.append(directory / source.name)
    return written


def _checked_formats(formats):
    for fmt in formats:
        check_choice("format", fmt, FORMATS)
    formats = [fmt for fmt in FORMATS if fmt in formats]  # the same files in any order given
    if not formats:
        raise InputError(f"formats must name at least one of {list(FORMATS)}, got none")
    return formats


def build(directory, formats=FORMATS):
    """Compute every case afresh and write a suite: how a new suite version is made.

    Writes :func:`~skf_ref.conformance.cases.generate`'s cases in each format and their
    ``manifest.json`` (with each file's sha256) to ``directory``. The files are the same,
    byte for byte, each time it runs in one environment (no dates inside); they record
    the ``skf_ref`` version that computed them. Pinning a new version: raise
    ``CONFORMANCE_VERSION``, build into ``skf_ref/conformance/suite_v<version>/``, commit.

    Parameters
    ----------
    directory : path-like
        Created if missing.
    formats : sequence of {"npz", "mat"}

    Returns
    -------
    list of Path
        The files written, the manifest last.
    """
    formats = _checked_formats(formats)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    fresh = generate()
    written = [
        write_case(case, directory / f"{case.name}.{fmt}") for case in fresh for fmt in formats
    ]
    entries = [
        {
            "name": case.name,
            "description": case.description,
            "exercises": list(case.exercises),
            "also_holds": list(case.extras),
            "n_channels": case.inputs["L"].shape[0],
            "n_sources": case.shape[0],
            "n_times": case.shape[1],
            "tolerance": case.tolerance,
            "files": {
                f"{case.name}.{fmt}": sha256(directory / f"{case.name}.{fmt}") for fmt in formats
            },
        }
        for case in fresh
    ]
    path = directory / "manifest.json"
    with atomic_path(path) as tmp:
        tmp.write_text(
            json.dumps(_about() | {"cases": entries}, indent=1) + "\n", encoding="utf-8"
        )
    return [*written, path]


def _about():
    return {
        "conformance_version": CONFORMANCE_VERSION,
        "skf_ref_version": __version__,
        "skf_ref_version_means": "the skf_ref that computed the expected outputs",
        "tolerance": TOLERANCE,
        "tolerance_means": "largest |theirs - expected| over largest |expected|, per output",
        "float32_tolerance": FLOAT32_TOLERANCE,
        "layout": {
            "L": "(n_channels, n_sources)",
            "Y": "(n_channels, n_times); column t is y_t",
            "noise_cov, theta0, q, transition": "a scalar c means c times the identity",
            "noise_cov": "the noise covariance R: a scalar c is R = c I, a variance (not sigma)",
            "smoother": "text: none, rts-standardized or rts-state",
            "z, z_filtered, x, x_filtered, weights": "(n_sources, n_times)",
            "log_likelihood": "a scalar",
        },
        "inputs": list(INPUTS),
        "outputs": list(OUTPUTS),
        "documentation": "docs/conformance.md of the skf_ref repository",
    }
