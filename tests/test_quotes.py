"""Every number the README and the documentation quote from the study comes from the report.

``python -m validation.reproduce`` writes ``validation/report/headline.json``: the headline
tables (at 20 and 30 dB) and every number of the default's verdict. The README's section "What
the SKF is worth", and the documentation's sections on it, must print those tables as written
and quote no number the report did not produce.
"""

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEADLINE = ROOT / "validation" / "report" / "headline.json"
REPORT = ROOT / "validation" / "report" / "REPORT.md"
#: (file, the heading of the section that quotes the study, the headline tables it prints;
#: None: all): the section runs to the next heading of the same or a higher level. The
#: README, kept short, prints the 20 dB table and links to the others.
QUOTING = (
    ("README.md", "## What the SKF is worth", ("20 dB",)),
    ("docs/choosing.md", "## What the SKF is worth", None),
    ("docs/study.md", "## What the report says", None),
)


def _section(path, heading):
    text = (ROOT / path).read_text()
    start = text.index(f"\n{heading}\n")
    level = heading.split(" ", 1)[0]
    rest = text[start + len(heading) + 2 :]
    stop = re.search(rf"^#{{1,{len(level)}}} ", rest, flags=re.MULTILINE)
    return rest[: stop.start()] if stop else rest


@pytest.fixture(scope="module")
def headline():
    return json.loads(HEADLINE.read_text())


@pytest.mark.parametrize(("path", "heading", "names"), QUOTING)
def test_the_headline_tables_are_printed_as_the_report_wrote_them(headline, path, heading, names):
    section = _section(path, heading)
    for name in names or headline["tables"]:
        assert f"**{name}**" in section, f"{path}: no {name} table"
        table = headline["tables"][name]
        assert table in section, f"{path}: the {name} table differs from headline.json's"


@pytest.mark.parametrize(("path", "heading", "names"), QUOTING)
def test_every_number_quoted_is_the_reports(headline, path, heading, names):
    section = _section(path, heading)
    for table in headline["tables"].values():
        section = section.replace(table, "")
    section = re.sub(r"`[^`]*`|\([^()]*\.(?:md|png|py)[^()]*\)", "", section)  # code, links
    quotable = set(headline["quotable"])
    quoted = set(re.findall(r"\d+(?:\.\d+)?", section))
    assert quoted <= quotable, f"{path}: numbers not in headline.json: {sorted(quoted - quotable)}"


def test_the_report_prints_the_same_tables(headline):
    report = REPORT.read_text()
    for table in headline["tables"].values():
        assert table in report
