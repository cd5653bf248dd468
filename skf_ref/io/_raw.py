"""The SKF along a continuous recording, as MNE's ``apply_inverse_raw``.

The filter (and the smoother) runs along every sample of the segment asked for: one
sequence, as the model has it (docs/model.md §1). The samples inside bad segments (``BAD_``
annotations) are missing observations: predicted, not updated, without an estimate (NaN).
Its estimate, n_sources x n_times, grows with the recording; it is returned in memory when
it fits, or streamed to a zarr store one block of rows at a time
(:func:`skf_ref.io._zarr_dask.stc_to_zarr`) when it does not.
"""

import os
from typing import Any

import numpy as np

from .._utils import memory
from .._utils.checks import (
    InputError,
    InputTypeError,
    check_instance,
    check_int,
    check_memory_limit,
    describe,
    path_renamed,
)
from .._utils.extras import optional
from .._utils.log import logger, verbosity
from .._utils.parallel import check_n_jobs, plan_jobs
from ..method._search import check_time_constant
from ..method._units import units_cause, units_mismatch, warn_units
from ._jobs import rows_in_jobs
from ._operator import SKFOperator

__all__ = ["apply_skf_raw"]


@path_renamed
def apply_skf_raw(
    raw: Any,
    operator: SKFOperator,
    start: int = 0,
    stop: int | None = None,
    *,
    exponent: float = 0.5,
    smoother: str | None = "rts-smoothed-weights",
    pick_ori: str | None = None,
    standardize: str | None = None,
    path: str = "auto",
    out: str | os.PathLike[str] | None = None,
    overwrite: bool = False,
    memory_limit: float | None = None,
    return_reconstruction: bool = False,
    reject_by_annotation: bool = True,
    time_constant_ms: Any = None,
    n_jobs: int | None = None,
    verbose: bool | str | int | None = None,
) -> Any:
    """The SKF along a continuous recording, as MNE's ``apply_inverse_raw``.

    The samples from ``start`` to ``stop`` are one sequence: the filter (and smoother) runs
    along all of them. Samples inside bad segments (annotations whose description starts
    with ``"bad"``, as MNE's readers reject them) are missing observations: the filter
    predicts across them without an update, so nothing inside a bad segment reaches the
    estimate elsewhere, and the estimate there is NaN on every smoother (docs/model.md §2);
    samples that are NaN in every channel of the recording itself are missing observations
    too. The log says which segments were skipped, and why. EP-SNR is over that sequence
    (docs/model.md §4: ``q`` is the walk's variance over the ``stop - start`` samples), as
    for an evoked; the stationary AR(1) prior (``time_constant_ms``) does not depend on its
    length. The estimate is returned in memory, or, with ``out``, streamed to a zarr store
    one block of rows at a time: no (n_sources, n_times) array is ever held whole.

    Parameters
    ----------
    raw : mne.io.Raw
    operator : SKFOperator
    start, stop : int, optional
        The first sample and the one after the last (indices, as ``raw.get_data``).
    exponent : float
        As :func:`apply_skf`.
    smoother : {"rts-smoothed-weights", None, "rts-standardized", "rts-state"}
        As :func:`apply_skf`.
    pick_ori : {None, "vector"}
        As :func:`apply_skf`.
    standardize : {"column", "position"}
        As :func:`apply_skf`.
    path : {"auto", "spectral", "dense", "filterpy"}
        As :func:`apply_skf`.
    out : path-like, optional
        A zarr store to create (e.g. ``"run1-skf.zarr"``): its array ``"data"`` holds what
        the source estimate would (positions x times, or positions x 3 x times for
        ``"vector"``), its attributes the vertices, ``tmin``, ``tstep``, the subject and the
        settings. Needs the ``zarr`` extra.
    overwrite : bool
        Replace a store at ``out`` that an earlier call wrote.
    memory_limit : float, optional
        Bytes the estimate may take in memory (default half the memory available);
        without ``out``, a larger one is refused before any work.
    return_reconstruction : bool
        Also return the :class:`skf_ref.Reconstruction` (whitened units; its outputs are
        computed when asked for, in blocks: ``.blocks``, :func:`skf_ref.io.to_zarr`).
    reject_by_annotation : bool
        Make the samples inside ``BAD_`` annotations missing observations (default, as
        MNE's readers); ``False`` filters every sample, bad segments included. The paper's
        smoother, ``"rts-standardized"``, is undefined over missing steps: use
        ``"rts-state"``, no smoother, or ``reject_by_annotation=False``.
    time_constant_ms : float or "auto" or (float, float), optional
        The stationary AR(1) prior (:func:`skf_ref.ar1_priors`) in place of the operator's
        evolution prior, the sampling step from the recording's ``info["sfreq"]``
        (:meth:`skf_ref.SKFOperator.reconstruct`; ``"auto"`` is chosen on the samples from
        ``start`` to ``stop``). Default None: the operator's.
    n_jobs : int or None
        Jobs the rows of the estimate are shared among (MNE's convention: 1 in this
        process, -1 every core; None, the default, in this process unless a
        ``joblib.parallel_config`` is active, e.g. ``backend="dask"``: on a Dask
        cluster). The recording is one sequence and is not cut in time: the filter runs
        here, and the jobs compute the standardization and the sources, each a run of
        whole positions, from its r x T quantities (sent to each job once): the n x T part
        of the work, on the spectral path (the others compute everything at once). With
        ``out``, each job writes its own rows to the store (the jobs must see this
        machine's files: a Dask cluster on a shared disk). This process already runs
        those rows on every core (threads); jobs bring more cores, on a cluster. The
        estimate equals that of one job to rounding.
    verbose : bool or str or int, optional

    Returns
    -------
    stc or zarr.Group
        The source estimate, or with ``out`` the store, open for reading.
    reconstruction : skf_ref.Reconstruction
        Only with ``return_reconstruction=True``.
    """
    mne = optional("mne", "mne", "apply_skf_raw")
    if not isinstance(raw, mne.io.BaseRaw):
        raise InputTypeError(f"raw must be an mne.io.Raw, got {describe(raw)}")
    check_instance("operator", operator, SKFOperator, "an SKFOperator (make_skf_operator)")
    operator.check_pick_ori(pick_ori)
    memory_limit = check_memory_limit(memory_limit)
    check_instance("reject_by_annotation", reject_by_annotation, bool, "True or False")
    n_jobs = check_n_jobs(n_jobs)
    if time_constant_ms is not None:  # refused before the recording is read
        time_constant_ms = check_time_constant(time_constant_ms)
    start = check_int("start", start, minimum=0, maximum=raw.n_times - 1)
    stop = raw.n_times if stop is None else check_int("stop", stop, maximum=raw.n_times)
    if stop <= start:
        raise InputError(f"stop must be > start={start}, got {stop}")
    if out is not None:
        from ._zarr_dask import check_new_store, stc_to_zarr

        check_new_store(out, overwrite)
    n_times, n = stop - start, operator.n_sources
    with verbosity(verbose):
        needed = _raw_picks(raw.info, operator)
        memory.require(8 * len(needed) * n_times, f"{n_times} samples of raw", memory_limit)
        if out is None:
            memory.require(
                8 * 2 * n * n_times,
                f"a source estimate of {n} sources x {n_times} samples in memory (give "
                "out='NAME.zarr' to stream it to disk)",
                memory_limit,
            )
        info = mne.pick_info(raw.info, needed)
        data = raw.get_data(
            picks=needed,
            start=start,
            stop=stop,
            reject_by_annotation="NaN" if reject_by_annotation else None,
            verbose=False,  # the segments skipped are logged below
        )
        annotated = _annotated(raw, needed, start, stop, reject_by_annotation)
        data = _select(operator, info, data, raw.times[start:stop], annotated)
        units = units_mismatch(operator.whitener @ data)  # NaN columns: left out
        warn_units(units)
        with units_cause(units):
            rec = operator.reconstruct(
                data,
                exponent=exponent,
                smoother=smoother,
                path=path,
                memory_limit=memory_limit,
                standardize=standardize,
                time_constant_ms=time_constant_ms,
                sfreq=raw.info["sfreq"],
            )
        tmin, tstep = float(raw.times[start]), 1.0 / raw.info["sfreq"]
        if out is None:
            rows_in_jobs(rec, operator.n_components, plan_jobs(n_jobs, "apply_skf_raw"))
            result = operator.to_stc(rec, tmin, tstep, pick_ori)
        else:
            src = operator.forward["src"]
            result = stc_to_zarr(
                rec, src, out, tmin, tstep, pick_ori, overwrite=overwrite, n_jobs=n_jobs
            )
    return (result, rec) if return_reconstruction else result


def _annotated(raw, picks, start, stop, reject):
    """The samples from ``start`` to ``stop`` inside bad segments (``BAD_`` annotations),
    as MNE's ``reject_by_annotation`` finds them (read off one channel)."""
    if not reject:
        return np.zeros(stop - start, bool)
    _, kept = raw.get_data(
        picks=picks[:1],
        start=start,
        stop=stop,
        reject_by_annotation="omit",
        return_times=True,
        verbose=False,
    )
    return ~np.isin(raw.times[start:stop], kept)


def _spans(mask, times):
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.view(np.int8), [0]])))
    return [(times[a], times[b - 1]) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _select(operator, info, data, times, annotated):
    """The operator's channels of ``data`` (n_channels, n_times), checked on the samples
    outside bad segments; the samples inside them (NaN in every channel) stay NaN, as do
    the samples the recording itself holds as NaN in every channel (``annotated`` tells
    which are which: the log names each kind for what it is)."""
    missing = np.isnan(data).all(axis=0)
    if not missing.any():
        return operator.select(info, data, "raw")
    gaps = missing & ~annotated  # NaN in the recording itself, no annotation
    if missing.all():
        why = (
            "lies in a bad segment (BAD_ annotations): nothing to reconstruct; give "
            "reject_by_annotation=False to use them"
            if not gaps.any()
            else "is NaN in every channel"
            + (" or lies in a bad segment (BAD_ annotations)" if annotated.any() else "")
            + ": nothing to reconstruct"
        )
        raise InputError(f"every sample from start to stop {why}")
    for kind, mask in (
        ("bad segment(s) (BAD_ annotations)", missing & annotated),
        ("gap(s) of NaN in every channel of the recording (no annotation)", gaps),
    ):
        if not mask.any():
            continue
        segments = _spans(mask, times)
        logger.info(
            "    %d %s skipped as missing observations, %d of %d samples, no estimate there: %s",
            len(segments),
            kind,
            np.count_nonzero(mask),
            len(mask),
            ", ".join(f"{a:.3f}-{b:.3f} s" for a, b in segments),
        )
    picked = np.full((len(operator.ch_names), len(missing)), np.nan)
    picked[:, ~missing] = operator.select(info, data[:, ~missing], "raw")
    return picked


def _raw_picks(info, operator):
    """Indices of the operator's channels and of every EEG channel (the reference check)."""
    mne = optional("mne", "mne", "apply_skf_raw")
    eeg = mne.pick_types(info, meg=False, eeg=True, exclude=[]) if operator.eeg_names else []
    used = [info.ch_names.index(c) for c in operator.ch_names if c in info.ch_names]
    return sorted(set(used) | set(int(i) for i in eeg))
