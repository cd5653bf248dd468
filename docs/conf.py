"""Sphinx configuration of skf_ref's documentation site.

Build it from the repository's root with README's command:
``python -m sphinx -W --keep-going -n -b html docs docs/_build/html`` (warnings are errors,
every cross-reference must resolve; nothing is fetched from the network).
"""

import os
import sys
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
numpydoc_validation_checks = set()

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
