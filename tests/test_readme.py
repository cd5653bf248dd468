"""The README runs as written, and its tables say what the code does."""

import doctest
import re
from pathlib import Path

from skf_ref.study import metrics

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


def test_readme_examples_run_as_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the examples write files
    result = doctest.testfile(
        str(README),
        module_relative=False,
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
    )
    assert result.attempted > 0 and result.failed == 0, result
    assert (tmp_path / "skf-own-data-vl.stc").exists() and (tmp_path / "skf-own-data.png").exists()


def test_metrics_table_is_the_code_s():
    rows = re.findall(r"^\| `(\w+)` \| (.+?) \| (.+?) \| (.+?) \|$", README.read_text(), re.M)
    assert rows == [tuple(column) for column in metrics.COLUMNS]


def test_nothing_cites_files_outside_the_repository():
    private = "SKF" + "_SPEC"  # spelled apart so that this file does not cite it either
    texts = [README, *ROOT.glob("docs/*.md"), *ROOT.glob("skf_ref/**/*.py")]
    for path in texts:
        text = path.read_text()
        assert private not in text and "../shared" not in text, path
