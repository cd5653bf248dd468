"""Outputs a user can trust: checked before any work, whole or absent, written where a link
points, never replacing what this package did not write, no temporary left after a rerun."""

import errno
import os
import subprocess
import sys

import numpy as np
import pytest

from skf_ref import InputError, reconstruct
from skf_ref._utils.atomic_files import (
    atomic_path,
    check_output_path,
    remove_stale_temporaries,
    rename_noreplace,
    temporary_folder,
)
from skf_ref.io import to_zarr


def _rec(n=60, T=5):
    rng = np.random.default_rng(0)
    L = rng.standard_normal((8, n))
    return reconstruct(L, rng.standard_normal((8, T)), noise_std=1.0, theta0=1.0, q=0.1)


@pytest.fixture(scope="module")
def dead_pid():
    """The id of a process that has ended: what a killed writer's temporaries carry."""
    process = subprocess.Popen([sys.executable, "-c", "pass"])
    process.wait()
    return process.pid


# --- checked before any work ----------------------------------------------------------------


def test_an_output_path_is_checked_for_everything_that_would_fail_later(tmp_path):
    data = tmp_path / "Y.npz"
    data.write_bytes(b"input")
    (tmp_path / "dir.npz").mkdir()
    (tmp_path / "sub").mkdir()
    link = tmp_path / "link.npz"
    link.symlink_to(data)
    hard = tmp_path / "hard.npz"
    os.link(data, hard)
    cases = {
        tmp_path / "x.txt": r"x.txt: must end in .npz or .stc, got '.txt'",
        tmp_path / "nodir" / "x.npz": r"x.npz: the folder .*nodir does not exist",
        tmp_path / "dir.npz": r"dir.npz is a folder; give a file name",
        link: r"link.npz is the input --data \(.*Y.npz\): it would be overwritten",
        hard: r"hard.npz is the input --data",
        tmp_path / "sub" / ".." / "Y.npz": r"Y.npz is the input --data",
    }
    for path, match in cases.items():
        with pytest.raises(InputError, match=f"^argument --out: .*{match}"):
            check_output_path(
                path, name="argument --out", suffixes=(".npz", ".stc"), inputs={"--data": data}
            )
    existing = tmp_path / "old.npz"
    existing.write_bytes(b"a result")
    with pytest.raises(InputError, match="old.npz exists: give --overwrite to replace it"):
        check_output_path(
            existing, overwrite=False, overwrite_hint="give --overwrite to replace it"
        )
    assert check_output_path(existing) == existing
    with pytest.raises(TypeError, match=r"^path must be a file name \(str or path-like\), got"):
        check_output_path(np.zeros(3))


# --- whole or absent, through links, errors naming the user's path --------------------------


def test_writing_through_a_symbolic_link_writes_the_file_it_points_to(tmp_path):
    target = tmp_path / "runs" / "run5.txt"
    target.parent.mkdir()
    target.write_text("old")
    link = tmp_path / "latest.txt"
    link.symlink_to(target)
    with atomic_path(link) as tmp:
        tmp.write_text("new")
    assert link.is_symlink() and target.read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["latest.txt", "runs"]
    assert [p.name for p in target.parent.iterdir()] == ["run5.txt"]


def test_a_failed_write_names_the_user_s_path_not_the_temporary(tmp_path):
    path = tmp_path / "o.npz"
    with pytest.raises(OSError, match="No space left") as info, atomic_path(path) as tmp:
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp))
    assert info.value.filename == str(path) and ".skf-tmp" not in str(info.value)
    assert not any(tmp_path.iterdir())
    with pytest.raises(InputError, match=f"^{tmp_path / 'no' / 'o.npz'}: the folder"):
        with atomic_path(tmp_path / "no" / "o.npz"):
            pass


def test_rename_noreplace_never_replaces_even_an_empty_folder(tmp_path):
    source = tmp_path / "new"
    source.mkdir()
    for kind in ("empty folder", "folder", "file", "link"):
        target = tmp_path / kind.replace(" ", "_")
        if kind == "file":
            target.write_text("mine")
        elif kind == "link":
            target.symlink_to(tmp_path / "nowhere")
        else:
            target.mkdir()
            if kind == "folder":
                (target / "notes.txt").write_text("mine")
        with pytest.raises(FileExistsError):
            rename_noreplace(source, target)
        assert source.is_dir(), kind
    rename_noreplace(source, tmp_path / "free")
    assert (tmp_path / "free").is_dir() and not source.exists()


# --- stores: the extension decides, nothing of anyone else's replaced -----------------------


@pytest.mark.parametrize("name", ["x.h5", "x.npz", "x", "x.zarr.zip"])
def test_a_store_is_written_only_to_a_name_ending_in_zarr(tmp_path, name):
    with pytest.raises(InputError, match=r"a zarr store \(a folder\) is written to a name ending"):
        to_zarr(_rec(), tmp_path / name)
    assert not any(tmp_path.iterdir())


def _while_writing(monkeypatch, action):
    """Run ``action`` once the first block is computed, as another process would."""
    from skf_ref import Reconstruction

    original = Reconstruction.blocks

    def blocks(self, name, rows=None):
        for number, block in enumerate(original(self, name, rows)):
            yield block
            if number == 0:
                monkeypatch.setattr(Reconstruction, "blocks", original)  # the other's: plain
                action()

    monkeypatch.setattr(Reconstruction, "blocks", blocks)


def test_two_writers_of_one_store_one_wins_the_other_is_told(tmp_path, monkeypatch):
    path, other = tmp_path / "r.zarr", _rec(n=40)
    _while_writing(monkeypatch, lambda: to_zarr(other, path, chunks=10))  # it finishes first
    with pytest.raises(InputError, match=r"r.zarr appeared while this store was written"):
        to_zarr(_rec(), path, chunks=10)
    monkeypatch.undo()
    import zarr

    assert zarr.open_group(path, mode="r")["z"].shape == (40, 5)  # the winner's, whole
    assert [p.name for p in tmp_path.iterdir()] == ["r.zarr"]


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_folder_of_the_user_s_that_appears_meanwhile_is_never_touched(
    tmp_path, monkeypatch, overwrite
):
    import shutil

    path = tmp_path / "r.zarr"
    if overwrite:
        to_zarr(_rec(), path)  # the store overwrite=True may replace...

    def users_folder():  # ...replaced meanwhile by a folder of the user's (even empty)
        shutil.rmtree(path, ignore_errors=True)
        path.mkdir()
        (path / "notes.txt").write_text("the user's")

    _while_writing(monkeypatch, users_folder)
    with pytest.raises(InputError, match=r"r.zarr (appeared|changed) while this store was"):
        to_zarr(_rec(), path, chunks=10, overwrite=overwrite)
    assert (path / "notes.txt").read_text() == "the user's"
    assert [p.name for p in tmp_path.iterdir()] == ["r.zarr"]


def test_overwrite_replaces_the_store_it_checked(tmp_path):
    import zarr

    path = tmp_path / "r.zarr"
    to_zarr(_rec(n=40), path)
    to_zarr(_rec(), path, arrays=("weights",), overwrite=True)
    store = zarr.open_group(path, mode="r")
    assert list(store.array_keys()) == ["weights"] and store["weights"].shape == (60, 5)
    assert [p.name for p in tmp_path.iterdir()] == ["r.zarr"]


# --- no temporary survives a rerun, whoever writes ------------------------------------------


def _writers(tmp_path, mne_setup):
    """Each writer of the package: (its output, how it runs)."""
    from skf_ref.conformance import cases, write_case
    from skf_ref.io import apply_skf, write_reconstruction, write_stc

    rec = _rec()
    evoked = mne_setup["make_epochs"](target=300, seed=5).average()
    stc = apply_skf(evoked, mne_setup["forward"], noise_std=1e-6)
    return {
        "write_reconstruction": (
            tmp_path / "r.npz",
            lambda: write_reconstruction(tmp_path / "r.npz", rec),
        ),
        "write_stc": (tmp_path / "e-vl.stc", lambda: write_stc(tmp_path / "e.stc", stc)),
        "write_case": (tmp_path / "c.mat", lambda: write_case(cases()[0], tmp_path / "c.mat")),
    }


def test_every_writer_removes_what_a_killed_one_left(tmp_path, mne_setup, dead_pid):
    for name, (output, write) in _writers(tmp_path, mne_setup).items():
        stem, suffix = output.stem, output.suffix
        stale_file = tmp_path / f".{stem}.skf-tmp-{dead_pid}-abc{suffix}"
        stale_file.write_bytes(b"half")
        stale_folder = tmp_path / f".{output.name}.skf-tmp-{dead_pid}-def"
        stale_folder.mkdir()
        (stale_folder / ".skf_ref_temporary").touch()
        live = tmp_path / f".{stem}.skf-tmp-{os.getpid()}-ghi{suffix}"  # a writer running
        live.write_bytes(b"in progress")
        write()
        assert not stale_file.exists() and not stale_folder.exists(), name
        assert live.exists() and output.exists(), name
        live.unlink()
    leftovers = [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert not leftovers


def test_a_temporary_folder_is_removed_after_and_marked_while(tmp_path, dead_pid):
    with temporary_folder(tmp_path / "x.stc") as tmp:
        assert tmp.name.startswith(f".x.stc.skf-tmp-{os.getpid()}-")
        assert (tmp / ".skf_ref_temporary").is_file()
    assert not any(tmp_path.iterdir())
    users = tmp_path / f".x.stc.skf-tmp-{dead_pid}-users"  # looks like one, holds no mark
    users.mkdir()
    (users / "data.txt").write_text("kept")
    assert remove_stale_temporaries(tmp_path / "x.stc") == []
    assert (users / "data.txt").exists()


@pytest.mark.parametrize("name", ["run1.h5", "run1-skf"])
def test_apply_skf_raw_refuses_a_store_name_of_another_format_before_any_work(
    tmp_path, mne_setup, name
):
    import mne

    from skf_ref import apply_skf_raw, make_skf_operator

    info = mne_setup["info"]
    raw = mne.io.RawArray(np.zeros((len(info.ch_names), 50)), info, verbose=False)
    raw.set_eeg_reference("average", projection=True, verbose=False)
    operator = make_skf_operator(raw.info, mne_setup["forward"], noise_std=1e-6, verbose=False)
    with pytest.raises(InputError, match=rf"{name}: a zarr store \(a folder\) is written to a"):
        apply_skf_raw(raw, operator, out=tmp_path / name)
    assert not any(tmp_path.iterdir())
