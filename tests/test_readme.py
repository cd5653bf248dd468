"""The README runs as written, and its summary table says what the report measured."""

import doctest
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
REPORT = ROOT / "validation" / "report" / "REPORT.md"
# Issue 25: a README a newcomer reads in two minutes.
MAX_LINES = 120


def test_readme_examples_run_as_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # an example may write files
    result = doctest.testfile(
        str(README),
        module_relative=False,
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
    )
    assert result.attempted > 0 and result.failed == 0, result


def test_readme_is_short():
    assert len(README.read_text().splitlines()) <= MAX_LINES


def _summary_rows(text):
    """The rows of the summary table: (label start, deep AUCs 10/20/30 dB, errors at 30 dB)."""
    return re.findall(
        r"^\| (the paper's|recommended|best MNE baseline)\b.*? \| "
        r"([\d.]+) / ([\d.]+) / ([\d.]+) \| (\d+) / (\d+) mm \|$",
        text,
        re.M,
    )


def test_summary_table_is_the_report_s():
    readme = _summary_rows(README.read_text())
    assert len(readme) == 3
    # the report's scored table: deep AUC and errors at 10, 20 and 30 dB, one row a setting
    auc, errors = r"\| ([\d.]+) ", r"\| \d+ / \d+ mm "
    report = re.findall(
        r"^\| (the paper's|recommended|best MNE baseline)\b[^|]*"
        + auc
        + errors
        + auc
        + errors
        + auc
        + r"\| (\d+) / (\d+) mm \|$",
        REPORT.read_text(),
        re.M,
    )
    assert readme == report
    # the documentation's page on choosing a setting shows the same table
    assert _summary_rows((ROOT / "docs" / "choosing.md").read_text()) == readme


def test_nothing_cites_files_outside_the_repository():
    private = "SKF" + "_SPEC"  # spelled apart so that this file does not cite it either
    texts = [
        README,
        *ROOT.glob("docs/**/*.md"),
        *ROOT.glob("docs/**/*.rst"),
        *ROOT.glob("docs/**/*.py"),
        *ROOT.glob("skf_ref/**/*.py"),
    ]
    for path in texts:
        if "_build" in path.parts or "auto_examples" in path.parts or "generated" in path.parts:
            continue
        text = path.read_text()
        assert private not in text and "../shared" not in text, path
        assert "/work/" not in text, path
