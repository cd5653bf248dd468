"""The documentation site cannot rot: its pages' examples run, every public name and every
command has a page, its tables are the code's, and the citation metadata agree.

Nothing here needs Sphinx: the pages are read as text (the site itself is built, warnings as
errors, by README's docs command in .ci/run).
"""

import argparse
import ast
import configparser
import importlib
import re
import sys
from importlib import metadata
from pathlib import Path

import pytest
from rounding import run_page_examples

import skf_ref
from skf_ref.cli import build_parser
from skf_ref.study import _metrics as metrics

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
# Pages whose examples are doctests (```pycon blocks); model.md has its own runner
# (tests/test_model_doc.py).
PAGES_WITH_EXAMPLES = ("getting_started.md", "choosing.md", "scale.md", "conformance.md")
# At least this many executed examples in the gallery (issue 25).
MIN_GALLERY = 6


def _pages():
    return sorted(p for p in DOCS.glob("*") if p.suffix in (".md", ".rst"))


@pytest.mark.parametrize("name", PAGES_WITH_EXAMPLES)
def test_page_examples_run_as_written(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the examples write files
    result = run_page_examples(DOCS / name)  # numbers to the page's digits (tests/rounding.py)
    assert result.attempted > 0 and result.failed == 0, result


def test_every_page_with_python_examples_is_run():
    with_examples = {p.name for p in _pages() if re.search(r"^>>> ", p.read_text(), re.M)}
    assert with_examples == set(PAGES_WITH_EXAMPLES)


def test_every_page_is_in_the_navigation():
    # a page outside every toctree is built but not reachable (docs/mne.md was, once)
    entries = set()
    for block in re.findall(
        r"^\.\. toctree::\n((?:   .*\n|\n)+)", (DOCS / "index.rst").read_text(), re.M
    ):
        entries |= {line.strip() for line in block.splitlines() if re.match(r"   [\w/]+$", line)}
    built = {"index", "sg_execution_times"}  # the root, and sphinx-gallery's timing page
    assert {p.stem for p in _pages()} - built <= entries


def _autosummary_entries(text):
    """The names listed under every ``.. autosummary::`` directive of an .rst text."""
    names = []
    for block in re.findall(r"^\.\. autosummary::\n((?:   .*\n|\n)+)", text, re.M):
        names += [line.strip() for line in block.splitlines() if re.match(r"   [\w.]+$", line)]
    return names


def _public_modules():
    """The documented modules (docs/sphinxext/skf_docs.py; tests/test_api.py holds them)."""
    sys.path.insert(0, str(DOCS / "sphinxext"))
    try:
        return importlib.import_module("skf_docs").PUBLIC_MODULES
    finally:
        sys.path.remove(str(DOCS / "sphinxext"))


def test_every_public_name_and_module_has_a_page():
    listed = set(_autosummary_entries((DOCS / "api.rst").read_text()))
    assert {f"skf_ref.{name}" for name in skf_ref.__all__} <= listed
    assert set(_public_modules()) <= listed


def test_every_name_a_module_page_links_to_is_documented():
    sys.path.insert(0, str(DOCS / "sphinxext"))
    try:
        skf_docs = importlib.import_module("skf_docs")
    finally:
        sys.path.remove(str(DOCS / "sphinxext"))
    pages, aliases = skf_docs.api_pages()
    documented = {f"skf_ref.{name}" for name in skf_ref.__all__} | {"skf_ref", *pages}
    for module, page in pages.items():
        documented |= {f"{module}.{name}" for name, _ in page["here"]}
    for module, page in pages.items():
        here = {name for name, _ in page["here"]}
        elsewhere = {name for name, _, _ in page["elsewhere"]}
        assert here | elsewhere == set(getattr(importlib.import_module(module), "__all__", []))
        for name, target, _ in page["elsewhere"]:
            assert target in documented, f"{module}.{name} links to {target}, which has no page"
    assert set(aliases.values()) <= documented


def _subcommands(parser, prefix=()):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield " ".join((*prefix, name))
                yield from _subcommands(sub, (*prefix, name))


def test_every_command_has_a_section():
    text = (DOCS / "cli.rst").read_text()
    documented = set(re.findall(r"^   :path: (.+)$", text, re.M))
    leaves = {path for path in _subcommands(build_parser())}
    leaves -= {path for path in leaves if any(o.startswith(path + " ") for o in leaves)}
    assert leaves == documented  # "conformance" alone has no options: its action does


def test_metrics_table_is_the_code_s():
    text = (DOCS / "study.md").read_text()
    rows = re.findall(r"^\| `(\w+)` \| (.+?) \| (.+?) \| (.+?) \|$", text, re.M)
    rows = [tuple(cell.replace("\\|", "|") for cell in row) for row in rows]
    from skf_ref.study._demo import DETECTION_COLUMNS

    assert rows == [tuple(column) for column in (*metrics.COLUMNS, *DETECTION_COLUMNS)]


def test_gallery_has_its_examples():
    examples = sorted((DOCS / "examples").glob("plot_*.py"))
    assert len(examples) >= MIN_GALLERY
    for path in examples:
        title = path.read_text().split('"""')[1].strip().splitlines()
        assert len(title) >= 2 and set(title[1]) == {"="}, f"{path.name} has no title"


def test_citation_metadata_agree():
    cff = (ROOT / "CITATION.cff").read_text()
    assert re.search(r"^cff-version: 1\.2\.0$", cff, re.M)
    assert re.search(rf"^version: {re.escape(skf_ref.__version__)}$", cff, re.M)
    titles = re.findall(r'^    title: "(.+)"$', cff, re.M)
    assert len(titles) == 4  # the SKF, the seed study, the standardization's theory (two)
    citing = " ".join((DOCS / "citing.md").read_text().split())
    for title in titles:
        assert title in citing, title
    assert "license = BSD-3-Clause" in (ROOT / "setup.cfg").read_text()
    assert (ROOT / "LICENSE").read_text().startswith("BSD 3-Clause License")


def test_citation_references_carry_the_papers_dois_and_claim_no_repository():
    yaml = pytest.importorskip("yaml")  # PyYAML comes with dask (the test extra)
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    dois = {ref["title"]: ref["doi"] for ref in cff["references"]}
    assert dois == {
        "Standardized Kalman filtering for dynamical source localization of concurrent "
        "subcortical and cortical brain activity": "10.1016/j.clinph.2024.09.021",
        "The Effect of Prior Parameters on Standardized Kalman Filter-Based EEG Source "
        "Localization": "10.48550/arXiv.2507.23450",
        "On Bias and Its Reduction via Standardization in Discretized Electromagnetic Source "
        "Localization Problems": "10.1088/1361-6420/ad5f53",
        "On Unbiased Parameter Estimation and Signal Reconstruction": "10.48550/arXiv.2605.05276",
    }
    # the repository has no public home yet: neither the citation nor the package claims one
    assert not {"repository-code", "url", "repository"} & set(cff)
    setup = (ROOT / "setup.cfg").read_text()
    assert not re.search(r"^(url|project_urls)\s*=", setup, re.M)
    citing = (DOCS / "citing.md").read_text()
    for doi in dois.values():
        assert f"doi:[{doi}](https://doi.org/{doi})" in citing
    for arxiv in ("2507.23450", "2405.04409", "2605.05276"):
        assert f"[arXiv:{arxiv}](https://arxiv.org/abs/{arxiv})" in citing
    # the seed study's status says how it was checked, and claims no journal DOI (issue 41)
    seed = next(r for r in cff["references"] if r["title"].startswith("The Effect"))
    assert seed["status"] == "preprint" and "checked in November 2026" in seed["notes"]


def _conf_constants():
    """docs/conf.py's module-level string and tuple constants, read without running it."""
    found = {}
    for node in ast.parse((DOCS / "conf.py").read_text()).body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1:
            target = node.targets[0]
            if isinstance(target, ast.Name):
                try:
                    found[target.id] = ast.literal_eval(node.value)
                except ValueError:
                    pass
    return found


def test_mathjax_is_served_from_the_site():
    conf = _conf_constants()
    path = conf["mathjax_path"]
    # relative: a file of the site's _static folder, not a CDN's
    assert "://" not in path and not path.startswith(("/", "//")), path
    assert conf["MATHJAX_FILES"][0] == Path(path).name
    docs_extra = configparser.ConfigParser()
    docs_extra.read(ROOT / "setup.cfg")
    assert conf["MATHJAX_DISTRIBUTION"] in docs_extra["options.extras_require"]["docs"]
    try:
        folder = metadata.distribution(conf["MATHJAX_DISTRIBUTION"]).locate_file(
            f"{conf['MATHJAX_DISTRIBUTION']}/static/mathjax"
        )
    except metadata.PackageNotFoundError:
        pytest.skip("the docs extra is not installed")
    for name in conf["MATHJAX_FILES"]:
        assert Path(folder, name).exists(), name
