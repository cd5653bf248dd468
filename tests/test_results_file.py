"""A sweep's results file: one writer at a time whatever name it is opened by, and BOMs read."""

import os

import pytest

from skf_ref import InputError
from skf_ref.study._sweep import KEY
from skf_ref.study._sweep._results import ResultsFile, read_results

ROW = {k: 0 for k in KEY} | dict(montage="biosemi64", smoother="none", peak_error_mm=1.0)


@pytest.fixture
def results(tmp_path):
    out = tmp_path / "results.csv"
    with ResultsFile(out) as first:
        first.add([ROW])
    return out


@pytest.mark.parametrize("link", ["symlink", "hard link"])
def test_a_second_sweep_through_another_name_of_the_file_is_refused(results, link):
    other = results.with_name("other.csv")
    (os.symlink if link == "symlink" else os.link)(results, other)
    with ResultsFile(results) as first:
        with pytest.raises(InputError, match="other.csv is in use by another sweep"):
            with ResultsFile(other) as second:
                second.add([ROW | dict(seed=1)])
        first.add([ROW | dict(seed=2)])
    assert list(read_results(results)["seed"]) == [0, 2]
    with ResultsFile(other) as again:  # released with the first
        assert len(again.existing) == 2


def test_a_new_file_is_locked_as_it_is_created(tmp_path):
    out = tmp_path / "new.csv"
    with ResultsFile(out) as first:
        first.add([ROW])
        os.link(out, tmp_path / "link.csv")
        with pytest.raises(InputError, match="is in use by another sweep"):
            ResultsFile(tmp_path / "link.csv").__enter__()


def test_a_byte_order_mark_is_read_past(results):
    with_bom = results.with_name("excel.csv")
    with_bom.write_bytes(b"\xef\xbb\xbf" + results.read_bytes())  # Excel's "CSV UTF-8"
    table = read_results(with_bom)
    assert list(table.columns[:2]) == ["n_positions", "montage"] and len(table) == 1
    with ResultsFile(with_bom) as resumed:
        resumed.add([ROW | dict(seed=3)])
    assert list(read_results(with_bom)["seed"]) == [0, 3]


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_writing_through_a_symbolic_link_updates_the_file_it_points_to(tmp_path, suffix):
    target = tmp_path / "runs" / f"all{suffix}"
    target.parent.mkdir()
    with ResultsFile(target) as first:
        first.add([ROW])
    link = tmp_path / f"link{suffix}"
    link.symlink_to(target)
    with ResultsFile(link) as resumed:
        assert len(resumed.existing) == 1
        resumed.add([ROW | dict(seed=1)])
    assert link.is_symlink() and link.resolve() == target.resolve()
    assert list(read_results(target)["seed"]) == [0, 1]  # the linked file has every row
    assert sorted(p.name for p in target.parent.iterdir() if not p.name.endswith(".lock")) == [
        target.name
    ]
