"""Sphinx configuration of skf_ref's documentation site.

Build it from the repository's root with README's command:
``python -m sphinx -W --keep-going -n -b html docs docs/_build/html`` (warnings are errors,
every cross-reference must resolve; nothing is fetched from the network).
"""

import os
import shutil
import sys
from importlib import metadata
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # the checkout's skf_ref, as pytest uses it
sys.path.insert(0, str(HERE / "sphinxext"))
os.environ.setdefault("MPLBACKEND", "Agg")

from skf_docs import api_pages, top_level_data  # noqa: E402

import skf_ref  # noqa: E402

project = "skf_ref"
author = "the skf_ref developers"
copyright = "the skf_ref developers"  # noqa: A001
version = release = skf_ref.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "sphinxarg.ext",
    "skf_docs",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "sphinxext", "examples"]
templates_path = ["_templates"]
root_doc = "index"
smartquotes = False  # "--flag" stays two hyphens, in the command line's help above all
highlight_language = "default"  # python where it parses, plain text (formulas) otherwise

# The API reference: one page per top-level name, one per public module (docs/api.rst).
API_PAGES, skf_aliases = api_pages()
autosummary_generate = True
autosummary_context = {"api_pages": API_PAGES, "top_level_data": top_level_data()}
autodoc_typehints = "none"  # the docstrings give the types, with shapes
autodoc_member_order = "bysource"
autodoc_inherit_docstrings = False  # filterpy's own docstrings are not ours to render
numpydoc_show_class_members = False
numpydoc_xref_param_type = False

# numpydoc checks every docstring it renders; a failure is a warning, so an error of the
# build (-W). All checks, but these, which are noise for this package:
numpydoc_validation_checks = {
    "all",
    "GL01",  # the summary starts on the line of the opening quotes (PEP 257's own style)
    "ES01",  # an extended summary: a one-line summary is enough for many small functions
    "EX01",  # an Examples section: wanted where it teaches (doctests run in pytest), not on
    # every accessor
    "SA01",  # a See Also section: the prose links what belongs together
    "RT02",  # a named return (``amplitude : ndarray, shape (n, T)``) says what is returned
    "SS05",  # an English heuristic (a first word ending in "s" is a third-person verb),
    # wrong on noun summaries ("Rows of ...", "Parameters of ...")
    "PR07",  # a sentence under every parameter: ``L : ndarray, shape (n_channels,
    "RT03",  # n_sources)`` says what ``L`` is; a sentence is written where it adds to that
}
numpydoc_validation_exclude = {
    # constants: documented by their ``#:`` comment, which numpydoc's checks of functions
    # and classes misread (or they read the value's type's docstring, ``str``'s)
    r"\.[A-Z][A-Z0-9_]*$",
    r"\.__version__$",
}
# No network at build time, so no intersphinx: references to other packages' objects stay
# plain text (they are named with their package, ``mne.Forward``); ours must all resolve.
_EXTERNAL = (
    r"(numpy|np|scipy|mne|pandas|pd|matplotlib|filterpy|zarr|dask|distributed|joblib|"
    r"pathlib|argparse|logging|os|concurrent|threading|collections|typing|enum|abc|"
    r"dataclasses|warnings|contextlib|json|io|types|functools|h5io|pymatreader|nibabel|"
    r"threadpoolctl|hypothesis|ray|mpmath)(\..+)?"
)
_BUILTINS = (
    r"(int|float|complex|str|bytes|bool|dict|list|tuple|set|frozenset|object|type|None|"
    r"callable|slice|range|iterable|iterator|generator|sequence|mapping|path-like|"
    r"array_like|array-like|ndarray|"
    r"Exception|BaseException|ValueError|TypeError|ImportError|KeyError|IndexError|"
    r"RuntimeError|OSError|MemoryError|FileNotFoundError|KeyboardInterrupt|"
    r"UserWarning|FutureWarning|RuntimeWarning|Warning|DeprecationWarning)"
)
nitpicky = True
nitpick_ignore_regex = [(r"py:.*", _EXTERNAL), (r"py:.*", _BUILTINS)]

# MathJax from the site itself: no network is needed to read an equation. The files are
# MathJax 3.2.2's (https://www.mathjax.org, Apache License 2.0) as the PyPI package
# sphinx-mathjax-offline ships them (the docs extra installs it); what the tex-chtml
# component loads is copied into _build/html/_static/mathjax at the end of the build
# (nothing of MathJax is committed). A relative mathjax_path is relative to _static.
mathjax_path = "mathjax/tex-chtml.js"
MATHJAX_DISTRIBUTION = "sphinx-mathjax-offline"
#: What tex-chtml.js loads: itself, TeX packages on demand, its fonts, the menu, and the
#: accessibility explorer the menu offers (with its speech rules).
MATHJAX_FILES = ("tex-chtml.js", "input/tex/extensions", "output/chtml", "ui", "a11y", "sre")


def _mathjax_folder():
    try:
        folder = metadata.distribution(MATHJAX_DISTRIBUTION).locate_file(
            f"{MATHJAX_DISTRIBUTION}/static/mathjax"
        )
    except metadata.PackageNotFoundError:
        folder = None
    if folder is None or not Path(folder, MATHJAX_FILES[0]).is_file():
        raise RuntimeError(
            f"the docs serve MathJax from the site: install {MATHJAX_DISTRIBUTION} "
            '(python -m pip install ".[docs]")'
        )
    return Path(folder)


def _copy_mathjax(app, exception):
    """Copy MathJax's files into the site's _static/mathjax (HTML builds)."""
    if app.builder.format != "html":
        return
    source, target = _mathjax_folder(), Path(app.outdir) / "_static" / "mathjax"
    for name in MATHJAX_FILES:
        (target / name).parent.mkdir(parents=True, exist_ok=True)
        if (source / name).is_dir():
            shutil.copytree(source / name, target / name, dirs_exist_ok=True)
        else:
            shutil.copy2(source / name, target / name)
    (target / "README.txt").write_text(
        "MathJax 3.2.2 (https://www.mathjax.org), under the Apache License 2.0 "
        "(https://www.apache.org/licenses/LICENSE-2.0), copied from the "
        f"{MATHJAX_DISTRIBUTION} package by docs/conf.py.\n"
    )


def setup(app):
    _mathjax_folder()  # missing: one clear error before the build starts
    app.connect("build-finished", _copy_mathjax)


myst_enable_extensions = ["dollarmath", "amsmath", "substitution"]
myst_substitutions = {"version": release}
myst_heading_anchors = 3

html_theme = "pydata_sphinx_theme"
html_title = f"skf_ref {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_show_sourcelink = False

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "abort_on_example_error": True,
    "image_scrapers": ("skf_docs.figure_scraper", "matplotlib"),  # this order: see the scraper
    "reference_url": {"skf_ref": None},
    "doc_module": ("skf_ref",),
    "backreferences_dir": None,
    "remove_config_comments": True,
    "download_all_examples": False,
    "min_reported_time": 0,
    "show_memory": False,
    "write_computation_times": True,
}
