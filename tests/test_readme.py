"""The README runs as written and stays short (tests/test_quotes.py holds its numbers)."""

from pathlib import Path

from rounding import run_page_examples

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
# Issue 25: a README a newcomer reads in two minutes (issue 34 added the study's headline
# table; tests/test_quotes.py holds its numbers to the report's).
MAX_LINES = 130


def test_readme_examples_run_as_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # an example may write files
    result = run_page_examples(README)  # numbers to the digits the page shows (tests/rounding.py)
    assert result.attempted > 0 and result.failed == 0, result


def test_readme_is_short():
    assert len(README.read_text().splitlines()) <= MAX_LINES


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
