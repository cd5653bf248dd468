"""The comparisons of tests/rounding.py accept rounding and nothing else."""

import doctest

import numpy as np
import pytest
from rounding import ROUTE_RTOL, NumberChecker, assert_same_to_rounding, same_printout


@pytest.mark.parametrize(
    "printed, page",
    [
        ("log-likelihood -4611.59, by likelihood", "log-likelihood -4611.6, by likelihood"),
        ("PM-SNR -20.00 dB", "PM-SNR -20.00 dB"),
        ("r = 0.4999", "r = 0.5"),
        ("1.2345e-05 V", "1.235e-05 V"),
    ],
)
def test_a_number_on_a_rounding_boundary_is_the_same_printout(printed, page):
    assert same_printout(printed, page)
    checker = NumberChecker()
    assert checker.check_output(page + "\n", printed + "\n", doctest.ELLIPSIS)


@pytest.mark.parametrize(
    "printed, page",
    [
        ("log-likelihood -4611.4", "log-likelihood -4611.6"),  # two units of the last digit
        ("2085 passed", "2086 passed"),  # integers are counts
        ("r = 0.5 (filtered)", "r = 0.5 (smoothed)"),
        ("1.2e-05 V", "1.2e-06 V"),
        ("a\nb", "a"),
    ],
)
def test_a_real_difference_is_not(printed, page):
    assert not same_printout(printed, page)
    assert not NumberChecker().check_output(page + "\n", printed + "\n", 0)


def test_routes_equal_to_rounding_and_no_further():
    rng = np.random.default_rng(0)
    a = rng.standard_normal((4, 5))
    assert_same_to_rounding(a * (1 + 1e-15), a)
    with pytest.raises(AssertionError, match="relative difference"):
        assert_same_to_rounding(a + 10 * ROUTE_RTOL * np.abs(a).max(), a)
    gap = a.copy()
    gap[:, 2] = np.nan
    assert_same_to_rounding(gap, gap.copy())
    with pytest.raises(AssertionError, match="NaN at other places"):
        assert_same_to_rounding(gap, a)
