"""A user's file is never replaced without being asked (issue 44, items 7-9).

Without ``overwrite`` (``--overwrite``) an existing file is refused before any work, and a
file that appears while the result is written (a second run of the same command) stays as
it is: the result is published only where nothing is, at the moment it is published.
"""

import json

import mne
import numpy as np
import pytest

import skf_ref
from skf_ref import InputError, make_skf_operator, write_skf_operator
from skf_ref._utils.atomic_files import atomic_path
from skf_ref.conformance import export
from skf_ref.io import _operator_file as operator_file


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if ".skf-" in p.name)


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_file_that_appears_meanwhile_is_replaced_only_with_overwrite(tmp_path, overwrite):
    path = tmp_path / "result.txt"
    context = atomic_path(path, overwrite=overwrite)
    if overwrite:
        with context as tmp:
            tmp.write_text("this run's")
            path.write_text("another run's")  # appears while this one is written
        assert path.read_text() == "this run's"
    else:
        with pytest.raises(InputError, match=r"result.txt appeared while it was written .* left"):
            with context as tmp:
                tmp.write_text("this run's")
                path.write_text("another run's")
        assert path.read_text() == "another run's"
    assert _leftovers(tmp_path) == []


def test_without_hard_links_the_file_is_still_never_replaced(tmp_path, monkeypatch):
    import errno
    import os

    def no_links(src, dst):
        raise OSError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(os, "link", no_links)
    path = tmp_path / "r.txt"
    with atomic_path(path, overwrite=False) as tmp:
        tmp.write_text("new")
    assert path.read_text() == "new"
    with pytest.raises(InputError, match="r.txt appeared while it was written"):
        with atomic_path(path, overwrite=False) as tmp:
            tmp.write_text("second")
    assert path.read_text() == "new" and _leftovers(tmp_path) == []


@pytest.fixture(scope="module")
def operator():
    montage = mne.channels.make_standard_montage("biosemi16")
    info = mne.create_info(montage.ch_names, 200.0, "eeg").set_montage(montage)
    sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    src = mne.setup_volume_source_space(sphere=sphere, pos=40.0, verbose=False)
    forward = mne.make_forward_solution(info, None, src, sphere, verbose=False)
    return make_skf_operator(info, forward, noise_std=1e-6, verbose=False)


def test_an_operator_file_that_appears_meanwhile_is_kept(operator, tmp_path, monkeypatch):
    # item 7: two runs of one batch line checked the name free, and both wrote it
    path = tmp_path / "op-skf.h5"
    original = operator_file._forward_bytes

    def second_run_meanwhile(forward):
        path.write_text("the other run's operator")
        return original(forward)

    monkeypatch.setattr(operator_file, "_forward_bytes", second_run_meanwhile)
    with pytest.raises(InputError, match=r"op-skf.h5 appeared while it was written"):
        write_skf_operator(path, operator)
    assert path.read_text() == "the other run's operator" and _leftovers(tmp_path) == []
    write_skf_operator(path, operator, overwrite=True)  # asked: replaced
    assert skf_ref.read_skf_operator(path).n_sources == operator.n_sources


@pytest.mark.parametrize("when", ["during the work", "while it is written"])
def test_reconstruct_keeps_an_output_that_appears_meanwhile(cli, tmp_path, monkeypatch, when):
    import skf_ref.method

    rng = np.random.default_rng(0)
    np.save(tmp_path / "L.npy", rng.standard_normal((8, 12)))
    np.save(tmp_path / "Y.npy", rng.standard_normal((8, 20)))
    out = tmp_path / "r.npz"
    module, name = (skf_ref.method, "reconstruct") if when == "during the work" else (
        np, "savez_compressed")  # fmt: skip
    original = getattr(module, name)

    def second_run_meanwhile(*args, **kwargs):
        if not out.exists():
            out.write_text("the other run's estimate")
        return original(*args, **kwargs)

    monkeypatch.setattr(module, name, second_run_meanwhile)
    arguments = ["reconstruct", "--leadfield", str(tmp_path / "L.npy"), "--data"]
    arguments += [str(tmp_path / "Y.npy"), "--noise-std", "1", "--out", str(out), "--quiet"]
    result = cli(*arguments)
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    expected = "appeared while it was written" if when != "during the work" else (
        "exists: give --overwrite to replace it")  # fmt: skip
    assert f"{out} {expected}" in result.stderr
    assert out.read_text() == "the other run's estimate" and _leftovers(tmp_path) == []
    monkeypatch.undo()
    assert cli(*arguments, "--overwrite").returncode == 0
    assert np.load(out)["z"].shape == (12, 20)


# --- compare --json, conformance export, demo --out: --overwrite (items 8, 9) -------------


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cases")
    export(folder, ["npz"])
    return folder / "original_skf.npz"


def test_compare_json_replaces_a_report_only_with_overwrite(cli, case, tmp_path):
    theirs = skf_ref.conformance.read_case(case).reconstruct()
    np.savez(tmp_path / "mine.npz", z=theirs.z)
    report = tmp_path / "report.json"
    report.write_text("the user's report")
    arguments = ["compare", str(case), str(tmp_path / "mine.npz"), "--json", str(report)]
    result = cli(*arguments)
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert f"argument --json: {report} exists: give --overwrite to replace it" in result.stderr
    assert report.read_text() == "the user's report"
    assert cli(*arguments, "--overwrite").returncode == 0
    assert json.loads(report.read_text())["agrees"] is True


def test_export_replaces_files_of_other_bytes_only_with_overwrite(cli, tmp_path):
    export(tmp_path, ["npz"])
    assert export(tmp_path, ["npz"])  # the suite's own bytes: a rerun replaces nothing
    mine = tmp_path / "original_skf.npz"
    mine.write_bytes(b"the user's own case")
    manifest = (tmp_path / "manifest.json").read_bytes()
    match = r"holds 1 file\(s\) named like the suite's .*original_skf.npz\): nothing is written"
    with pytest.raises(InputError, match=match + "; give overwrite=True"):
        export(tmp_path, ["npz"])
    assert mine.read_bytes() == b"the user's own case"
    assert (tmp_path / "manifest.json").read_bytes() == manifest  # nothing written
    result = cli("conformance", "export", str(tmp_path), "--format", "npz")
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert "original_skf.npz): nothing is written; give --overwrite" in result.stderr
    assert mine.read_bytes() == b"the user's own case"
    assert cli("conformance", "export", str(tmp_path), "--format", "npz", "--overwrite",
               "--quiet").returncode == 0  # fmt: skip
    assert skf_ref.conformance.verify(tmp_path) == []


def test_export_refuses_another_suites_manifest_without_overwrite(tmp_path):
    export(tmp_path, ["npz"], suite=2)
    with pytest.raises(InputError, match=r"named like the suite's but with other contents .*"
                       r"give overwrite=True"):  # fmt: skip
        export(tmp_path, ["npz"])
    export(tmp_path, ["npz"], overwrite=True)
    assert skf_ref.conformance.verify(tmp_path) == []


def test_demo_replaces_the_users_files_only_with_overwrite(cli, tmp_path):
    from skf_ref.study._demo import run_demo

    (tmp_path / "metrics.csv").write_text("the user's metrics")
    (tmp_path / "settings.json").write_text("{}")
    with pytest.raises(InputError, match=r"holds metrics.csv, settings.json: .* give overwrite"):
        run_demo(tmp_path, head="sphere", montage="biosemi16")
    result = cli("demo", "--out", str(tmp_path), "--head", "sphere", "--quiet")
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert "--out: out=" in result.stderr and "give --overwrite to replace them" in result.stderr
    assert result.stdout == ""  # refused before any work
    assert (tmp_path / "metrics.csv").read_text() == "the user's metrics"
