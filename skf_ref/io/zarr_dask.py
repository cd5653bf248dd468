"""Outputs beyond memory: streamed to a zarr store, or computed by a Dask cluster.

Every row of every spectral output depends on that row of ``V`` and on r x T quantities only
(:mod:`skf_ref.method.paths.spectral_rows`), so an output never has to exist whole: :func:`to_zarr`
writes it block of rows by block, :func:`to_dask` hands the blocks to Dask. Outputs of the other
paths, held in memory already, are cut into the same blocks. zarr and Dask are optional: ``pip
install "skf_ref[zarr]"`` or ``"skf_ref[dask]"``.
"""

import collections
import contextlib
import shutil
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from .._utils.checks import InputError, check_choice, check_int
from .._utils.extras import optional
from ..method.paths.spectral_rows import NAMES

__all__ = ["BLOCK_BYTES", "WRITE_BEHIND_BYTES", "to_dask", "to_zarr"]

#: Default size of one zarr chunk or Dask block (one block of rows): Dask's own advice is
#: blocks of tens to hundreds of MiB.
BLOCK_BYTES = 64 * 2**20
#: Blocks computed but not yet written to disk (:func:`to_zarr` writes on a thread of its
#: own while the next blocks are computed): at most this many bytes.
WRITE_BEHIND_BYTES = 128 * 2**20


def _rows_per_block(reconstruction, chunks):
    if chunks is None:
        return max(1, BLOCK_BYTES // (8 * reconstruction.n_times))
    return check_int("chunks", chunks, minimum=1)


def to_zarr(reconstruction, path, arrays=("z",), chunks=None, overwrite=False):
    """Write outputs to a zarr store (a folder), one block of rows at a time.

    No output is held whole: memory is the r x T quantities, the block being computed and
    at most :data:`WRITE_BEHIND_BYTES` of blocks waiting for the disk. The store is
    written under a temporary name beside ``path`` and renamed when complete, so an
    interruption leaves no half-written store.

    Parameters
    ----------
    reconstruction : skf_ref.Reconstruction
    path : path-like
        The store to create, e.g. ``"skf.zarr"``.
    arrays : sequence of str
        Outputs to write, each an array (n_sources, n_times) of the store:
        ``"z"``, ``"x"``, ``"z_filtered"``, ``"x_filtered"``, ``"weights"``.
    chunks : int, optional
        Rows per zarr chunk (and per block computed); default about 64 MiB a chunk.
    overwrite : bool
        Replace an existing store at ``path``.

    Returns
    -------
    zarr.Group
        The store, opened for reading; its attributes hold the reconstruction's settings.
    """
    zarr = optional("zarr", "zarr", "to_zarr")
    path = Path(path)
    names = [check_choice("arrays", name, NAMES) for name in arrays]
    if not names:
        raise InputError("arrays must name at least one output")
    step = _rows_per_block(reconstruction, chunks)
    if path.exists() and not overwrite:
        raise InputError(f"{path} exists: give overwrite=True to replace it")
    shape = (reconstruction.n_sources, reconstruction.n_times)
    tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.skf-tmp-"))
    try:
        group = zarr.open_group(tmp, mode="w")
        group.attrs.update(
            {**reconstruction.settings, "log_likelihood": reconstruction.log_likelihood}
        )
        for name in names:
            # uncompressed: estimates in float64 hardly compress, and writing is the bound
            array = group.create_array(
                name, shape=shape, chunks=(step, shape[1]), dtype="f8", compressors=None
            )
            _write_behind(reconstruction.blocks(name, rows=step), array.__setitem__)
        if path.exists():
            shutil.rmtree(path)
        tmp.rename(path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            shutil.rmtree(tmp)
        raise
    return zarr.open_group(path, mode="r")


def _write_behind(blocks, write, limit=WRITE_BEHIND_BYTES):
    """``write(rows, block)`` for each of ``blocks`` on a writer thread, so that the disk
    writes while the next blocks are computed; at most ``limit`` bytes wait to be written.
    Returns when every block is written; an interruption cancels the writes not started."""
    pending, waiting = collections.deque(), 0
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


def to_dask(reconstruction, name="z", chunks=None):
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
    rows = reconstruction.spectral_rows
    if rows is None or reconstruction.computed(name):
        return da.from_array(getattr(reconstruction, name), chunks=(step, -1))
    n, T = reconstruction.n_sources, reconstruction.n_times
    slices = [slice(start, min(start + step, n)) for start in range(0, n, step)]
    state = dask.delayed(rows, name=f"skf-rows-{dask.base.tokenize(id(rows), n, T)}")
    delta = None
    if name == "z" and rows.smoother == "rts-standardized":
        shares = [dask.delayed(_projection)(state, where) for where in slices]
        delta = dask.delayed(_correction)(state, shares)
    blocks = [
        da.from_delayed(
            dask.delayed(_block)(state, name, where, delta),
            shape=(where.stop - where.start, T),
            dtype=float,
        )
        for where in slices
    ]
    return da.concatenate(blocks, axis=0)


def _projection(rows, where):
    return rows.projection(where)


def _correction(rows, shares):
    return rows.correction_from(np.sum(shares, axis=0))


def _block(rows, name, where, delta):
    return np.ascontiguousarray(rows.block(name, where, delta=delta).T)
