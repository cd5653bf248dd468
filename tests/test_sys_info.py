"""skf_ref.sys_info() and ``skf-ref sys-info``: what a bug report needs, in one print."""

import configparser
import io
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

import skf_ref
from skf_ref._utils import provenance
from skf_ref._utils.extras import MissingDependencyError, optional
from skf_ref._utils.sys_info import OPTIONAL, REQUIRED, sys_info

ROOT = Path(__file__).resolve().parent.parent
#: The extras whose packages sys_info lists as optional (the others are tools: tests, docs).
RUNTIME_EXTRAS = ("mne", "study", "zarr", "dask", "parquet")


def _printed():
    out = io.StringIO()
    sys_info(out)
    return out.getvalue()


def _rows(text):
    """``{label: value}`` of the lines ``label  value`` (labels without spaces)."""
    return dict(re.findall(r"^(\S+) +(\S.*)$", text, flags=re.MULTILINE))


def _requirement_names(lines):
    names = []
    for line in lines.strip().splitlines():
        name = re.split(r"[\s<>=!~\[;]", line.strip(), maxsplit=1)[0]
        if name and not name.startswith("#") and name != "skf_ref":
            names.append(name)
    return names


def test_lists_match_setup_cfg():
    config = configparser.ConfigParser()
    config.read(ROOT / "setup.cfg")
    assert list(REQUIRED) == _requirement_names(config["options"]["install_requires"])
    extras = config["options.extras_require"]
    optional = []
    for extra in RUNTIME_EXTRAS:
        optional += [n for n in _requirement_names(extras[extra]) if n not in optional]
    # dask[array,distributed] installs distributed: listed by its own name
    assert sorted(OPTIONAL) == sorted({*optional, "distributed"})


def test_prints_every_dependency_with_its_version():
    rows = _rows(_printed())
    for name in ("skf_ref", *REQUIRED, *OPTIONAL):
        assert rows[name] == provenance.package_versions((name,))[name], name
    assert rows["skf_ref"] == skf_ref.__version__
    for label in ("Platform", "Python", "Executable", "CPUs", "Memory"):
        assert rows[label].strip(), label
    assert re.fullmatch(r"[\d.]+ GiB total, [\d.]+ GiB available", rows["Memory"])


def test_a_missing_package_reads_not_installed(monkeypatch):
    real = metadata.version

    def version(name):
        if name == "zarr":
            raise metadata.PackageNotFoundError(name)
        return real(name)

    monkeypatch.setattr(metadata, "version", version)
    assert _rows(_printed())["zarr"] == "not installed"


def test_blas_libraries_with_their_threads():
    text = _printed()
    blas = text.split("BLAS (threadpoolctl)\n", 1)[1].strip().splitlines()
    assert len(blas) == len(provenance.blas_threads()) >= 1  # numpy's, at least
    for line, entry in zip(blas, provenance.blas_threads(), strict=True):
        assert line.startswith(f"{entry['library']} {entry['version']} ")
        assert f"({entry['threads']} thread" in line


def test_to_standard_output_by_default(capsys):
    skf_ref.sys_info()
    out = capsys.readouterr().out
    assert out.startswith("Platform ") and "Required dependencies" in out


def test_the_command_prints_the_same(cli):
    result = cli("sys-info")
    assert result.returncode == 0 and result.stderr == ""
    ours, theirs = _rows(result.stdout), _rows(_printed())
    ours.pop("Memory"), theirs.pop("Memory")  # available memory moves between the calls
    assert ours == theirs


def test_the_command_takes_no_options(cli):
    result = cli("sys-info", "--threads", "2")
    assert result.returncode == 2
    assert re.fullmatch(r"skf-ref: error: unrecognized arguments: --threads 2\n", result.stderr)


def test_imports_no_optional_or_heavy_package():
    code = (
        "import sys, skf_ref; skf_ref.sys_info(); "
        "print(sorted({'mne', 'matplotlib', 'pandas', 'zarr', 'dask'} & set(sys.modules)))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], check=True, capture_output=True, text=True, cwd=ROOT
    )
    assert result.stdout.strip().splitlines()[-1] == "[]"


def test_a_missing_extra_says_to_install_it_from_the_source_tree():
    # skf_ref is on no package index: `pip install 'skf_ref[mne]'` would fail (issue 41).
    with pytest.raises(MissingDependencyError) as raised:
        optional("no_such_module", "mne", "apply_skf")
    said = str(raised.value)
    assert said.startswith("apply_skf needs no_such_module, which is not installed:")
    assert "python -m pip install '.[mne]'" in said and "skf_ref[" not in said
    assert "python -m pip install no_such_module" in said


def test_no_install_line_names_the_package_from_an_index():
    texts = [
        ROOT / "README.md",
        *ROOT.glob("docs/*.md"),
        *ROOT.glob("docs/*.rst"),
        *ROOT.glob("docs/examples/*.py"),
        *ROOT.glob("docs/examples/*.rst"),
        *ROOT.glob("skf_ref/**/*.py"),
    ]
    index_install = re.compile(r"pip install\s+(?:-\S+\s+)*['\"]?skf[_-]ref\b")
    for path in texts:
        text = re.sub(r"\s+", " ", path.read_text())
        assert not index_install.search(text), f"{path}: {index_install.search(text)[0]}"
