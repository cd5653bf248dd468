"""validation/epochs_bench.py runs on the sample subject's sensors and says what it measured."""

import json
import os

import numpy as np
import pandas as pd
import pytest

from skf_ref.study._head import find_testing_data
from validation import epochs_bench


@pytest.fixture(scope="module")
def testing_data():
    found = find_testing_data(os.environ.get("SKF_REF_TESTING_DATA"))
    if found is None:
        pytest.skip(
            "MNE's testing dataset was not found (MNE's lookup without downloading, or the "
            "folder SKF_REF_TESTING_DATA names): the benchmark needs the sample subject"
        )
    return found


@pytest.mark.slow  # the sample subject's BEM forward
def test_a_small_benchmark_reports_both_paths_with_load_and_threads(testing_data, tmp_path):
    arguments = ["--mne-testing-data", str(testing_data), "--out", str(tmp_path)]
    arguments += ["--spacing", "40", "--epochs", "3", "--repeats", "2", "--profile"]
    assert epochs_bench.main([*arguments, "--first-runs", "1"]) == 0
    table = pd.read_csv(tmp_path / "epochs.csv")
    assert list(table.path) == list(epochs_bench.PATHS) and (table.rounds == 2).all()
    assert (table.n_channels == 364).all() and (table.n_epochs == 3).all()
    assert list(table.n_times) == [151, 151, 453, 453]  # the raw: the epochs end to end
    ratios = table.set_index("path").ratio_median
    assert np.allclose(ratios[["mne-sloreta", "mne-sloreta-raw"]], 1.0)
    record = json.loads((tmp_path / "epochs.json").read_text())
    first = record["first_application"]["paths"]
    assert set(first) == {"mne-sloreta", "skf", "skf-auto"}
    assert all(len(v["seconds"]) == 1 and v["cpu_seconds"][0] > 0 for v in first.values())
    assert record["machine"]["versions"] and record["priors"] == epochs_bench.PRIORS
    assert table.blas_threads.min() >= 1 and table.load_before.str.count(" ").eq(2).all()
    text = (tmp_path / "epochs.md").read_text()
    assert "ratio to MNE" in text and "Load average" in text and "| info | select |" in text
    assert "| skf-raw |" in text and "The first application" in text
