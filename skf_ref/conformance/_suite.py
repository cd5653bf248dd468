"""The pinned suite: the committed case files, their manifest and checksums, and export.

Version :data:`~skf_ref.conformance.CONFORMANCE_VERSION` of the suite is a folder of files
in the package, ``suite_v4/``: each case as ``.npz`` and MATLAB v5 ``.mat``, and
``manifest.json`` with the sha256 of every file. They were written once by :func:`build`
and never change: :func:`export` copies them byte for byte, and :func:`cases` reads them, so
a later ``skf_ref`` cannot change what the suite expects. A test recomputes every case
with the installed package and fails when it drifts from the pinned outputs beyond a case's
tolerance. A changed case is a new suite version in a new folder; the earlier pinned
versions, ``suite_v2/`` and ``suite_v3/``, stay, and :func:`export` copies them on request
(``suite=2``, ``suite=3``).

The runners, ``_runners/run_cases.py`` and ``_runners/run_cases.m``, run an implementation
on every case and save its outputs for ``skf-ref compare``; :func:`export` copies them
beside the cases.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import warnings
from collections.abc import Sequence
from functools import cache
from pathlib import Path
from typing import Any

from .._utils.atomic_files import atomic_path
from .._utils.checks import InputError, check_choice, check_instance, check_path
from .._version import __version__
from ._case_files import FORMATS, read_case, write_case
from ._cases import (
    CONFORMANCE_VERSION,
    FLOAT32_TOLERANCE,
    INPUTS,
    OPTIONS,
    OUTPUTS,
    TOLERANCE,
    Case,
    generate,
)

__all__ = [
    "RUNNERS",
    "SUITE",
    "SUITES",
    "build",
    "cases",
    "check_pinned",
    "export",
    "manifest",
    "sha256",
    "verify",
]

#: The folder of each pinned version of the suite, inside the installed package.
SUITES = {
    v: Path(__file__).resolve().with_name(f"suite_v{v}") for v in (2, 3, CONFORMANCE_VERSION)
}
#: The folder of the pinned suite, this version's.
SUITE = SUITES[CONFORMANCE_VERSION]
#: The runner examples :func:`export` copies beside the cases (MATLAB/Octave and Python).
RUNNERS = tuple(
    Path(__file__).resolve().parent / "_runners" / f"run_cases.{ext}" for ext in ("m", "py")
)


def sha256(path: str | os.PathLike) -> str:
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
def _pinned_manifest(suite: int = CONFORMANCE_VERSION) -> dict[str, Any]:
    return json.loads((SUITES[suite] / "manifest.json").read_text(encoding="utf-8"))


def _checked_suite(suite: int) -> int:
    return int(check_choice("suite", suite, tuple(SUITES)))


def manifest(suite: int = CONFORMANCE_VERSION) -> dict[str, Any]:
    """The suite's ``manifest.json``: versions, tolerances, layout, and each case's files.

    Parameters
    ----------
    suite : int
        The suite version (``SUITES``); this version's by default.

    Returns
    -------
    dict
        ``conformance_version``; ``skf_ref_version`` (the version that computed the expected
        outputs); ``tolerance`` and ``float32_tolerance``; the variables and their layout;
        ``cases``, each with what it exercises, its sizes, its tolerance and ``files``
        (``{file name: sha256}``).

    Examples
    --------
    >>> manifest()["conformance_version"], manifest(suite=3)["conformance_version"]
    (4, 3)
    >>> sorted(manifest()["cases"][0]["files"])
    ['original_skf.mat', 'original_skf.npz']
    """
    pinned = _pinned_manifest(_checked_suite(suite))
    return json.loads(json.dumps(pinned))  # a copy the caller may change


@cache
def _pinned_cases(suite: int = CONFORMANCE_VERSION) -> tuple[Case, ...]:
    return tuple(
        read_case(SUITES[suite] / f"{entry['name']}.npz")
        for entry in _pinned_manifest(suite)["cases"]
    )


def cases(suite: int = CONFORMANCE_VERSION) -> list[Case]:
    """The suite's cases, read from its pinned files (once per process).

    Parameters
    ----------
    suite : int
        The suite version (``SUITES``); this version's by default.

    Returns
    -------
    list of Case

    Examples
    --------
    >>> [case.name for case in cases()][:3]
    ['original_skf', 'free_orientation', 'average_reference']
    >>> cases()[0].shape, cases()[0].skf_ref_version
    ((4, 7), '0.4.0')
    >>> len(cases(suite=3)), [case.name for case in cases()][17:]
    (17, ['ar1_prior', 'ar1_prior_smoothed'])
    """
    return list(_pinned_cases(_checked_suite(suite)))


def verify(directory: str | os.PathLike = SUITE, suite: int = CONFORMANCE_VERSION) -> list[str]:
    """The files of ``directory`` whose sha256 differs from the manifest's, or that are missing.

    Parameters
    ----------
    directory : path-like
        A folder :func:`export` wrote (any of its formats), or the pinned suite itself.
    suite : int
        The suite version it holds (``SUITES``); this version's by default.

    Returns
    -------
    list of str
        The names of the case files present in ``directory`` but changed, then
        ``manifest.json`` if changed, then the case files of the formats present that are
        missing. Empty when every file is the suite's.

    Raises
    ------
    skf_ref.InputError
        ``directory`` does not exist, is a file, or holds no file of the suite (nothing
        to verify is not "every file is the suite's").

    Examples
    --------
    >>> verify()
    []
    """
    directory, suite = check_path("directory", directory), _checked_suite(suite)
    if not directory.is_dir():
        what = "is a file, not a folder" if directory.exists() else "does not exist"
        raise InputError(f"{directory} {what}: give the folder skf-ref conformance export wrote")
    files = _pinned_files(suite)
    present = {Path(name).suffix for name in files if (directory / name).is_file()}
    if not present:
        raise InputError(
            f"{directory} holds no file of the conformance suite (version "
            f"{suite}), such as {next(iter(files))}: export it there first "
            "(skf-ref conformance export DIR)"
        )
    changed = [
        n for n, d in files.items() if (directory / n).is_file() and sha256(directory / n) != d
    ]
    manifest_file = directory / "manifest.json"
    if manifest_file.is_file() and sha256(manifest_file) != sha256(
        SUITES[suite] / "manifest.json"
    ):
        changed.append("manifest.json")
    missing = [n for n in files if Path(n).suffix in present and not (directory / n).is_file()]
    return changed + missing


def _pinned_files(suite: int = CONFORMANCE_VERSION) -> dict[str, str]:
    """Every case file of a version of the suite: ``{file name: sha256}``."""
    cases = _pinned_manifest(suite)["cases"]
    return {name: digest for e in cases for name, digest in e["files"].items()}


def check_pinned(path: str | os.PathLike, case: Case) -> None:
    """Refuse a case file that says it is one of the pinned suite's but is not its bytes.

    A file whose ``case`` and ``conformance_version`` name a case of this suite must have
    the sha256 the manifest pins for that case in its format: a copy whose expected outputs
    were changed (same name, same version) is no conformance case.

    Parameters
    ----------
    path : path-like
        The case file.
    case : Case
        What it holds (:func:`~skf_ref.conformance.read_case`).

    Raises
    ------
    skf_ref.InputError
        The file claims a pinned case and its sha256 is not the pinned one.
    """
    version = case.conformance_version
    if version not in SUITES:
        return  # another version of the suite: not pinned in this package
    path = Path(path)
    pinned = _pinned_files(version).get(f"{case.name}{path.suffix}")
    if pinned is not None and sha256(path) != pinned:
        raise InputError(
            f"{path} says it is case {case.name!r} of conformance suite version "
            f"{version}, but it is not the suite's file (its sha256 differs from "
            "the pinned one): it was changed. Export the suite again (skf-ref conformance "
            "export DIR) and compare with its file"
        )


def _runner_destinations(directory: Path) -> list[tuple[Path, Path]]:
    """Where each runner goes: its own name, or beside a copy the user edited."""
    plan = []
    for runner in RUNNERS:
        shipped = sha256(runner)
        destination = directory / runner.name
        if destination.is_dir() or destination.is_file() and sha256(destination) != shipped:
            beside = directory / f"{runner.stem}_shipped{runner.suffix}"
            if beside.exists() and (not beside.is_file() or sha256(beside) != shipped):
                raise InputError(
                    f"{destination} and {beside} both differ from the {runner.name} of this "
                    "skf_ref (edited?): neither is replaced; move one of them away"
                )
            destination = beside
        plan.append((runner, destination))
    return plan


def export(
    directory: str | os.PathLike,
    formats: Sequence[str] = FORMATS,
    suite: int = CONFORMANCE_VERSION,
    overwrite: bool = False,
) -> list[Path]:
    """Copy the suite's files in ``formats``, its manifest and the runners to ``directory``.

    The case files and ``manifest.json`` are the pinned ones, byte for byte: the manifest
    lists every file of the suite (both formats) with its sha256. A file of ``directory``
    named like one of them that holds other bytes (a file of the user's, another suite's)
    is replaced only with ``overwrite=True``; one that holds the same bytes (an earlier
    export) stays. A runner already in ``directory`` that differs from the one this package
    ships (one the user adapted, as its docstring invites) is never replaced: the shipped
    one is written beside it as ``run_cases_shipped.py`` (or ``.m``), with a warning.

    Parameters
    ----------
    directory : path-like
        Created if missing.
    formats : sequence of {"npz", "mat"}
    suite : int
        The suite version (``SUITES``): this version's by default; ``2`` or ``3`` copies
        that version's files, byte for byte as earlier packages exported them.
    overwrite : bool
        Replace the files named like the suite's cases and manifest that hold other
        bytes. False: they are refused before anything is written, naming them.

    Returns
    -------
    list of Path
        The case files copied, then the runners, then ``manifest.json``.

    Raises
    ------
    skf_ref.InputError
        ``directory`` is a file; an unknown format; a runner and its ``_shipped`` copy
        both edited; without ``overwrite``, a file named like a case or the manifest
        that holds other bytes (nothing is written).

    Examples
    --------
    >>> import tempfile
    >>> written = export(tempfile.mkdtemp(), formats=["mat"])
    >>> [path.name for path in written][:2], written[-1].name
    (['original_skf.mat', 'free_orientation.mat'], 'manifest.json')
    """
    formats, suite = _checked_formats(formats), _checked_suite(suite)
    directory = check_path("directory", directory)
    check_instance("overwrite", overwrite, bool, "True or False")
    if directory.exists() and not directory.is_dir():
        raise InputError(f"{directory} is a file: give a folder (made if missing)")
    names = [f"{e['name']}.{fmt}" for e in _pinned_manifest(suite)["cases"] for fmt in formats]
    runners = _runner_destinations(directory)
    folder = SUITES[suite]
    plan = [(folder / name, directory / name) for name in names]
    plan += [*runners, (folder / "manifest.json", directory / "manifest.json")]
    same = {destination for source, destination in plan if _holds(destination, source)}
    others = [
        destination
        for _, destination in plan
        if destination not in same and (destination.exists() or destination.is_symlink())
    ]
    if others and not overwrite:
        listed = ", ".join(path.name for path in others[:5])
        raise InputError(
            f"{directory} holds {len(others)} file(s) named like the suite's but with other "
            f"contents ({listed}{', ...' if len(others) > 5 else ''}): nothing is written; "
            "give overwrite=True to replace them, or export to another folder"
        )
    directory.mkdir(parents=True, exist_ok=True)
    for source, destination in plan:
        if destination in same:
            continue  # the suite's very bytes already: nothing to replace
        # a file that appears meanwhile is replaced only when overwrite says so
        with atomic_path(destination, overwrite=overwrite) as tmp:
            shutil.copyfile(source, tmp)
    for runner, destination in runners:
        if destination.name != runner.name:
            warnings.warn(
                f"{directory / runner.name} differs from the runner this skf_ref ships (your "
                f"version?): kept as it is; the shipped one is {destination}",
                UserWarning,
                stacklevel=2,
            )
    return [destination for _, destination in plan]


def _holds(destination: Path, source: Path) -> bool:
    """Whether ``destination`` is a file with the bytes of ``source``."""
    return destination.is_file() and sha256(destination) == sha256(source)


def _checked_formats(formats):
    for fmt in formats:
        check_choice("format", fmt, FORMATS)
    formats = [fmt for fmt in FORMATS if fmt in formats]  # the same files in any order given
    if not formats:
        raise InputError(f"formats must name at least one of {list(FORMATS)}, got none")
    return formats


def build(directory: str | os.PathLike, formats: Sequence[str] = FORMATS) -> list[Path]:
    """Compute every case afresh and write a suite: how a new suite version is made.

    Writes ``generate``'s cases in each format and their
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
    directory = check_path("directory", directory)
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
            "intermediates": list(case.intermediates),
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
        "tolerance_means": "largest |theirs - expected| at a step over the output's own scale "
        "(largest |expected|; the log-likelihood's: the sum of the sizes of its terms)",
        "float32_tolerance": FLOAT32_TOLERANCE,
        "layout": {
            "L": "(n_channels, n_sources)",
            "Y": "(n_channels, n_times); column t is y_t",
            "noise_cov, theta0, q, transition": "a scalar c means c times the identity",
            "noise_cov": "the noise covariance R: a scalar c is R = c I, a variance (not sigma)",
            "smoother": "text: none, rts-standardized, rts-state or rts-smoothed-weights",
            "standardize": "text: column (each source on its own) or position (n_orient "
            "columns of a position as a whole, MNE's order)",
            "n_orient": "an integer, 1 or 3: the columns of a position",
            "z, z_filtered, x, x_filtered, weights": "(n_sources, n_times)",
            "log_likelihood": "a scalar",
            "x_pred, P_pred, S, K, P_filt, w, G, P_smooth, Sigma, w_smooth": "the expected "
            "intermediates (cases of at most 50 steps; those of the case's smoother): time "
            "last, P_pred is (n_sources, n_sources, n_times), G has n_times - 1 steps",
        },
        "inputs": [*INPUTS, *OPTIONS],
        "outputs": list(OUTPUTS),
        "documentation": "docs/conformance.md of the skf_ref repository",
    }
