"""The cross-check of every path against the dense oracle (validation/crosscheck.py)."""

import itertools

import numpy as np
import pytest

from validation import crosscheck as cc

# Number of problem kinds the grid must cover: 2 orientations x 2 references x 4 exponents
# x 3 smoothers x 2 noise models, plus the general model once per smoother.
N_GRID = 2 * 2 * 4 * 3 * 2
N_GENERAL = 3
# What the paths must agree to (the brief of the cross-check), independent of the value of
# cc.TOLERANCE so that loosening the script's threshold cannot loosen this test.
REQUIRED = 1e-8


@pytest.fixture(scope="module")
def rows():
    return cc.crosscheck()


def test_every_difference_within_tolerance(rows):
    compared = [row for row in rows if not row["skipped"]]
    assert compared, "no comparison was made"
    for row in compared:
        for quantity in cc.QUANTITIES:
            assert row[quantity] < REQUIRED, (row["problem"], row["path"], quantity)


def test_grid_covers_every_case(rows):
    assert len(rows) == (N_GRID + N_GENERAL) * len(cc.PATHS)
    for path in cc.PATHS:
        grid = [r for r in rows if r["path"] == path and r["transition"] == "identity"]
        covered = {
            (r["orientation"], r["reference"], r["exponent"], r["smoother"], r["noise"])
            for r in grid
        }
        wanted = set(
            itertools.product(
                ("fixed", "free"),
                ("none", "average"),
                (0.5, 1.0, 1.25, 1.5),
                (None, "rts-standardized", "rts-state"),
                ("noise_std", "noise_cov"),
            )
        )
        assert covered == wanted
        general = [r for r in rows if r["path"] == path and r["transition"] == "general"]
        assert {r["smoother"] for r in general} == {None, "rts-standardized", "rts-state"}


def test_problems_are_what_they_claim():
    problems = cc.make_problems()
    assert len(problems) == N_GRID + N_GENERAL
    for problem in problems:
        n_columns = cc.N_POSITIONS * (3 if problem.labels["orientation"] == "free" else 1)
        assert problem.L.shape == (cc.N_CHANNELS, n_columns)
        assert problem.Y.shape == (cc.N_CHANNELS, cc.N_TIMES)
        rank = np.linalg.matrix_rank(problem.L)
        if problem.labels["reference"] == "average":
            # The constant vector is in the left null space: rank n_channels - 1 at most.
            assert np.max(np.abs(problem.L.sum(axis=0))) < 1e-12 * np.max(np.abs(problem.L))
            assert rank == min(cc.N_CHANNELS - 1, n_columns)
        else:
            assert rank == min(cc.N_CHANNELS, n_columns)
        assert ("noise_cov" in problem.kwargs) == (problem.labels["noise"] == "noise_cov")
    general = [p for p in problems if p.labels["transition"] == "general"]
    for problem in general:
        for name in ("transition", "theta0", "q", "noise_cov"):
            matrix = problem.kwargs[name]
            off_diagonal = matrix - np.diag(np.diag(matrix))
            assert np.max(np.abs(off_diagonal)) > 0.01 * np.max(np.abs(matrix)), name
        for name in ("theta0", "q", "noise_cov"):
            assert np.all(np.linalg.eigvalsh(problem.kwargs[name]) > 0), name


def test_problems_are_seeded():
    first, second = cc.make_problems()[5], cc.make_problems()[5]
    np.testing.assert_array_equal(first.L, second.L)
    np.testing.assert_array_equal(first.Y, second.Y)


def test_relative_difference():
    assert cc.relative_difference([1.0, -4.0], [1.0, -4.0]) == 0.0
    assert cc.relative_difference([1.0, -3.0], [1.0, -4.0]) == 0.25
    assert cc.relative_difference(2.0, 0.0) == 2.0
    assert np.isnan(cc.relative_difference([np.nan], [1.0]))


@pytest.mark.slow
def test_main_passes_and_prints_table(capsys):
    assert cc.main(["--paths", "filterpy"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("| problem | path | z |")
    assert out.count("| filterpy |") == N_GRID + N_GENERAL
    assert "PASS" in out


def test_main_fails_on_a_wrong_path(monkeypatch, capsys):
    # A path that is wrong by 1e-6 must be caught: the harness itself is under test.
    reconstruct = cc.reconstruct

    def perturbed(L, Y, *, path, **kwargs):
        result = reconstruct(L, Y, path=path, **kwargs)
        if path == "filterpy":
            z = result.z.copy()
            z[0, 0] *= 1 + 1e-6
            result._arrays["z"] = z
        return result

    monkeypatch.setattr(cc, "reconstruct", perturbed)
    problems = cc.make_problems()[:2]
    monkeypatch.setattr(cc, "make_problems", lambda: problems)
    assert cc.main([]) == 1
    assert "FAIL" in capsys.readouterr().out


def test_skipped_comparisons_are_reported(monkeypatch):
    monkeypatch.setattr(cc, "qualifies", lambda path, problem: False)
    rows = cc.crosscheck(problems=cc.make_problems()[:2])
    assert len(rows) == 2 * len(cc.PATHS)
    assert all(row["skipped"] for row in rows)
    assert all(np.isnan(row[q]) for row in rows for q in cc.QUANTITIES)
    assert np.isnan(cc.worst(rows))
    assert not cc.passed(rows)
    assert "skipped" in cc.format_table(rows)


def test_zero_comparisons_fail(monkeypatch, capsys):
    # Every comparison skipped: nothing was shown, so the run must not pass.
    monkeypatch.setattr(cc, "qualifies", lambda path, problem: False)
    problems = cc.make_problems()[:2]
    monkeypatch.setattr(cc, "make_problems", lambda: problems)
    assert cc.main([]) == 1
    out = capsys.readouterr().out
    summary = out.strip().splitlines()[-2]  # the last line is the wall time
    assert summary.startswith("no comparison was made")
    assert summary.endswith("FAIL")
    assert "PASS" not in out


def test_some_skipped_rows_still_pass(monkeypatch, capsys):
    # Skipped rows beside compared ones keep the old behaviour: the compared ones decide.
    monkeypatch.setattr(cc, "qualifies", lambda path, problem: path == "filterpy")
    problems = cc.make_problems()[:2]
    monkeypatch.setattr(cc, "make_problems", lambda: problems)
    assert cc.main([]) == 0
    out = capsys.readouterr().out
    assert "over 2 compared and 2 skipped" in out and out.strip().splitlines()[-2].endswith("PASS")


def test_qualifies_hook():
    problems = cc.make_problems()
    general = [p for p in problems if p.labels["transition"] == "general"]
    for path in ("filterpy", "dense"):
        assert all(cc.qualifies(path, p) for p in problems)
    # the spectral path needs scalar transition, theta0 and q: only the grid qualifies
    assert not any(cc.qualifies("spectral", p) for p in general)
    assert all(cc.qualifies("spectral", p) for p in problems if p not in general)


def test_unknown_path_is_refused():
    with pytest.raises(SystemExit):
        cc.main(["--paths", "nonsense"])
