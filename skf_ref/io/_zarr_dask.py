"""Outputs beyond memory: streamed to a zarr store, or computed by a Dask cluster.

Every row of every spectral output depends on that row of ``V`` and on r x T quantities only
(the reconstruction's ``lazy_outputs``), so an output never has to exist whole: :func:`to_zarr`
writes it block of rows by block, :func:`to_dask` hands the blocks to Dask. Outputs of the other
paths, held in memory already, are cut into the same blocks. zarr and Dask are optional: from the
source tree, ``python -m pip install ".[zarr]"`` or ``".[dask]"``.
"""

from __future__ import annotations

import collections
import collections.abc
import contextlib
import os
import secrets
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from .._utils.atomic_files import rename_noreplace, stale_temporaries, temporary_prefix
from .._utils.checks import (
    InputError,
    InputTypeError,
    check_choice,
    check_instance,
    check_int,
    check_path,
    describe,
)
from .._utils.extras import optional
from .._utils.parallel import plan_jobs, run_jobs
from ..method import Reconstruction, amplitude_from_components
from ..method._outputs import ARRAYS as NAMES
from ._stc import stc_layout

__all__ = [
    "BLOCK_BYTES",
    "STORE_MARK",
    "STORE_SUFFIX",
    "TIME_CHUNK_BYTES",
    "WRITE_BEHIND_BYTES",
    "check_new_store",
    "new_store",
    "stc_to_zarr",
    "to_dask",
    "to_zarr",
]

#: Default size of one zarr chunk or Dask block (one block of rows): Dask's own advice is
#: blocks of tens to hundreds of MiB. Smaller outputs are one chunk of their own size.
BLOCK_BYTES = 64 * 2**20
#: Blocks computed but not yet written to disk (:func:`to_zarr` writes on a thread of its
#: own while the next blocks are computed): at most this many bytes.
WRITE_BEHIND_BYTES = 128 * 2**20
#: Bytes of one chunk of a source estimate's store (:func:`stc_to_zarr`): a shard per
#: block of rows, cut in time, so that a span of time reads about this much per block.
TIME_CHUNK_BYTES = 2**20
#: The attribute that marks a store as written by this package: ``"writing"`` until every
#: array is whole, then ``"complete"``. Only a store so marked is ever replaced.
STORE_MARK = "skf_ref_store"
#: The extension of a store's name: the extension decides the format.
STORE_SUFFIX = ".zarr"
_STORE_ID = "skf_ref_store_id"  # each store's own: overwrite replaces only the store checked


def _check_reconstruction(reconstruction: Any, path: Any) -> None:
    """The arguments of a writer, each of its kind (swapped ones named as such)."""
    check_path("path", path)
    check_instance("reconstruction", reconstruction, Reconstruction, "an skf_ref.Reconstruction")


def _rows_per_block(reconstruction, chunks, multiple=1):
    """Rows per chunk: ``chunks``, or about :data:`BLOCK_BYTES`; never more than the rows
    there are, and a multiple of ``multiple`` (the rows of one source position)."""
    n = reconstruction.n_sources
    if chunks is None:
        chunks = max(1, BLOCK_BYTES // (8 * reconstruction.n_times))
    else:
        chunks = check_int("chunks", chunks, minimum=1)
    return max(multiple, min(chunks, n) // multiple * multiple)


def _check_names(arrays):
    if isinstance(arrays, str) or not isinstance(arrays, collections.abc.Iterable):
        raise InputTypeError(
            f"arrays must be a sequence of output names such as ('z', 'weights'), got "
            f"{describe(arrays)}"
        )
    names = [check_choice("arrays", name, NAMES) for name in arrays]
    if not names:
        raise InputError("arrays must name at least one output")
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise InputError(f"arrays must name each output once, got {twice} more than once")
    return names


def _mark(path: Path) -> tuple[str | None, str | None]:
    """The :data:`STORE_MARK` and the id of the zarr store at ``path`` (None if none)."""
    zarr = optional("zarr", "zarr", "to_zarr")
    try:
        attrs = zarr.open_group(path, mode="r").attrs
    except Exception:  # not a zarr group (a folder of the user's, a file): zarr's own errors
        return None, None
    return attrs.get(STORE_MARK), attrs.get(_STORE_ID)


def _clean_up(path: Path) -> None:
    """Finish or remove what a killed writer of ``path`` left: a complete new store goes in
    place when ``path`` is missing, else an old one comes back; the rest is deleted."""
    for kind in ("tmp", "old"):
        for leftover in stale_temporaries(path, kind):
            mark, _ = _mark(leftover)
            if leftover.is_symlink() or not leftover.is_dir():
                continue  # not ours after all: never delete it
            if mark is None and any(leftover.iterdir()):
                continue
            if mark == "complete":
                with contextlib.suppress(FileExistsError):
                    rename_noreplace(leftover, path)
                    continue
            shutil.rmtree(leftover, ignore_errors=True)


def check_new_store(
    path: str | os.PathLike, overwrite: bool = False, name: str = "path"
) -> str | None:
    """Refuse, before any work, a store that :func:`new_store` could not write at ``path``.

    Also finishes or removes what a killed writer of ``path`` left.

    Parameters
    ----------
    path : path-like
        The store to create: a name ending in ``.zarr`` (the extension decides the format).
    overwrite : bool
        Whether a store this package wrote at ``path`` may be replaced.
    name : str
        The parameter, for messages (``"out"``).

    Returns
    -------
    str or None
        The id of the store that ``overwrite`` would replace; None if ``path`` is free.

    Raises
    ------
    skf_ref.InputError
        Another extension, a missing folder, an existing ``path`` without ``overwrite``, or
        anything at ``path`` that is not a complete store this package wrote.
    """
    optional("zarr", "zarr", "writing a zarr store")
    path = check_path(name, path)
    if path.suffix != STORE_SUFFIX:
        raise InputError(
            f"{path}: a zarr store (a folder) is written to a name ending in .zarr, got "
            f"{path.suffix or 'no extension'!r}: the extension decides the format"
        )
    if not path.parent.is_dir():
        raise InputError(f"{path}: the folder {path.parent} does not exist")
    _clean_up(path)
    if not (path.exists() or path.is_symlink()):
        return None
    if not overwrite:
        raise InputError(f"{path} exists: give overwrite=True to replace it")
    mark, identity = _mark(path)
    if path.is_symlink() or not path.is_dir() or mark != "complete":
        raise InputError(
            f"{path} exists and is not a store written by skf_ref: it is never replaced; "
            "remove it yourself or choose another path"
        )
    return identity or ""


def _publish(tmp: Path, path: Path, replaced: str | None) -> None:
    """Rename the whole store ``tmp`` to ``path``, replacing only the store ``replaced``.

    Renames never replace (:func:`~skf_ref._utils.atomic_files.rename_noreplace`): what
    appeared at ``path`` while ``tmp`` was written (a folder of the user's, the store of
    another process) stays, and this store is refused; a store to replace is first set
    aside, and put back unless it is the very store checked before the work.
    """
    old = None
    if replaced is not None:
        old = path.with_name(temporary_prefix(path, "old") + secrets.token_hex(4))
        try:
            rename_noreplace(path, old)
        except FileNotFoundError:  # removed meanwhile: nothing to replace
            old = None
        if old is not None and (old.is_symlink() or _mark(old) != ("complete", replaced or None)):
            with contextlib.suppress(FileExistsError):
                rename_noreplace(old, path)
                old = None
            raise InputError(
                f"{path} changed while this store was written (another process?): it is left "
                "as it is" + (f" (set aside as {old})" if old else "") + "; this store is not "
                "kept: write it again, or to another path"
            )
    try:
        rename_noreplace(tmp, path)
    except FileExistsError:
        raise InputError(
            f"{path} appeared while this store was written (another process?): it is left as "
            "it is and this store is not kept: write it again, or to another path"
        ) from None
    finally:
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)


@contextlib.contextmanager
def new_store(
    path: str | os.PathLike, overwrite: bool = False, attributes: dict | None = None
) -> Iterator[Any]:
    """A zarr group written under a hidden temporary name, renamed to ``path`` when whole.

    The store is marked (:data:`STORE_MARK`, with an id of its own) as this package's, so
    that ``overwrite`` may replace it later; nothing else is ever deleted. The rename
    never replaces anything: of two processes writing the same ``path``, one wins and the
    other gets an error (what appeared at ``path`` meanwhile stays as it is). If the block
    raises, the temporary goes; if the process is killed, the next call for the same
    ``path`` finishes or removes what it left.

    Parameters
    ----------
    path : path-like
        The store to create, ending in ``.zarr``.
    overwrite : bool
        Replace a store this package wrote at ``path``.
    attributes : dict, optional
        The group's attributes.

    Yields
    ------
    zarr.Group
        Open for writing.
    """
    zarr = optional("zarr", "zarr", "to_zarr")
    path = check_path("path", path)
    replaced = check_new_store(path, overwrite)
    try:
        tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=temporary_prefix(path)))
    except OSError as err:
        raise InputError(f"{path}: cannot write in {path.parent}: {err.strerror}") from err
    try:
        group = zarr.open_group(tmp, mode="w")
        identity = secrets.token_hex(8)
        group.attrs.update({**(attributes or {}), STORE_MARK: "writing", _STORE_ID: identity})
        yield group
        group.attrs[STORE_MARK] = "complete"
        _publish(tmp, path, replaced)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def to_zarr(
    reconstruction: Reconstruction,
    path: str | os.PathLike,
    arrays: Sequence[str] = ("z",),
    chunks: int | None = None,
    overwrite: bool = False,
) -> Any:
    """Write outputs to a zarr store (a folder), one block of rows at a time.

    No output is held whole: memory is the r x T quantities, the block being computed and
    at most ``WRITE_BEHIND_BYTES`` (128 MiB) of blocks waiting for the disk. The store is
    written under a temporary name beside ``path`` and renamed when complete
    (``new_store``), so an interruption leaves no half-written store.

    Parameters
    ----------
    reconstruction : skf_ref.Reconstruction
    path : path-like
        The store to create, e.g. ``"skf.zarr"``.
    arrays : sequence of str
        Outputs to write, each an array (n_sources, n_times) of the store:
        ``"z"``, ``"x"``, ``"z_filtered"``, ``"x_filtered"``, ``"weights"``.
    chunks : int, optional
        Rows per zarr chunk (and per block computed); default about 64 MiB a chunk, and
        never more rows than the output has.
    overwrite : bool
        Replace a store at ``path`` that this function wrote (never anything else).

    Returns
    -------
    zarr.Group
        The store, opened for reading; its attributes hold the reconstruction's settings.
    """
    zarr = optional("zarr", "zarr", "to_zarr")
    _check_reconstruction(reconstruction, path)
    names = _check_names(arrays)
    step = _rows_per_block(reconstruction, chunks)
    shape = (reconstruction.n_sources, reconstruction.n_times)
    settings = {**reconstruction.settings, "log_likelihood": reconstruction.log_likelihood}
    with new_store(path, overwrite, settings) as group:
        for name in names:
            # uncompressed: estimates in float64 hardly compress, and writing is the bound
            array = group.create_array(
                name, shape=shape, chunks=(step, shape[1]), dtype="f8", **_checked_chunks()
            )
            _write_behind(reconstruction.blocks(name, rows=step), array.__setitem__)
    return zarr.open_group(path, mode="r")


def stc_to_zarr(
    reconstruction: Reconstruction,
    src: Any,
    path: str | os.PathLike,
    tmin: float,
    tstep: float,
    pick_ori: str | None = None,
    overwrite: bool = False,
    n_jobs: int | None = None,
) -> Any:
    """Write what :func:`skf_ref.io.make_stc` would hold to a zarr store, block by block.

    An estimate of any length, without ever holding it whole: the rows come one block at a
    time.

    Parameters
    ----------
    reconstruction : skf_ref.Reconstruction
    src : mne.SourceSpaces
    path : path-like
        The store to create.
    tmin, tstep : float
        Seconds.
    pick_ori : {None, "vector"}
    overwrite : bool
        Replace a store this package wrote at ``path``.
    n_jobs : int or None
        Jobs the rows are shared among, as MNE takes it (1: this process; None, the
        default: this process unless a ``joblib.parallel_config`` is active), each a run
        of whole shards that it computes and writes to the store itself: the jobs must
        see this machine's files. Used when the outputs are computed on demand (the
        spectral path); the store holds the same numbers to rounding.

    Returns
    -------
    zarr.Group
        Open for reading: the array ``"data"`` (n_positions, n_times), or (n_positions,
        3, n_times) for ``"vector"``, one shard per block of rows in chunks of about
        ``TIME_CHUNK_BYTES`` (1 MiB) along time, each chunk with its CRC-32C checksum;
        attributes ``vertices`` (one list per
        source space), ``tmin``, ``tstep``, ``subject``, ``stc_class`` (MNE's class) and
        the settings. :func:`skf_ref.read_skf_stream` reads it back as a source estimate.
    """
    zarr = optional("zarr", "zarr", "stc_to_zarr")
    _check_reconstruction(reconstruction, path)
    layout = stc_layout(reconstruction.n_sources, src, pick_ori)
    k = layout.components
    n_positions, T = reconstruction.n_sources // k, reconstruction.n_times
    step = _rows_per_block(reconstruction, None, multiple=k)
    shape = (n_positions, 3, T) if pick_ori == "vector" else (n_positions, T)
    attributes = {
        **reconstruction.settings,
        "log_likelihood": reconstruction.log_likelihood,
        "vertices": [v.tolist() for v in layout.vertices],
        "tmin": float(tmin),
        "tstep": float(tstep),
        "subject": layout.subject,
        "stc_class": layout.class_name,
    }

    jobs = plan_jobs(n_jobs, "stc_to_zarr")
    # one shard (one file) per block of rows, cut in time into chunks of about
    # TIME_CHUNK_BYTES: a span of time is read without reading the rest (read_skf_stream)
    per_sample = step // k * int(np.prod(shape[1:-1]))  # values of one sample in a shard
    times = max(1, min(T, TIME_CHUNK_BYTES // (8 * per_sample)))
    chunks = (step // k, *shape[1:-1], times)
    shards = (step // k, *shape[1:-1], -(-T // times) * times)
    with new_store(path, overwrite, attributes) as group:
        array = group.create_array(
            "data", shape=shape, chunks=chunks, shards=shards, dtype="f8", **_checked_chunks()
        )
        if jobs.local or reconstruction.lazy_outputs is None or reconstruction.computed("z"):
            blocks = reconstruction.blocks("z", rows=step)
            rows = (_stc_rows(where, block, k, pick_ori) for where, block in blocks)
            _write_behind(rows, array.__setitem__)
        else:
            _write_in_jobs(reconstruction, array, step, k, pick_ori, jobs)
    return zarr.open_group(path, mode="r")


def _stc_rows(where: slice, block: Any, k: int, pick_ori: str | None) -> tuple[slice, Any]:
    """Rows ``where`` of ``z`` as the rows of positions of a source estimate's array."""
    positions = slice(where.start // k, where.stop // k)
    if pick_ori == "vector":
        return positions, block.reshape(-1, 3, block.shape[-1])
    if k == 3:
        return positions, amplitude_from_components(block, 3)
    return positions, block


def _write_part(reconstruction, array, blocks, shared, k, pick_ori):
    """One job's shards: each block of rows computed, then written to the store."""
    for where in blocks:
        positions, rows = _stc_rows(where, reconstruction._block("z", where, shared), k, pick_ori)
        array[positions] = rows


def _write_in_jobs(reconstruction, array, step, k, pick_ori, jobs):
    """Every shard of ``array`` (``step`` rows of ``z`` each) computed and written by the
    jobs, one run of consecutive shards per job; the paper's smoother's correction, which
    every block needs, computed here once."""
    n = reconstruction.n_sources
    shards = [slice(start, min(start + step, n)) for start in range(0, n, step)]
    shared = reconstruction._shared("z")
    parts = [p for p in np.array_split(np.arange(len(shards)), jobs.count) if len(p)]
    calls = [
        (reconstruction, array, [shards[i] for i in part], shared, k, pick_ori) for part in parts
    ]
    for _ in run_jobs(_write_part, calls, jobs):
        pass


def _checked_chunks() -> dict[str, Any]:
    """How every array of a store is written: each chunk with its checksum, every chunk.

    Uncompressed (estimates in float64 hardly compress, and writing is the bound), each
    chunk followed by its CRC-32C (zarr's ``crc32c`` codec: a reader checks it, so a byte
    changed or a chunk cut short is an error, never other numbers); every chunk written,
    even one equal to the fill value, so that a missing chunk is always a missing file;
    and NaN as the fill value, so that zarr reads a missing chunk as "no estimate", never
    as zeros ("no activity"). :func:`skf_ref.read_skf_stream` refuses a missing chunk.
    """
    from zarr.codecs import Crc32cCodec

    return dict(
        compressors=[Crc32cCodec()],
        fill_value=np.nan,
        config={"write_empty_chunks": True},
    )


def _write_behind(blocks, write, limit=WRITE_BEHIND_BYTES):
    """``write(rows, block)`` for each of ``blocks`` on a writer thread, so that the disk
    writes while the next blocks are computed; at most ``limit`` bytes wait to be written.
    Returns when every block is written; an interruption cancels the writes not started."""
    pending: collections.deque = collections.deque()
    waiting = 0
    with ThreadPoolExecutor(1) as writer:
        try:
            for rows, block in blocks:
                pending.append((writer.submit(write, rows, block), block.nbytes))
                waiting += block.nbytes
                del block  # the writer's reference is the only one: freed once written
                while pending and (waiting > limit or pending[0][0].done()):
                    done, nbytes = pending.popleft()
                    done.result()
                    waiting -= nbytes
            for done, _ in pending:
                done.result()
        finally:
            writer.shutdown(cancel_futures=True)


def to_dask(reconstruction: Reconstruction, name: str = "z", chunks: int | None = None) -> Any:
    """Output ``name`` as a Dask array of row blocks that a cluster computes.

    The r x T quantities (and ``V``) are one Dask task, so a distributed cluster moves
    them to each worker once, not once per block. For the paper's smoother
    (``"rts-standardized"``) the blocks' projections ``zeta`` are summed first, as tasks
    too, then each block is smoothed: no block is computed on the client.

    Parameters
    ----------
    reconstruction : skf_ref.Reconstruction
    name : {"z", "x", "z_filtered", "x_filtered", "weights"}
    chunks : int, optional
        Rows per block; default about 64 MiB a block.

    Returns
    -------
    dask.array.Array, shape (n_sources, n_times)
    """
    da = optional("dask.array", "dask", "to_dask")
    import dask

    check_choice("name", name, NAMES)
    step = _rows_per_block(reconstruction, chunks)
    outputs = reconstruction.lazy_outputs
    if outputs is None or reconstruction.computed(name):
        return da.from_array(getattr(reconstruction, name), chunks=(step, -1))
    n, T = reconstruction.n_sources, reconstruction.n_times
    slices = [slice(start, min(start + step, n)) for start in range(0, n, step)]
    state = dask.delayed(outputs, name=f"skf-rows-{dask.base.tokenize(id(outputs), n, T)}")
    # what every block needs of the others (the paper's smoother's correction), as tasks
    shares = [dask.delayed(_share)(state, name, where) for where in slices]
    shared = dask.delayed(_combine)(state, name, shares)
    blocks = [
        da.from_delayed(
            dask.delayed(_block)(state, name, where, shared),
            shape=(where.stop - where.start, T),
            dtype=float,
        )
        for where in slices
    ]
    return da.concatenate(blocks, axis=0)


def _share(outputs, name, where):
    return outputs.share(name, where)


def _combine(outputs, name, shares):
    return outputs.combine(name, shares)


def _block(outputs, name, where, shared):
    return outputs.block(name, where, shared)
