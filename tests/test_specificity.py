"""The baselines' bookkeeping and the specificity statistics (validation/reproduce)."""

import numpy as np
import pandas as pd
import pytest

from validation.reproduce.baselines import COLUMNS, _whitener
from validation.reproduce.specificity import auc_interval, scores


def test_whitener_whitens_an_average_referenced_covariance():
    rng = np.random.default_rng(0)
    n = 6
    P = np.eye(n) - 1.0 / n
    A = rng.standard_normal((n, n))
    C = P @ (A @ A.T) @ P  # rank n - 1, the ones vector in its null space
    W = _whitener(C)
    assert W.shape == (n - 1, n)
    np.testing.assert_allclose(W @ C @ W.T, np.eye(n - 1), atol=1e-10)
    np.testing.assert_allclose(W @ np.ones(n), 0.0, atol=1e-10)


def test_auc_interval_contains_the_area_and_stays_informative_at_the_ceiling():
    rng = np.random.default_rng(1)
    present, absent = rng.normal(1.0, 1.0, 20), rng.normal(0.0, 1.0, 20)
    area, low, high = auc_interval(present, absent)
    assert low < area < high and 0.5 < area < 1.0
    area, low, high = auc_interval(present + 100.0, absent)  # a bootstrap gives [1, 1] here
    assert area == high == 1.0 and 0.85 < low < 0.95


def _rows(method, deep_present, deep_absent):
    rows = []
    for seed, (present, absent) in enumerate(zip(deep_present, deep_absent, strict=True)):
        for data, deep in (("both", present), ("superficial", absent), ("deep", present)):
            rows.append(
                dict(
                    condition="c", snr_db=20.0, seed=seed, data=data, method=method,
                    setting="s", deep_region_db=deep, deep_level=10 ** (deep / 20),
                    deep_epoch_db=deep - 1.0,
                    superficial_region_db=-20.0 if data == "deep" else 0.0,
                    deep_error_mm=[5.0, 10.0, 10.0, np.nan][seed],
                    superficial_error_mm=3.0, run_s=0.01, prep_s=0.1,
                )
            )  # fmt: skip
    return rows


def test_scores_count_detections_and_separations():
    table = pd.DataFrame(
        _rows("A", [0.0, -1.0, -2.0, -3.0], [-10.0, -20.0, -2.5, -7.0]), columns=list(COLUMNS)
    )
    row = scores(table).iloc[0]
    assert row["n_seeds"] == 4
    assert row["deep_auc"] == pytest.approx(15 / 16)  # only -2.5 beats a present score (-3)
    assert row["deep_tpr"] == 1.0 and row["deep_fpr"] == 0.25  # -2.5 dB is within 6 dB
    assert row["deep_fpr_low"] < 0.25 < row["deep_fpr_high"]  # Clopper-Pearson
    assert row["deep_tpr_high"] == 1.0 and row["deep_tpr_low"] == pytest.approx(0.025**0.25)
    assert row["deep_level_auc"] == row["deep_epoch_db_auc"] == pytest.approx(15 / 16)
    assert row["superficial_auc"] == 1.0 and row["superficial_fpr"] == 0.0
    assert (row["deep_err"], row["deep_q1"], row["deep_q3"]) == (10.0, 7.5, 10.0)
    assert row["deep_no_estimate"] == 1
