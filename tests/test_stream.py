"""Outputs in row blocks, streamed to zarr or computed by Dask, equal the in-memory ones."""

import tracemalloc

import numpy as np
import pytest

from skf_ref import InputError, reconstruct
from skf_ref.io import to_dask, to_zarr

NAMES = ("z", "x", "z_filtered", "x_filtered", "weights")
SMOOTHERS = (None, "rts-standardized", "rts-state")
# Blocks compute the same products on sub-blocks of V, which BLAS rounds differently from
# the whole array's (a unit in the last place); the paper's smoother also sums the
# projection zeta over blocks in another order. Equal to rounding, never bit for bit.
BLOCK_RTOL = 1e-13


def problem(n=300, m=8, T=50, seed=0):
    rng = np.random.default_rng(seed)
    L = rng.standard_normal((m, n))
    L -= L.mean(axis=0)
    return L, rng.standard_normal((m, T))


def run(smoother, method="spectral", **kwargs):
    L, Y = problem(**kwargs)
    return reconstruct(
        L, Y, noise_std=1.0, theta0=1.0, q=0.1, exponent=1.25, smoother=smoother, path=method
    )


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@pytest.mark.parametrize("method", ["spectral", "dense"])
@pytest.mark.parametrize("smoother", SMOOTHERS)
def test_blocks_equal_the_arrays(method, smoother):
    whole = run(smoother, method, n=60)
    for name in NAMES:
        blocked = np.concatenate([b for _, b in run(smoother, method, n=60).blocks(name, 7)])
        assert relative(blocked, getattr(whole, name)) <= BLOCK_RTOL, name


@pytest.mark.parametrize("smoother", SMOOTHERS)
def test_zarr_store_equals_the_arrays(tmp_path, smoother):
    store = to_zarr(run(smoother), tmp_path / "r.zarr", arrays=NAMES, chunks=37)
    whole = run(smoother)
    for name in NAMES:
        assert store[name].shape == (300, 50) and store[name].chunks == (37, 50)
        assert relative(np.asarray(store[name][:]), getattr(whole, name)) <= BLOCK_RTOL, name
    assert store.attrs["smoother"] == smoother and store.attrs["exponent"] == 1.25


def test_zarr_store_is_whole_or_absent(tmp_path, monkeypatch):
    from skf_ref import Reconstruction

    path = tmp_path / "r.zarr"
    rec = run("rts-state")
    calls = []

    def failing(self, name, rows=None):  # an interruption after the first block
        for where, block in original(self, name, rows):
            calls.append(where)
            yield where, block
            raise KeyboardInterrupt

    original = Reconstruction.blocks
    monkeypatch.setattr(Reconstruction, "blocks", failing)
    with pytest.raises(KeyboardInterrupt):
        to_zarr(rec, path, chunks=10)
    assert calls and not path.exists() and not list(tmp_path.iterdir())
    monkeypatch.undo()
    to_zarr(rec, path)
    with pytest.raises(InputError, match="exists: give overwrite=True"):
        to_zarr(rec, path)
    to_zarr(rec, path, arrays=("weights",), overwrite=True)
    with pytest.raises(InputError, match="arrays must be one of"):
        to_zarr(rec, tmp_path / "s.zarr", arrays=("zz",))


def test_a_failed_write_leaves_no_store_and_says_why(tmp_path, monkeypatch):
    # blocks are written on a thread of their own: its error (here a full disk) must still
    # reach the caller, and the half-written store must go
    import errno

    from skf_ref.io import _zarr_dask as stream

    written = []

    def full_disk(rows, block):
        if written:
            raise OSError(errno.ENOSPC, "No space left on device")
        written.append(rows)

    original = stream._write_behind
    monkeypatch.setattr(
        stream, "_write_behind", lambda blocks, write: original(blocks, full_disk, limit=0)
    )
    with pytest.raises(OSError, match="No space left"):
        to_zarr(run("rts-standardized"), tmp_path / "r.zarr", chunks=10)
    assert written and not list(tmp_path.iterdir())


@pytest.mark.parametrize("threads", [1, 2])
def test_no_n_by_t_array_before_an_output_is_asked_for(threads):
    # what a spectral reconstruct holds is n x r (V and the SVD's workspace, here ~10 MB)
    # and r x T; blocks of rows are about 4 MiB, and each worker thread holds a few (with
    # one BLAS thread, one worker); one (n, T) output would be 160 MB
    from threadpoolctl import threadpool_limits

    n, T = 20_000, 1000
    L, Y = problem(n=n, m=16, T=T)
    tracemalloc.start()
    try:
        with threadpool_limits(threads, user_api="blas"):
            rec = reconstruct(
                L, Y, noise_std=1.0, theta0=1.0, q=0.1, exponent=1.25, smoother="rts-standardized"
            )
            prepared = tracemalloc.get_traced_memory()[1]
            total = sum(float(block.sum()) for _, block in rec.blocks("z"))  # one at a time
            streamed = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    one_output = 8 * n * T
    assert prepared < one_output / 8, prepared
    assert streamed < one_output / 4 * threads, streamed
    assert total == pytest.approx(float(rec.z.sum()), rel=1e-9)


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as local,
        distributed.Client(local) as client,
    ):
        yield client


@pytest.mark.slow
@pytest.mark.parametrize("smoother", SMOOTHERS)
def test_dask_array_on_a_local_cluster_equals_the_arrays(cluster, smoother):
    array = to_dask(run(smoother), "z", chunks=40)
    whole = run(smoother).z
    assert array.chunks[0] == (40,) * 7 + (20,)
    # the r x T state is one task: it travels to each worker once, not once per block
    state = [key for key in array.__dask_graph__() if str(key).startswith("skf-rows")]
    assert len(state) == 1
    assert relative(cluster.compute(array).result(), whole) <= BLOCK_RTOL


@pytest.mark.slow
def test_sweep_on_a_local_cluster_of_processes(cluster, tmp_path):
    import joblib

    from skf_ref.study._sweep import KEY, run_sweep

    grid = dict(
        snr_db=[20.0],
        ep_snr_db=[0.0, 20.0],
        pm_snr_db=[0.0],
        exponent=[0.5],
        smoother=[None, "rts-state"],
        seed=[0, 1],
    )
    with joblib.parallel_config(backend="dask"):
        remote = run_sweep(grid, tmp_path / "r.csv", n_jobs=2, verbose=False, n_positions=500)
    local = run_sweep(grid, tmp_path / "l.csv", verbose=False, n_positions=500)
    key = list(KEY)
    a = remote.sort_values(key).reset_index(drop=True)
    b = local.sort_values(key).reset_index(drop=True)
    assert len(a) == 8 and (a[key] == b[key]).all().all()
    # the workers run BLAS on one thread each, this process on its default: rounding only
    numbers = [c for c in b.columns if b[c].dtype.kind == "f"]
    np.testing.assert_allclose(a[numbers], b[numbers], rtol=1e-12)


def test_the_number_of_threads_changes_no_block_output():
    # blocks run in worker threads, each on one BLAS thread, and their shares are summed in
    # block order: the same bits on one core or two. Only the smoother's last product, one
    # BLAS call over the whole array on every BLAS thread, may round differently.
    from threadpoolctl import threadpool_limits

    L, Y = problem(n=6000, m=16, T=300)
    outputs = []
    for threads in (1, 2):
        with threadpool_limits(threads, user_api="blas"):
            rec = reconstruct(
                L, Y, noise_std=1.0, theta0=1.0, q=0.1, exponent=1.25, smoother="rts-standardized"
            )
            outputs.append((rec.z_filtered, rec.weights, rec.x, rec.z))
    (*blocks_one, z_one), (*blocks_two, z_two) = outputs
    for one, two in zip(blocks_one, blocks_two, strict=True):
        np.testing.assert_array_equal(one, two)
    np.testing.assert_allclose(z_one, z_two, rtol=0, atol=1e-13 * np.abs(z_one).max())


def test_narrow_smoothed_blocks_computed_several_at_a_time_equal_the_whole():
    # rows=7 at T=300: blocks of 7 rows are computed 511 rows at a time (the smoother's
    # backward pass is paid per block computed) and handed out 7 by 7
    L, Y = problem(n=1200, m=16, T=300)
    rec = reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1, smoother="rts-standardized")
    pieces = list(rec.blocks("z", rows=7))
    assert [rows.stop - rows.start for rows, _ in pieces[:3]] == [7, 7, 7]
    np.testing.assert_allclose(np.vstack([b for _, b in pieces]), rec.z, rtol=0, atol=1e-12)


# --- what to_zarr may touch on disk -------------------------------------------------------


def test_overwrite_replaces_only_a_store_to_zarr_wrote(tmp_path):
    rec = run(None, n=60, T=5)
    folder = tmp_path / "mine.zarr"
    folder.mkdir()
    (folder / "notes.txt").write_text("a user's file")
    a_file = tmp_path / "data.zarr"
    a_file.write_text("not a store")
    for path in (folder, a_file):
        with pytest.raises(InputError, match=f"{path} exists and is not a store written by"):
            to_zarr(rec, path, overwrite=True)
    assert (folder / "notes.txt").read_text() == "a user's file"
    assert a_file.read_text() == "not a store"
    store = tmp_path / "r.zarr"
    to_zarr(rec, store)
    again = to_zarr(rec, store, arrays=("weights",), overwrite=True)
    assert list(again.array_keys()) == ["weights"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data.zarr", "mine.zarr", "r.zarr"]


def test_a_killed_writer_s_temporaries_go_on_the_next_run(tmp_path):
    import subprocess
    import sys

    import zarr

    from skf_ref.io._zarr_dask import STORE_MARK

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    rec = run(None, n=60, T=5)

    def left_by_the_dead(tag, mark):
        path = tmp_path / f".r.zarr.skf-{tag}-{dead.pid}-{mark}"
        to_zarr(rec, tmp_path / "scratch.zarr").store.close()
        (tmp_path / "scratch.zarr").rename(path)
        zarr.open_group(path, mode="r+").attrs[STORE_MARK] = mark
        return path

    left_by_the_dead("tmp", "writing")  # killed while writing: deleted
    complete = left_by_the_dead("tmp", "complete")  # killed while renaming: put in place
    (tmp_path / f".r.zarr.skf-tmp-{dead.pid}-empty").mkdir()  # killed before writing
    users = tmp_path / f".r.zarr.skf-tmp-{dead.pid}-ghi"  # a look-alike of the user's: kept
    users.mkdir()
    (users / "notes.txt").write_text("kept")
    with pytest.raises(InputError, match="r.zarr exists: give overwrite=True"):
        to_zarr(rec, tmp_path / "r.zarr")  # the complete store is back in place
    assert not complete.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [users.name, "r.zarr"]
    old = left_by_the_dead("old", "complete")  # set aside, the new one in place: deleted
    to_zarr(rec, tmp_path / "r.zarr", overwrite=True)
    assert not old.exists() and (users / "notes.txt").exists()


def test_errors_name_the_user_s_path_and_arrays_are_checked(tmp_path):
    rec = run(None, n=60, T=5)
    missing = tmp_path / "nodir" / "r.zarr"
    with pytest.raises(InputError, match=f"{missing}: the folder {missing.parent} does not"):
        to_zarr(rec, missing)
    with pytest.raises(InputError, match=r"arrays must name each output once, got \['z'\]"):
        to_zarr(rec, tmp_path / "r.zarr", arrays=("z", "z"))
    with pytest.raises(TypeError, match="arrays must be a sequence of output names"):
        to_zarr(rec, tmp_path / "r.zarr", arrays="weights")
    assert not list(tmp_path.iterdir())


def test_a_small_output_takes_a_small_chunk(tmp_path):
    store = to_zarr(run(None, n=10, T=5), tmp_path / "r.zarr", arrays=NAMES)
    assert store["z"].chunks == (10, 5)
    size = sum(p.stat().st_size for p in (tmp_path / "r.zarr").rglob("*") if p.is_file())
    assert size < 64 * 2**10  # five 10 x 5 arrays and their metadata, not 64 MiB a chunk
