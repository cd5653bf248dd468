"""The SKF over MNE-BIDS-pipeline's derivatives: a source estimate beside each evoked.

MNE-BIDS-pipeline (1.10: its steps ``sensor/_01_make_evoked``, ``sensor/_06_make_cov``,
``source/_04_make_forward`` and ``source/_05_make_inverse``) writes, for each subject (and
session), in ``DERIVATIVES_ROOT/sub-XX/[ses-YY/]{meg,eeg}/``:

- ``sub-XX[_ses-YY]_task-TASK_ave.fif``: the evokeds of one task, one per condition and
  contrast, each named by its ``comment``;
- ``sub-XX[_ses-YY]_fwd.fif``: the forward, one for every task (earlier versions named it
  with the task: ``sub-XX_task-TASK_fwd.fif``, taken too);
- ``sub-XX[_ses-YY][_task-noise|rest]_proc-{clean,custom,adhoc}_cov.fif``: the noise
  covariance, with the rank the pipeline uses beside it (``..._rank.json``);

(other entities, ``acq-``, ``rec-``, ``space-``, in the names as the pipeline's configuration
sets them; the group average's folder ``sub-average/``, with the grand-average evoked only,
is left out) and beside each evoked its inverse solutions,
``sub-XX[_ses-YY]_task-TASK_COND+dSPM+hemi.h5`` (``COND`` the condition without ``/``,
``_``, ``-`` or spaces; ``dSPM`` the method). :func:`apply_skf_bids` writes
``sub-XX[_ses-YY]_task-TASK_COND+SKF+hemi.h5`` there, MNE's HDF5 source estimate, and
``...+SKF+hemi.json`` beside it with the settings, the inputs and the versions. It makes
one operator per subject folder (:func:`~skf_ref.io._make_operator.make_skf_operator`, with
the pipeline's rank) and applies it to every condition
(:func:`~skf_ref.io._apply.apply_skf`), as the pipeline makes one inverse operator and
applies it.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._utils.atomic_files import atomic_path
from .._utils.checks import InputError, InputTypeError, check_path, describe
from .._utils.extras import optional
from .._utils.log import logger, verbosity
from .._utils.parallel import check_n_jobs, plan_jobs, run_jobs

__all__ = ["DATATYPES", "METHOD", "apply_skf_bids", "find_derivatives", "output_name"]

#: The datatype folders the pipeline writes to.
DATATYPES = ("meg", "eeg")
#: The pipeline's group folder (``sensor/_99_group_average`` writes the grand-average
#: evoked there): no forward, the pipeline makes no inverse there, and it is left out
#: unless ``subjects`` names it.
GROUP = "sub-average"
#: The method's name in the outputs' names, where the pipeline writes ``dSPM``, ``MNE``...
METHOD = "SKF"

_ENTITY = re.compile(r"^([a-zA-Z0-9]+)-([a-zA-Z0-9+]+)$")


def _entities(path: Path) -> tuple[dict[str, str], str] | None:
    """A BIDS name's entities (in order) and suffix: ``sub-01_task-x_ave.fif`` ->
    ``({"sub": "01", "task": "x"}, "ave")``; None for another name."""
    name = path.name
    if not name.endswith(".fif"):
        return None
    *parts, suffix = name[: -len(".fif")].split("_")
    entities = {}
    for part in parts:
        match = _ENTITY.match(part)
        if match is None or match[1] in entities:
            return None
        entities[match[1]] = match[2]
    return (entities, suffix) if parts and "sub" in entities else None


def _without(entities: dict[str, str], *names: str) -> dict[str, str]:
    return {k: v for k, v in entities.items() if k not in names}


@dataclass
class Folder:
    """One subject's (and session's) datatype folder of the derivatives: what it holds.

    Attributes
    ----------
    path : Path
        ``sub-XX/[ses-YY/]{meg,eeg}``.
    evokeds : list of Path
        Every ``*_ave.fif`` in it.
    forwards, covariances : dict
        ``{evoked: forward}`` and ``{evoked: noise covariance}``.
    """

    path: Path
    evokeds: list[Path] = field(default_factory=list)
    forwards: dict[Path, Path] = field(default_factory=dict)
    covariances: dict[Path, Path] = field(default_factory=dict)


def _match(evoked: Path, candidates: list[Path], kind: str, choose: str | None) -> Path:
    """The forward (``kind="fwd"``) or noise covariance (``"cov"``) of an evoked.

    A forward has the evoked's entities without the task (the pipeline since 1.5) or with
    it (before). A covariance has them without the task and the processing, with an
    optional task of its own (``noise``, ``rest``) and processing (``clean``...): among
    several, ``choose`` (a part of the name) picks one.
    """
    entities = _entities(evoked)
    assert entities is not None
    mine = _without(entities[0], "task")
    found = []
    for path in candidates:
        theirs = _entities(path)
        if theirs is None:
            continue
        if kind == "fwd" and theirs[0] in (mine, entities[0]):
            found.append(path)
        if kind == "cov" and _without(theirs[0], "task", "proc") == mine:
            found.append(path)
    if kind == "cov" and choose is not None:
        found = [path for path in found if choose in path.name]
    what = "forward (*_fwd.fif)" if kind == "fwd" else "noise covariance (*_cov.fif)"
    if not found:
        also = f" whose name holds {choose!r}" if kind == "cov" and choose else ""
        raise InputError(f"{evoked}: no {what}{also} for it in {evoked.parent}")
    if len(found) > 1:
        names = ", ".join(sorted(path.name for path in found))
        hint = (
            ": give noise_cov=PART (--noise-cov PART) to take the one whose name holds PART, "
            "e.g. 'proc-clean' or 'task-noise'"
            if kind == "cov"
            else ""
        )
        raise InputError(f"{evoked}: {len(found)} {what} files fit it: {names}{hint}")
    return found[0]


def find_derivatives(
    root: str | os.PathLike[str],
    subjects: list[str] | None = None,
    noise_cov: str | None = None,
) -> list[Folder]:
    """The subject folders of MNE-BIDS-pipeline's derivatives, each evoked's inputs found.

    Parameters
    ----------
    root : path-like
        The pipeline's ``deriv_root`` (by default ``BIDS_ROOT/derivatives/mne-bids-pipeline``).
    subjects : list of str, optional
        The subjects to take, as the pipeline's configuration names them (``"01"``);
        default every ``sub-*`` folder but the group average's, ``sub-average``.
    noise_cov : str, optional
        Where a folder holds several noise covariances that fit: a part of the name of the
        one to take (``"proc-clean"``, ``"task-noise"``).

    Returns
    -------
    list of Folder
        Sorted by path; each with at least one evoked, and its forward and covariance.

    Raises
    ------
    skf_ref.InputError
        ``root`` is not a folder, holds no evoked, names no such subject, or an evoked has
        no forward or noise covariance (or several that fit).

    Examples
    --------
    >>> find_derivatives("no/such/folder")
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: root: no/such/folder is not a folder
    """
    root = check_path("root", root)
    if not root.is_dir():
        raise InputError(f"root: {root} is not a folder")
    if subjects is not None:
        if isinstance(subjects, str) or not all(isinstance(s, str) for s in subjects):
            raise InputTypeError(
                f"subjects must be a list of subject labels such as ['01'], got "
                f"{describe(subjects)}"
            )
        missing = [s for s in subjects if not (root / f"sub-{s}").is_dir()]
        if missing:
            raise InputError(f"subjects: {root} has no folder sub-{missing[0]}")
    if noise_cov is not None and not isinstance(noise_cov, str):
        raise InputTypeError(f"noise_cov must be a part of a file name, got {describe(noise_cov)}")
    chosen = None if subjects is None else {f"sub-{s}" for s in subjects}
    folders = []
    for subject in sorted(root.glob("sub-*")):
        if not subject.is_dir() or (chosen is not None and subject.name not in chosen):
            continue
        if chosen is None and subject.name == GROUP:
            continue  # the group average: no forward, and the pipeline no inverse, there
        levels = [subject, *sorted(p for p in subject.glob("ses-*") if p.is_dir())]
        for level in levels:
            for datatype in DATATYPES:
                folder = _folder(level / datatype, noise_cov)
                if folder is not None:
                    folders.append(folder)
    if not folders:
        raise InputError(
            f"root: {root} holds no evoked of MNE-BIDS-pipeline's derivatives "
            f"(sub-*/[ses-*/]{{{','.join(DATATYPES)}}}/sub-*_ave.fif): give the pipeline's "
            "deriv_root"
        )
    return folders


def _folder(path: Path, noise_cov: str | None) -> Folder | None:
    if not path.is_dir():
        return None
    evokeds = sorted(p for p in path.glob("sub-*_ave.fif") if _entities(p) is not None)
    if not evokeds:
        return None
    forwards = sorted(path.glob("sub-*_fwd.fif"))
    covariances = sorted(path.glob("sub-*_cov.fif"))
    folder = Folder(path, evokeds)
    for evoked in evokeds:
        folder.forwards[evoked] = _match(evoked, forwards, "fwd", None)
        folder.covariances[evoked] = _match(evoked, covariances, "cov", noise_cov)
    return folder


def sanitize_condition(condition: str) -> str:
    """A condition as the pipeline puts it in a file name (``sanitize_cond_name``).

    Examples
    --------
    >>> sanitize_condition("auditory/left - visual")
    'auditoryleftvisual'
    """
    for character in ("/", "_", "-", " "):
        condition = condition.replace(character, "")
    return condition


def output_name(evoked: str | os.PathLike[str], condition: str) -> Path:
    """The SKF estimate of one condition of an evoked file, named as the pipeline names its
    inverse solutions, with :data:`METHOD` for the method.

    Parameters
    ----------
    evoked : path-like
        ``..._ave.fif``.
    condition : str
        The evoked's ``comment``.

    Returns
    -------
    Path
        Beside the evoked.

    Examples
    --------
    >>> output_name("sub-01/meg/sub-01_task-audvis_ave.fif", "auditory/left").as_posix()
    'sub-01/meg/sub-01_task-audvis_auditoryleft+SKF+hemi.h5'
    """
    evoked = Path(evoked)
    stem = evoked.name[: -len("_ave.fif")]
    return evoked.with_name(f"{stem}_{sanitize_condition(condition)}+{METHOD}+hemi.h5")


def _read_rank(cov: Path) -> Any:
    """The rank the pipeline saved beside the covariance (``..._rank.json``), or None."""
    path = cov.with_name(cov.name[: -len("_cov.fif")] + "_rank.json")
    if not path.is_file():
        return None
    try:
        rank = json.loads(path.read_text("utf-8"))
    except (OSError, ValueError) as err:
        raise InputError(f"{path}: not the pipeline's rank (JSON): {err}") from err
    if not isinstance(rank, dict) or not all(
        isinstance(k, str) and isinstance(v, int) and not isinstance(v, bool)
        for k, v in rank.items()
    ):
        raise InputError(f"{path}: not the pipeline's rank, a dict of channel type to int")
    return rank


def _read(reader: Any, path: Path) -> Any:
    try:
        return reader(path, verbose=False)
    except Exception as err:  # MNE's readers raise several types for a bad file
        raise InputError(f"{path}: MNE cannot read it: {err}") from err


def _referenced(evoked: Any) -> Any:
    """The evoked with the average-reference projector the pipeline gives its EEG before
    its inverse (unless it has one, or carries the average reference already)."""
    from ._channels import has_average_reference_projector

    mne = optional("mne", "mne", "apply_skf_bids")
    eeg = [evoked.ch_names[i] for i in mne.pick_types(evoked.info, meg=False, eeg=True)]
    if not eeg or evoked.info["custom_ref_applied"]:
        return evoked
    if has_average_reference_projector(evoked.info, eeg, "evoked"):
        return evoked
    return evoked.set_eeg_reference("average", projection=True, verbose=False)


def _subject(
    folder: Folder,
    overwrite: bool,
    operator_settings: dict[str, Any],
    settings: dict[str, Any],
    verbose: Any,
) -> tuple[list[Path], list[Path]]:
    """One job: one operator for the folder, an estimate per condition not done yet."""
    mne = optional("mne", "mne", "apply_skf_bids")
    from .._utils.provenance import machine
    from ._apply import apply_skf
    from ._make_operator import make_skf_operator

    written: list[Path] = []
    skipped: list[Path] = []
    operators: list[Any] = []
    with verbosity(verbose):
        for evoked_path in folder.evokeds:
            evokeds = _read(mne.read_evokeds, evoked_path)
            names = [output_name(evoked_path, e.comment or str(k)) for k, e in enumerate(evokeds)]
            twice = sorted({n.name for n in names if names.count(n) > 1})
            if twice:
                raise InputError(
                    f"{evoked_path}: two conditions give the same file name {twice[0]} (the "
                    "pipeline drops '/', '_', '-' and spaces from a condition's name)"
                )
            for evoked, out in zip(evokeds, names, strict=True):
                if out.exists() and not overwrite:
                    skipped.append(out)
                    continue
                evoked = _referenced(evoked)
                forward, cov = folder.forwards[evoked_path], folder.covariances[evoked_path]
                operator = _operator(
                    operators, evoked, forward, cov, operator_settings, make_skf_operator
                )
                stc = apply_skf(evoked, operator, **settings, verbose=False)
                record = {
                    "method": METHOD,
                    "condition": evoked.comment,
                    "nave": evoked.nave,
                    "evoked": evoked_path.name,
                    "forward": forward.name,
                    "noise_cov": cov.name,
                    "rank": _read_rank(cov),
                    **operator_settings,
                    **settings,
                    "operator": repr(operator),
                    "channels": {"used": operator.ch_names, "left_out": operator.dropped},
                    "machine": machine(),
                }
                sidecar = out.with_suffix(".json")
                with atomic_path(sidecar) as tmp:
                    tmp.write_text(json.dumps(record, indent=1, default=str) + "\n", "utf-8")
                # the estimate last: a folder holds it only once everything is written
                with atomic_path(out, overwrite=overwrite) as tmp:
                    stc.save(tmp, ftype="h5", overwrite=True, verbose=False)
                written.append(out)
        logger.info(
            "SKF on %s: %d written, %d there already", folder.path, len(written), len(skipped)
        )
    return written, skipped


def _operator(operators, evoked, forward, cov, operator_settings, make):
    """The folder's operator that fits this evoked's info (made from the first evoked's,
    as the pipeline makes one inverse per subject); another made only if it does not."""
    for operator in operators:
        try:
            operator.check_info(evoked.info, "evoked")
        except InputError:
            continue
        return operator
    mne = optional("mne", "mne", "apply_skf_bids")
    operator = make(
        evoked.info,
        _read(mne.read_forward_solution, forward),
        _read(mne.read_cov, cov),
        **operator_settings,
        rank=_read_rank(cov),
        verbose=False,
    )
    operators.append(operator)
    return operator


def apply_skf_bids(
    root: str | os.PathLike[str],
    *,
    subjects: list[str] | None = None,
    noise_cov: str | None = None,
    pm_snr_db: Any = None,
    ep_snr_db: Any = None,
    time_constant_ms: Any = None,
    exponent: float = 0.5,
    smoother: str | None = "rts-smoothed-weights",
    standardize: str | None = None,
    pick_ori: str | None = None,
    n_jobs: int | None = None,
    overwrite: bool = False,
    verbose: bool | str | int | None = None,
) -> dict[str, list[Path]]:
    """The SKF on every evoked of MNE-BIDS-pipeline's derivatives, beside its inverses.

    For each subject (and session) folder of ``root`` (this module's docstring gives the
    layout): one operator (:func:`skf_ref.make_skf_operator`, from the first evoked's info,
    the folder's forward, noise covariance and the rank the pipeline saved), applied to
    every condition of every ``*_ave.fif`` (:func:`skf_ref.apply_skf`), each estimate
    written beside its evoked as ``..._task-TASK_COND+SKF+hemi.h5`` (MNE's HDF5 source
    estimate, as the pipeline writes ``COND+dSPM+hemi.h5``), with its settings, inputs and
    versions in ``...+SKF+hemi.json``. EEG is given the average-reference projector, as the
    pipeline does before its inverse, unless it has one or carries the average reference.

    An estimate that exists is skipped (``overwrite=True`` computes it again, e.g. with
    other settings): an interrupted run is resumed by running it again, and every file is
    whole or absent (written under a temporary name and renamed; the estimate last, after
    its settings). Subjects run as joblib's jobs: ``n_jobs`` as MNE takes it (1 in this
    process; -1 every core; None, the default, in this process unless a
    ``joblib.parallel_config`` is active: ``with joblib.parallel_config(backend="dask"):``
    sends the subjects to a Dask cluster whose workers see these files).

    Parameters
    ----------
    root : path-like
        The pipeline's ``deriv_root`` (``BIDS_ROOT/derivatives/mne-bids-pipeline``).
    subjects : list of str, optional
        The subjects (``["01", "02"]``, as the pipeline's ``subjects``); default all but
        the group average's ``sub-average``.
    noise_cov : str, optional
        Where a folder holds several noise covariances (the pipeline run with several
        ``noise_cov`` settings): a part of the name of the one to take, e.g.
        ``"proc-clean"`` (the baseline's) or ``"task-noise"`` (the empty room's).
    pm_snr_db, ep_snr_db : float or "auto" or (float, float), optional
        The priors, as :func:`skf_ref.make_skf_operator` takes them; default its own.
    time_constant_ms : float or "auto" or (float, float), optional
        The AR(1) prior's time constant, as :func:`skf_ref.make_skf_operator` takes it;
        default its own (``"auto"`` unless ``ep_snr_db`` is given).
    exponent : float
        As :func:`skf_ref.apply_skf`.
    smoother : {"rts-smoothed-weights", None, "rts-standardized", "rts-state"}
        As :func:`skf_ref.apply_skf`.
    standardize : {"column", "position"}, optional
        As :func:`skf_ref.apply_skf`.
    pick_ori : {None, "vector"}
        As :func:`skf_ref.apply_skf`.
    n_jobs : int or None
        Subjects computed at once (MNE's convention, above).
    overwrite : bool
        Compute and replace estimates that exist.
    verbose : bool or str or int, optional
        The "skf_ref" log's level: each subject folder's count at INFO.

    Returns
    -------
    dict
        ``"written"``: the estimates written, ``"skipped"``: those that existed, lists of
        ``Path`` in the folders' order.

    Raises
    ------
    skf_ref.InputError
        Before any work: ``root`` is not the pipeline's derivatives, or an evoked lacks its
        forward or noise covariance (``find_derivatives``); then anything
        :func:`skf_ref.make_skf_operator` or :func:`skf_ref.apply_skf` refuses, naming the
        file. The subjects finished before stay written.

    Examples
    --------
    >>> apply_skf_bids("no/such/folder")
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: root: no/such/folder is not a folder
    """
    n_jobs = check_n_jobs(n_jobs)
    if not isinstance(overwrite, bool):
        raise InputTypeError(f"overwrite must be True or False, got {describe(overwrite)}")
    with verbosity(verbose):
        folders = find_derivatives(root, subjects, noise_cov)
    operator_settings = {
        k: v
        for k, v in dict(
            pm_snr_db=pm_snr_db, ep_snr_db=ep_snr_db, time_constant_ms=time_constant_ms
        ).items()
        if v is not None
    }
    settings = dict(exponent=exponent, smoother=smoother, standardize=standardize)
    settings["pick_ori"] = pick_ori
    jobs = plan_jobs(n_jobs, "apply_skf_bids")
    calls = [(folder, overwrite, operator_settings, settings, verbose) for folder in folders]
    result: dict[str, list[Path]] = {"written": [], "skipped": []}
    for written, skipped in run_jobs(_subject, calls, jobs):
        result["written"] += written
        result["skipped"] += skipped
    return result
