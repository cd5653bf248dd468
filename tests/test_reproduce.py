"""validation.reproduce: the report end to end, its regenerability, and each decision rule.

The decision rules are checked on hand-made sweep tables whose verdicts are known by
construction; the report itself runs as ``--quick`` (2 seeds, about 1000 positions, a 2 x 2
fine map; the sphere cells only: the tests never read MNE's testing dataset) into two
folders, which also proves that it regenerates byte for byte. The first run takes the
default output folder, which must not be the committed report.
"""

import contextlib
import hashlib
import io
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from validation import reproduce as rp
from validation.reproduce.rules_v3 import VERDICTS_V3
from validation.reproduce.sensitivity import SENSITIVITY, crop_head
from validation.reproduce.settings import (
    CELLS,
    CONTROLS,
    DEFAULT_OUT,
    EXPONENTS,
    FINE_RANGE,
    FULL,
    MANIFEST,
    NOISE_LEVELS,
    QUICK_OUT,
    RESULTS,
    STAGES,
    TUNED_PRIOR,
    TUNING,
    VERDICTS,
    Settings,
)
from validation.reproduce.specificity_report import TIMINGS_TITLE
from validation.reproduce.tuned import TUNED, compare_tuned, paper_cells

# What the issue asks the tests to run: the quick report; without MNE's testing dataset (the
# tests never read it) only the sphere cells run and the BEM cells are marked "not run".
QUICK = ["--quick", "--jobs", "2"]
QUICK_SEEDS = 2
SPHERE_CELLS = [cell for cell in CELLS if not cell.realistic]
N_CELL_FIGURES = 6 + 1 + 2 + 4 + 2  # prior grids, exponents, seed points, averages, fine maps
FIGURE_LINK = re.compile(r"!\[[^\]]*\]\(([^)]+)\)")


def _snapshot(folder):
    """Every file under ``folder`` by relative name, with its SHA-256."""
    return {
        path.relative_to(folder).as_posix(): hashlib.sha256(path.read_bytes()).hexdigest()
        for path in sorted(folder.rglob("*"))
        if path.is_file()
    }


def _git_status(folder):
    """``git status --porcelain`` of ``folder``, or None outside a git checkout."""
    if shutil.which("git") is None:
        return None
    result = subprocess.run(
        ["git", "status", "--porcelain", "--", str(folder)],
        cwd=folder.parent,
        capture_output=True,
        text=True,
        check=False,
    )
    return result.stdout if result.returncode == 0 else None


def _no_dataset(patch, folder):
    """MNE's lookup of its testing dataset finds nothing (the tests never read it)."""
    import mne

    patch.setattr(mne.datasets.testing, "data_path", lambda **kwargs: folder / "no-dataset")


@pytest.fixture(scope="module")
def committed_report():
    """The committed report folder's files and git status before any report test runs."""
    return _snapshot(DEFAULT_OUT), _git_status(DEFAULT_OUT)


@pytest.fixture(scope="module")
def reports(tmp_path_factory, committed_report):
    """One run of the quick report, and a second that renders it again from its rows.

    The first runs without ``--out`` from a scratch current directory, so it writes to the
    default folder of a quick run. The second gets a copy of the first's results files and
    manifest only, in a folder given with ``--out``: it reuses every row and writes every
    page, table and figure anew (each figure's reconstructions recomputed and checked
    against their rows). Returns both folders, the first's standard error and the second's
    report text.
    """
    cwd = tmp_path_factory.mktemp("cwd")
    err = io.StringIO()
    with pytest.MonkeyPatch.context() as patch:
        _no_dataset(patch, cwd)
        patch.chdir(cwd)
        with contextlib.redirect_stderr(err):
            assert rp.main(QUICK) == 0
        first, second = cwd / QUICK_OUT, tmp_path_factory.mktemp("report1")
        for path in first.rglob("*.csv"):
            if path.name not in ("summary.csv", "scores.csv"):
                (second / path.relative_to(first)).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(path, second / path.relative_to(first))
        shutil.copy2(first / MANIFEST, second / MANIFEST)
        assert rp.main([*QUICK, "--out", str(second)]) == 0
    return [first, second], err.getvalue()


def _without_date(path):
    """The report's lines but the two that measure this run: its date and its run times."""
    text = path.read_text().split(TIMINGS_TITLE, 1)[0]
    return [line for line in text.splitlines() if not line.startswith("Generated:")]


def _section(text, title):
    return text.split(title, 1)[1].split("\n## ", 1)[0]


def _findings_rows(text, title="## Findings"):
    return [line for line in _section(text, title).splitlines() if re.match(r"\| F\d", line)]


def _verdict(cell):
    return cell.strip().strip("*")


@pytest.mark.slow  # the quick report, run twice: 2-4 minutes (.ci/run runs it)
class TestReport:
    def test_quick_run_leaves_the_committed_report_alone(self, reports, committed_report):
        files, status = committed_report
        assert (reports[0][0] / "REPORT.md").exists()  # the default folder of a quick run
        assert _snapshot(DEFAULT_OUT) == files
        assert _git_status(DEFAULT_OUT) == status

    def test_one_line_says_how_to_point_at_the_dataset(self, reports):
        lines = [line for line in reports[1].splitlines() if "testing dataset" in line]
        assert len(lines) == 1 and "--mne-testing-data DIR" in lines[0]

    def test_rules_come_before_the_findings(self, reports):
        text = (reports[0][0] / "REPORT.md").read_text()
        v1, v2 = text.index("## Decision rules\n"), text.index("## Decision rules, v2")
        assert 0 < v1 < v2 < text.index("## Decision rules, v3") < text.index("## Findings")
        assert text.count("Generated:") == 1

    def test_v1_v2_v3_verdicts_in_every_cell_and_not_run_without_the_dataset(self, reports):
        rows = _findings_rows((reports[0][0] / "REPORT.md").read_text())
        assert [row.split("|")[1].strip() for row in rows] == [f"F{i}" for i in range(1, 7)]
        for row in rows:
            cells = [cell.strip() for cell in row.strip(" |").split("|")[2:]]
            assert len(cells) == len(CELLS)
            for cell, text in zip(CELLS, cells, strict=True):
                if cell.realistic:
                    assert text == "not run"
                else:
                    v1, v2, v3 = (_verdict(v) for v in text.split(" / "))
                    assert v1 in VERDICTS and v2 in VERDICTS and v3 in VERDICTS_V3

    def test_every_linked_figure_exists(self, reports):
        folder = reports[0][0]
        links = FIGURE_LINK.findall((folder / "REPORT.md").read_text())
        assert links == [
            "source_placement.png",
            "worth/cross_talk.png",
            "worth/windows.png",
            "baselines/roc.png",
            "baselines/deep_scores.png",
        ]
        for k, cell in enumerate(SPHERE_CELLS):  # --quick draws the first cell's only
            page = folder / cell.name / "CELL.md"
            cell_links = FIGURE_LINK.findall(page.read_text())
            assert len(set(cell_links)) == (N_CELL_FIGURES if k == 0 else 0)
            assert ("Not drawn: a --quick run" in page.read_text()) == (k > 0)
            links += [f"{cell.name}/{name}" for name in cell_links]
        for name in links:
            assert (folder / name).read_bytes().startswith(b"\x89PNG")

    def test_tables_and_controls_written(self, reports):
        for cell in SPHERE_CELLS:
            folder = reports[0][0] / cell.name
            for name in ("paper_grid.csv", "fine_grid.csv", "summary.csv", *CONTROLS.values()):
                assert len(pd.read_csv(folder / name)) > 0, name
            paper = pd.read_csv(folder / "paper_grid.csv")
            # snr, EP, PM, exponent, smoother, seed
            assert len(paper) == 3 * 2 * 2 * 4 * 3 * QUICK_SEEDS
            assert set(paper["conductor"]) == {cell.conductor}
            assert set(paper["source_space"]) == {cell.source_space}
            for source, name in CONTROLS.items():
                control = pd.read_csv(folder / name)
                assert set(control["sources"]) == {source}
                # F4's corners (12) and every exponent and smoother at EP 20, PM 0 (36),
                # one setting shared, at each seed
                assert len(control) == (12 + 36 - 3) * QUICK_SEEDS
            summary = pd.read_csv(folder / "summary.csv")
            for column in ("score", "echo"):  # the quartiles beside mean and SE
                q1, median, q3 = (summary[f"{column}_{q}"] for q in ("q1", "median", "q3"))
                assert ((q1 <= median) & (median <= q3)).all()
        text = (reports[0][0] / "REPORT.md").read_text()
        assert "## Controls" in text and "## A lone source" in text
        for title in ("## Controls", "## A lone source"):  # median [Q1, Q3] and seeds
            section = _section(text, title)
            assert "| seeds |" in section and re.search(r"\d \[-?\d", section)
        assert not (reports[0][0] / "variants").exists()  # the variants: full runs only

    def test_regenerable_byte_for_byte(self, reports):
        first, second = reports[0]
        assert _without_date(first / "REPORT.md") == _without_date(second / "REPORT.md")
        assert (first / "source_placement.png").read_bytes() == (
            second / "source_placement.png"
        ).read_bytes()
        for cell in SPHERE_CELLS:
            a, b = first / cell.name, second / cell.name
            assert (a / "CELL.md").read_text() == (b / "CELL.md").read_text()
            for name in FIGURE_LINK.findall((a / "CELL.md").read_text()):
                assert (a / name).read_bytes() == (b / name).read_bytes(), name
            names = ["paper_grid.csv", "fine_grid.csv", "summary.csv", *CONTROLS.values(), TUNED]
            if cell.name == "sphere-volume":
                names.append(SENSITIVITY)
            for name in names:
                assert (a / name).read_bytes() == (b / name).read_bytes(), name
        runs = sorted((first / "worth" / "runs").rglob("*.csv.gz"))  # recomputed by the second
        assert runs
        for path in runs:
            other = second / path.relative_to(first)
            assert path.read_bytes() == other.read_bytes(), path.relative_to(first)

    def test_sensitivity_follows_the_discussion(self, reports):
        text = (reports[0][0] / "sphere-volume" / "CELL.md").read_text()
        title = "## Sensitivity (post hoc): source grid above the lowest electrode"
        assert text.index("## Discussion") < text.index(title) < text.index("## Tables")
        section = _section(text, title)
        assert re.search(r"\d+ of \d+ positions remain", section)
        rows = [line for line in section.splitlines() if re.match(r"\| F\d", line)]
        assert [row.split("|")[1].strip() for row in rows] == ["F5", "F6"]
        table = pd.read_csv(reports[0][0] / "sphere-volume" / SENSITIVITY)
        # snr, exponent, smoother (none, rts-standardized), seed
        assert len(table) == 3 * 4 * 2 * QUICK_SEEDS

    def test_each_cell_page_has_every_rule_set(self, reports):
        for cell in SPHERE_CELLS:
            text = (reports[0][0] / cell.name / "CELL.md").read_text()
            for title in (f"## Findings by the v{v} rules" for v in (1, 2, 3)):
                rows = _findings_rows(text, title)
                assert [row.split("|")[1].strip() for row in rows] == [
                    f"F{i}" for i in range(1, 7)
                ]

    def test_priors_chosen_by_the_data(self, reports):
        text = (reports[0][0] / "REPORT.md").read_text()
        section = _section(text, "## Priors chosen by the data")
        rows = [line for line in section.splitlines() if line.startswith("| sphere")]
        settings = len(SPHERE_CELLS) * len(NOISE_LEVELS) * len(STAGES)
        for name in ("marginal likelihood", "discrepancy principle"):
            tuned = [row for row in rows if f"| {name}, per seed |" in row]
            assert len(tuned) == settings
            met = sum(row.rstrip(" |").endswith("| met") for row in tuned)
            assert f"by the {name}: met in {met} of {settings} settings" in section
            # the bound counts: one row per cell, noise level and criterion
            bounds = [row for row in rows if f"| {name} | {QUICK_SEEDS} |" in row]
            assert len(bounds) == len(SPHERE_CELLS) * len(NOISE_LEVELS)
        # the best cell is chosen on the first half of the seeds and scored on the other
        assert "best of the map, chosen on seed 0 |" in section
        assert "scored on seed 1 (1 seed, none of which chose the best cell)" in section
        for cell in SPHERE_CELLS:
            table = pd.read_csv(reports[0][0] / cell.name / TUNED)
            assert len(table) == 2 * len(NOISE_LEVELS) * len(STAGES) * QUICK_SEEDS
            # one choice per criterion, noise level and seed, shared by both stages
            keys = ["criterion", "snr_db", "seed"]
            choices = table.groupby(keys)[["ep_snr_db", "pm_snr_db"]].nunique()
            assert (choices == 1).all().all()
            assert table["ep_snr_db"].between(*FINE_RANGE).all()
            assert table["pm_snr_db"].between(*FINE_RANGE).all()
            # every SNR on a bound gave one warning, caught and counted
            on_bound = (table["pm_bound"] != "none").astype(int) + (table["ep_bound"] != "none")
            assert (table["bound_warnings"] == on_bound).all()

    def test_rerun_reuses_rows_and_gives_the_same_report(self, reports):
        # the second run found every row in its results files and computed none
        generated = [
            line
            for line in (reports[0][1] / "REPORT.md").read_text().splitlines()
            if "Generated:" in line
        ]
        assert "(0 of " in generated[0]


def test_crop_keeps_the_positions_at_or_above_the_lowest_electrode():
    from skf_ref.study import scenario as simulate

    head = simulate.make_head_model(500)
    cropped = crop_head(head)
    floor = rp.electrode_floor(head)
    assert (cropped.positions[:, 2] >= floor).all()
    assert 0 < cropped.n_positions < head.n_positions
    assert cropped.n_positions == (head.positions[:, 2] >= floor).sum()
    # the three lead-field columns of each kept position, in order
    kept = np.flatnonzero(head.positions[:, 2] >= floor)
    L = head.leadfield.reshape(head.n_channels, -1, 3)[:, kept].reshape(head.n_channels, -1)
    np.testing.assert_array_equal(cropped.leadfield, L)


class TestPrepareOut:
    def _stale_folder(self, tmp_path, recorded):
        for name in RESULTS:
            (tmp_path / name).write_text("n_positions\n1\n")
        (tmp_path / MANIFEST).write_text(json.dumps(recorded))

    def test_same_settings_keep_the_results(self, tmp_path):
        wanted = {"seeds": 3}
        self._stale_folder(tmp_path, wanted)
        assert rp.prepare_out(tmp_path, wanted) is None
        assert all((tmp_path / name).exists() for name in RESULTS)

    def test_changed_settings_delete_the_results(self, tmp_path):
        self._stale_folder(tmp_path, {"seeds": 3})
        assert "changed" in rp.prepare_out(tmp_path, {"seeds": 4})
        assert not any((tmp_path / name).exists() for name in RESULTS)
        assert json.loads((tmp_path / MANIFEST).read_text()) == {"seeds": 4}

    def test_missing_manifest_deletes_the_results(self, tmp_path):
        self._stale_folder(tmp_path, {})
        (tmp_path / MANIFEST).unlink()
        assert rp.prepare_out(tmp_path, {"seeds": 3}) is not None
        assert not any((tmp_path / name).exists() for name in RESULTS)

    def test_fresh_deletes_the_results(self, tmp_path):
        self._stale_folder(tmp_path, {"seeds": 3})
        assert rp.prepare_out(tmp_path, {"seeds": 3}, fresh=True) == "--fresh"
        assert not any((tmp_path / name).exists() for name in RESULTS)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--jobs", "0"], "--jobs"),
        (["--seeds", "1"], "--seeds"),
        (["--fine-step", "7"], "--fine-step"),
        (["--fine-step", "-10"], "--fine-step"),
        (["--bogus"], "unrecognized"),
        (["--n-positions", "10"], "n_positions"),
        (["--mne-testing-data", "."], "testing_data must be MNE's testing dataset folder"),
    ],
)
def test_bad_arguments_print_one_line_and_return_2(argv, message, tmp_path, capsys, monkeypatch):
    _no_dataset(monkeypatch, tmp_path)
    assert rp.main([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["--quick", "--out", str(DEFAULT_OUT)],
        ["--seeds", "3", "--out", str(DEFAULT_OUT)],
        ["--n-positions", "1000", "--out", str(DEFAULT_OUT / "sub")],
        ["--fine-step", "20", "--out", str(DEFAULT_OUT / ".." / DEFAULT_OUT.name)],
        ["--out", str(DEFAULT_OUT)],  # no testing dataset: the sphere cells only
    ],
)
def test_partial_run_into_the_committed_report_is_refused(argv, capsys, monkeypatch, tmp_path):
    _no_dataset(monkeypatch, tmp_path)
    before = _snapshot(DEFAULT_OUT)
    assert rp.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "committed report folder" in err
    assert _snapshot(DEFAULT_OUT) == before
    assert not (DEFAULT_OUT / "sub").exists()


def test_output_folder():
    quick = Settings(seeds=2, n_positions=1000, fine_step=60.0, quick=True)
    assert rp.output_folder(FULL) == DEFAULT_OUT
    assert rp.output_folder(Settings(seeds=10)) == DEFAULT_OUT  # the full preset's values
    assert rp.output_folder(FULL, DEFAULT_OUT) == DEFAULT_OUT
    assert rp.output_folder(quick) == QUICK_OUT
    assert rp.output_folder(Settings(seeds=4)) == QUICK_OUT
    assert rp.output_folder(Settings(realistic=False)) == QUICK_OUT  # no BEM cells
    assert rp.output_folder(quick, Path("elsewhere")) == Path("elsewhere")
    with pytest.raises(ValueError, match="is the committed report folder"):
        rp.output_folder(Settings(n_positions=500), DEFAULT_OUT)


@pytest.mark.slow
def test_runs_as_a_module():
    """``python -m validation.reproduce`` reaches :func:`main` (bad arguments: exit 2)."""
    result = subprocess.run(
        [sys.executable, "-m", "validation.reproduce", "--bogus"],
        cwd=Path(__file__).resolve().parents[1],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 2
    assert result.stderr.startswith("reproduce: unrecognized arguments: --bogus")


# --------------------------------------------------------------------------- rule tables


def _rows(snr, ep, pm, scores, exponent=0.5, smoother="none", **metrics):
    """One row per seed; both peak errors equal the given score, so the score is that."""
    n = len(scores)
    columns = dict(
        deep_detected=True,
        deep_region_db=0.0,
        deep_region_at_superficial_peak_db=-20.0,
        echo=0.0,
        separation=False,
    )
    columns.update(metrics)
    columns = {k: list(v) if np.ndim(v) else [v] * n for k, v in columns.items()}
    return pd.DataFrame(
        dict(
            snr_db=snr,
            ep_snr_db=ep,
            pm_snr_db=pm,
            exponent=exponent,
            smoother=smoother,
            seed=range(n),
            deep_error_mm=scores,
            superficial_error_mm=scores,
            **columns,
        )
    )


def _corners(snr, means, spread=1.0, **metrics):
    """The 2 x 2 tuning grid at one noise level: ``means`` maps (EP, PM) -> mean score."""
    return pd.concat(
        [
            _rows(snr, ep, pm, [mean - spread, mean, mean + spread], **metrics)
            for (ep, pm), mean in means.items()
        ]
    )


def _means(m00, m20_0, m0_20, m20_20):
    """(EP, PM) -> mean from the four means in the order (0,0), (20,0), (0,20), (20,20)."""
    return {(0.0, 0.0): m00, (20.0, 0.0): m20_0, (0.0, 20.0): m0_20, (20.0, 20.0): m20_20}


class TestStatistics:
    def test_mean_and_standard_error(self):
        table = _rows(10.0, 0.0, 0.0, [1.0, 2.0, 6.0])
        mean, se, n = rp.cell_stats(table, 10.0, 0.0, 0.0, 0.5, "none")
        assert (mean, n) == (3.0, 3)
        assert se == pytest.approx(np.std([1.0, 2.0, 6.0], ddof=1) / np.sqrt(3))

    def test_missing_setting_is_named(self):
        with pytest.raises(ValueError, match="no rows for snr_db=20, ep_snr_db=0"):
            rp.cell_stats(_rows(10.0, 0.0, 0.0, [1.0]), 20.0, 0.0, 0.0, 0.5, "none")

    def test_undefined_echo_is_left_out(self):
        table = _rows(10.0, 0.0, 0.0, [1.0, 1.0, 1.0], echo=[0.5, np.nan, 0.7])
        mean, _, n = rp.cell_stats(table, 10.0, 0.0, 0.0, 0.5, "none", "echo")
        assert (mean, n) == (pytest.approx(0.6), 2)


class TestF1:
    def test_reproduced(self):
        finding = rp.rule_f1(_corners(10.0, _means(10, 40, 20, 50)))
        assert finding.verdict == "reproduced"

    def test_pm_hurting_more_is_partly(self):
        assert rp.rule_f1(_corners(10.0, _means(10, 20, 40, 50))).verdict == "partly"

    def test_other_best_is_partly(self):
        assert rp.rule_f1(_corners(10.0, _means(30, 40, 20, 50))).verdict == "partly"

    def test_neither_is_not_reproduced(self):
        finding = rp.rule_f1(_corners(10.0, _means(30, 35, 40, 10)))
        assert finding.verdict == "not reproduced"

    def test_a_tie_for_best_is_no_best(self):
        finding = rp.rule_f1(_corners(10.0, _means(10, 40, 10, 50)))
        assert [ok for _, ok in finding.criteria] == [False, True]


class TestF2:
    AT_10 = _means(10, 40, 20, 50)  # spread 40 mm

    def _table(self, at_20):
        return pd.concat([_corners(10.0, self.AT_10), _corners(20.0, at_20)])

    def test_reproduced(self):
        assert rp.rule_f2(self._table(_means(10, 15, 12, 20))).verdict == "reproduced"

    def test_more_sensitive_than_at_10_db_is_partly(self):
        assert rp.rule_f2(self._table(_means(10, 80, 12, 90))).verdict == "partly"

    def test_other_best_and_more_sensitive_is_not_reproduced(self):
        finding = rp.rule_f2(self._table(_means(50, 10, 60, 90)))
        assert finding.verdict == "not reproduced"


class TestF3:
    def test_ep_20_best_is_reproduced(self):
        assert rp.rule_f3(_corners(30.0, _means(20, 10, 30, 40))).verdict == "reproduced"

    def test_pm_20_best_is_reproduced(self):
        assert rp.rule_f3(_corners(30.0, _means(20, 30, 10, 40))).verdict == "reproduced"

    def test_both_tied_best_is_reproduced(self):
        assert rp.rule_f3(_corners(30.0, _means(20, 10, 10, 40))).verdict == "reproduced"

    def test_within_one_standard_error_is_partly(self):
        # spread 3 -> SE = 3 / sqrt(3) = 1.73 mm; (EP 20, PM 0) is 1 mm above the best
        table = _corners(30.0, _means(10, 11, 30, 40), spread=3.0)
        assert rp.rule_f3(table).verdict == "partly"

    def test_far_from_best_is_not_reproduced(self):
        table = _corners(30.0, _means(10, 20, 30, 40), spread=3.0)
        assert rp.rule_f3(table).verdict == "not reproduced"


class TestF4:
    def _table(self, echo_at_best):
        """Best cell (0, 0) at every level; echo of the best cell per level, 0.9 elsewhere."""
        frames = []
        for snr, echo in zip(NOISE_LEVELS, echo_at_best, strict=True):
            for (ep, pm), mean in _means(10, 40, 20, 50).items():
                value = echo if (ep, pm) == (0.0, 0.0) else [0.9, 0.9, 0.9]
                frames.append(_rows(snr, ep, pm, [mean - 1, mean, mean + 1], echo=value))
        return pd.concat(frames)

    def test_echo_at_every_level_is_reproduced(self):
        finding = rp.rule_f4(self._table([[0.5, 0.6, 0.55]] * 3))
        assert finding.verdict == "reproduced"

    def test_echo_at_one_level_is_partly(self):
        echoes = [[0.5, 0.6, 0.55], [-0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]]
        assert rp.rule_f4(self._table(echoes)).verdict == "partly"

    def test_echo_only_away_from_the_best_cell_is_not_reproduced(self):
        assert rp.rule_f4(self._table([[-0.1, 0.1, 0.0]] * 3)).verdict == "not reproduced"


class TestF5:
    def _table(self, suppress=True, best=1.25, missed=(False, False, True), high=(-3, -3, -9)):
        ep, pm = TUNED_PRIOR
        scores = {1.0: 30.0, 1.25: 20.0, 1.5: 25.0, 0.5: 5.0}
        scores[best] = 10.0
        frames = []
        for exponent in EXPONENTS:
            frames.append(_rows(30.0, ep, pm, [50.0] * 3, exponent, deep_region_db=-2.0))
            metrics = dict(deep_region_db=-5.0 if suppress else 0.0)
            if exponent == 1.0:
                metrics["deep_detected"] = list(missed)
            if exponent == 1.5:
                metrics["deep_region_at_superficial_peak_db"] = list(high)
            frames.append(
                _rows(
                    30.0, ep, pm, [scores[exponent]] * 3, exponent, "rts-standardized", **metrics
                )
            )
        return pd.concat(frames)

    def test_all_four_is_reproduced(self):
        finding = rp.rule_f5(self._table())
        assert [ok for _, ok in finding.criteria] == [True] * 4
        assert finding.verdict == "reproduced"

    def test_exponent_1_best_is_partly(self):
        finding = rp.rule_f5(self._table(best=1.0))
        assert [ok for _, ok in finding.criteria] == [True, False, True, True]
        assert finding.verdict == "partly"

    def test_none_is_not_reproduced(self):
        table = self._table(suppress=False, best=1.5, missed=(True, True, False), high=(-9,) * 3)
        assert rp.rule_f5(table).verdict == "not reproduced"


class TestF6:
    def _table(self, smoothed, plain):
        ep, pm = TUNED_PRIOR
        frames = []
        for snr, sep_s, sep_n in zip(NOISE_LEVELS, smoothed, plain, strict=True):
            frames.append(
                _rows(snr, ep, pm, [1.0] * 4, 1.25, "rts-standardized", separation=sep_s)
            )
            frames.append(_rows(snr, ep, pm, [1.0] * 4, 1.25, "none", separation=sep_n))
        return pd.concat(frames)

    HALF = [True, True, False, False]
    NONE = [False] * 4

    def test_separation_at_every_level_is_reproduced(self):
        finding = rp.rule_f6(self._table([self.HALF] * 3, [self.NONE] * 3))
        assert finding.verdict == "reproduced"

    def test_no_better_than_unsmoothed_is_partly(self):
        finding = rp.rule_f6(self._table([self.HALF] * 3, [self.NONE, self.HALF, self.HALF]))
        assert finding.verdict == "partly"

    def test_below_half_is_not_reproduced(self):
        rare = [True, False, False, False]
        finding = rp.rule_f6(self._table([rare] * 3, [self.NONE] * 3))
        assert finding.verdict == "not reproduced"


def test_evaluate_on_a_full_table_gives_six_findings():
    frames = [_corners(snr, _means(10, 40, 20, 50)) for snr in NOISE_LEVELS]
    frames.append(TestF5()._table())
    frames.append(TestF6()._table([TestF6.HALF] * 3, [TestF6.NONE] * 3))
    # F5 and F6 add 30 dB EP 20 PM 0 rows; keep the tuning corners unique
    table = pd.concat(frames).drop_duplicates(
        ["snr_db", "ep_snr_db", "pm_snr_db", "exponent", "smoother", "seed"]
    )
    findings = rp.evaluate(table)
    assert [f.number for f in findings] == [1, 2, 3, 4, 5, 6]
    assert all(f.verdict in VERDICTS for f in findings)


def test_blas_order_does_not_change_the_outputs(monkeypatch):
    # threadpoolctl lists the BLAS libraries in an order that varies between processes;
    # the manifest and the results files must not depend on it.
    from validation.reproduce import cells, settings

    libraries = [
        {"library": "openblas", "version": "0.3.31", "threads": 2, "threading_layer": "pthreads"},
        {"library": "openblas", "version": "0.3.30", "threads": 2, "threading_layer": "pthreads"},
    ]
    manifests = []
    for order in (libraries, libraries[::-1]):
        monkeypatch.setattr(settings, "blas_threads", lambda order=order: list(order))
        manifests.append(settings.manifest(FULL)["blas"])
    assert manifests[0] == manifests[1]
    assert cells._sorted_words("openblas-0.3.31 openblas-0.3.30") == cells._sorted_words(
        "openblas-0.3.30 openblas-0.3.31"
    )
    assert cells._sorted_words("none") == "none"


# --------------------------------------------------------------------------- tuned priors


def _stage_rows(errors, seeds=4, **columns):
    """Rows at every noise level and stage: ``errors`` maps (EP, PM) -> a score (mm), the
    error of seed s being score + (s - 1.5), or a function of the seed giving it."""
    rows = []
    for snr in NOISE_LEVELS:
        for _, (exponent, smoother) in STAGES:
            for (ep, pm), score in errors.items():
                for seed in range(seeds):
                    error = score(seed) if callable(score) else score + (seed - 1.5)
                    rows.append(
                        dict(
                            snr_db=snr,
                            ep_snr_db=ep,
                            pm_snr_db=pm,
                            exponent=exponent,
                            smoother=smoother,
                            seed=seed,
                            deep_error_mm=error,
                            superficial_error_mm=error,
                            deep_corr=0.5,
                            superficial_corr=0.7,
                            separation=seed < 2,
                        )
                        | columns
                    )
    return pd.DataFrame(rows)


def _tuned_rows(score, seeds=4):
    """Both criteria's rows: per-seed priors (EP 13 + 0.1 seed, PM on the lower bound)."""
    frames = []
    for criterion in ("likelihood", "discrepancy"):
        rows = _stage_rows({(13.0, -20.0): score}, seeds, criterion=criterion)
        rows["ep_snr_db"] += 0.1 * rows["seed"]
        rows = rows.assign(pm_bound="lower", ep_bound="none", bound_warnings=1)
        frames.append(rows)
    return pd.concat(frames, ignore_index=True)


class TestTunedComparison:
    # choose on seeds 0, 1 and score on 2, 3: with errors score + (-1.5, -0.5, 0.5, 1.5),
    # a cell of score 10 has median 11.0, Q1 10.75 and Q3 11.25 on the scoring seeds
    fixed = _stage_rows(
        {(0.0, 0.0): 10.0, (20.0, 0.0): 12.0, (0.0, 20.0): 20.0, (20.0, 20.0): 30.0}
    )

    def test_the_seeds_that_choose_and_the_seeds_that_score_are_disjoint(self):
        from validation.reproduce.tuned import split_seeds

        assert split_seeds(10) == (range(0, 5), range(5, 10))
        assert split_seeds(QUICK_SEEDS) == (range(0, 1), range(1, 2))
        for seeds in range(2, 13):
            choose, score = split_seeds(seeds)
            assert choose and score and not set(choose) & set(score)
            assert sorted([*choose, *score]) == list(range(seeds))
        for comparison in compare_tuned(_tuned_rows(10.0), self.fixed, seeds=4):
            assert comparison.choose_seeds == (0, 1) and comparison.score_seeds == (2, 3)
            for entry in (*comparison.tuned.values(), comparison.best, *comparison.paper):
                assert entry.score[3] == 2 and entry.separated[1] == 2  # scoring seeds only

    def test_the_best_cell_is_chosen_on_the_first_half_and_scored_on_the_other(self):
        # (20, 0) is best on seeds 0, 1 (8 mm) and worst of the two on seeds 2, 3 (14 mm)
        flip = {(0.0, 0.0): 10.0, (20.0, 0.0): lambda seed: 8.0 if seed < 2 else 14.0}
        out = compare_tuned(_tuned_rows(10.0), _stage_rows(flip), seeds=4)
        for comparison in out:
            assert comparison.best.priors == "(EP 20, PM 0)"
            assert comparison.best.score == (14.0, 14.0, 14.0, 2)

    def test_the_best_cell_is_the_lowest_median_and_the_paper_cells_follow_the_paper(self):
        out = compare_tuned(_tuned_rows(10.0), self.fixed, seeds=4)
        assert len(out) == len(NOISE_LEVELS) * len(STAGES)
        for comparison in out:
            assert comparison.best.priors == "(EP 0, PM 0)"
            assert comparison.best.score == (11.0, 10.75, 11.25, 2)
            assert [p.priors for p in comparison.paper] == [
                f"(EP {e:g}, PM {p:g})" for e, p in paper_cells(comparison.snr, comparison.stage)
            ]
        assert paper_cells(30.0, TUNING) == [(20.0, 0.0), (0.0, 20.0)]
        assert paper_cells(10.0, TUNING) == [(0.0, 0.0)]

    def test_a_median_at_the_best_cells_q3_meets_the_target(self):
        out = compare_tuned(_tuned_rows(10.25), self.fixed, seeds=4)  # median 11.25
        assert all(all(c.met.values()) for c in out)
        tuned = out[0].tuned["discrepancy"]
        assert tuned.score[0] == pytest.approx(11.25)
        assert tuned.separated == (0, 2) and tuned.correlation == (0.6, 0.6, 0.6, 2)

    def test_a_median_beyond_the_best_cells_q3_misses_it(self):
        out = compare_tuned(_tuned_rows(10.26), self.fixed, seeds=4)
        assert not any(any(c.met.values()) for c in out)

    def test_a_lower_separation_rate_misses_it(self):
        fixed = self.fixed.assign(separation=True)  # the best cell: 2 of 2 scoring seeds
        tuned = _tuned_rows(10.0)
        tuned["separation"] = tuned["seed"] < 3  # 1 of 2: 50 % < 90 % of 100 %
        assert not any(any(c.met.values()) for c in compare_tuned(tuned, fixed, seeds=4))
        tuned["separation"] = True
        assert all(all(c.met.values()) for c in compare_tuned(tuned, fixed, seeds=4))

    def test_choices_on_the_range_ends_are_counted_over_every_seed(self):
        out = compare_tuned(_tuned_rows(10.0), self.fixed, seeds=4)
        for comparison in out:
            for bounds in comparison.bounds.values():
                assert (bounds.seeds, bounds.pm_snr_db, bounds.ep_snr_db) == (4, (4, 0), (0, 0))
                assert bounds.warnings == 4
        # the median [Q1, Q3] of the scoring seeds' choices: EP 13.2 and 13.3
        assert out[0].tuned["likelihood"].priors == "EP 13.2 [13.2, 13.3], PM -20.0 [-20.0, -20.0]"
