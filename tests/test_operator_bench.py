"""validation/operator_bench.py runs, and its table says what it measured."""

import numpy as np

from validation import operator_bench


def test_a_small_benchmark_reports_every_path_with_its_load_and_threads(tmp_path):
    assert (
        operator_bench.main(["--size", "300,32,20", "--repeats", "2", "--out", str(tmp_path)]) == 0
    )
    text = (tmp_path / "operator.md").read_text()
    table = operator_bench.pd.read_csv(tmp_path / "operator.csv")
    assert list(table.path) == list(operator_bench.PATHS)
    assert (table.rounds == 2).all() and (table.seconds_median > 0).all()
    assert np.allclose(table.set_index("path").ratio_median["mne-sloreta"], 1.0)
    assert table.blas_threads.min() >= 1 and table.load_before.str.count(" ").eq(2).all()
    assert "ratio to MNE" in text and "Load average" in text
