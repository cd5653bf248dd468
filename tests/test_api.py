"""The declared public API: which modules are public, and exactly which names each declares.

A name added to (or removed from) a public module's ``__all__`` fails
``test_each_public_module_declares_exactly_these_names`` until it is added here and the API
reference (docs/api.rst, generated from ``__all__``) says what it is.
"""

import ast
import importlib
import pkgutil
import re
import sys
from pathlib import Path

import pytest

import skf_ref

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "sphinxext"))
import skf_docs  # noqa: E402

#: Every public module and the names it declares.
PUBLIC_API = {
    "skf_ref": {
        "InputError",
        "InputTypeError",
        "PAPER_SETTING",
        "RECOMMENDED_SETTING",
        "Reconstruction",
        "SKFOperator",
        "StandardizedKalmanFilter",
        "__version__",
        "apply_skf",
        "apply_skf_bids",
        "apply_skf_epochs",
        "apply_skf_raw",
        "ar1_priors",
        "compare",
        "evolution_variance",
        "lead_field_amplitude",
        "make_skf_operator",
        "prior_variance",
        "priors_from_snr",
        "read_skf_operator",
        "read_skf_stream",
        "reconstruct",
        "sys_info",
        "tune",
        "write_skf_operator",
    },
    "skf_ref.method": {
        "SpectralBasis",
        "SpectralModel",
        "StateSpaceModel",
        "TuneResult",
        "amplitude_from_components",
    },
    "skf_ref.io": {
        "LeadField",
        "Recording",
        "baseline_covariance",
        "make_stc",
        "read_data",
        "read_leadfield",
        "read_variables",
        "stc_to_zarr",
        "to_dask",
        "to_zarr",
        "write_reconstruction",
        "write_stc",
    },
    "skf_ref.conformance": {
        "CONFORMANCE_VERSION",
        "Case",
        "FLOAT32_TOLERANCE",
        "TOLERANCE",
        "build",
        "cases",
        "export",
        "manifest",
        "read_case",
        "verify",
        "write_case",
    },
    "skf_ref.datasets": {
        "baseline_noise_cov",
        "data_path",
        "forward_from_leadfield",
        "load_fecnn_evoked",
        "load_fecnn_forward",
        "load_sep256_evoked",
        "sphere_forward",
    },
    "skf_ref.study": {
        "Anatomy",
        "HeadModel",
        "Scenario",
        "Simulation",
        "Truth",
        "apply_minimum_norm",
        "cache_dir",
        "calibrate",
        "detected",
        "draw_sources",
        "earth_movers_distance",
        "echo",
        "find_testing_data",
        "grid_size",
        "make_head",
        "make_head_model",
        "make_realistic_head",
        "make_sphere_head",
        "p20n20_scenario",
        "paper_grid",
        "peak_localization_error",
        "plot_comparison",
        "plot_estimate",
        "plot_landscape",
        "plot_time_courses",
        "read_results",
        "region_db",
        "region_mask",
        "region_time_course",
        "run_demo",
        "run_sweep",
        "separation",
        "simulate",
        "spatial_dispersion",
        "summarize",
        "time_course_correlation",
    },
    "skf_ref.cli": {
        "main",
    },
}

#: How many public modules and names the package may declare (each name once).
MAX_MODULES, MAX_NAMES = 10, 100


def _every_module():
    found = pkgutil.walk_packages(skf_ref.__path__, "skf_ref.")
    return {"skf_ref", *(info.name for info in found if not info.name.endswith("__main__"))}


@pytest.mark.parametrize("module", sorted(PUBLIC_API))
def test_each_public_module_declares_exactly_these_names(module):
    declared = importlib.import_module(module).__all__
    assert len(declared) == len(set(declared)), f"{module}.__all__ names one twice"
    assert set(declared) == PUBLIC_API[module]
    for name in declared:
        assert getattr(importlib.import_module(module), name) is not None, name


def test_every_other_module_is_private():
    others = _every_module() - set(PUBLIC_API)
    public = {m for m in others if not any(part.startswith("_") for part in m.split("."))}
    assert not public, f"modules neither declared public nor private: {sorted(public)}"


def test_the_surface_is_small_and_each_name_declared_once():
    declared = [name for names in PUBLIC_API.values() for name in names]
    assert len(PUBLIC_API) <= MAX_MODULES
    assert len(declared) <= MAX_NAMES, len(declared)
    twice = sorted({name for name in declared if declared.count(name) > 1})
    assert not twice, f"declared in two public modules: {twice}"


@pytest.mark.parametrize("module", sorted(PUBLIC_API))
def test_dir_shows_the_declared_names(module):
    shown = {name for name in dir(importlib.import_module(module)) if not name.startswith("_")}
    assert shown == {name for name in PUBLIC_API[module] if not name.startswith("_")}


def test_the_file_tree_shows_only_the_public_modules():
    """``ls`` shows the same API as ``__all__``: every other file and folder is private."""
    package = Path(skf_ref.__file__).parent
    shown = sorted(
        str(path.relative_to(package))
        for path in package.rglob("*.py")
        if not any(part.startswith("_") for part in path.relative_to(package).parts)
    )
    assert not shown, f"files of no public module without a leading underscore: {shown}"
    folders = {path.name for path in package.iterdir() if path.is_dir()}
    public = {name.split(".")[1] for name in PUBLIC_API if "." in name}
    assert {name for name in folders if not name.startswith("_")} == public


def test_the_method_layer_has_no_public_module_but_its_package():
    method = {m for m in _every_module() if m.startswith("skf_ref.method.")}
    assert method and all(m.split(".")[2].startswith("_") for m in method)


def test_the_api_reference_documents_exactly_the_public_modules():
    assert set(skf_docs.PUBLIC_MODULES) == set(PUBLIC_API)
    text = (ROOT / "docs" / "api.rst").read_text()
    listed = set(re.findall(r"^   (skf_ref[\w.]*)$", text, flags=re.MULTILINE))
    top = {f"skf_ref.{name}" for name in PUBLIC_API["skf_ref"]}
    assert listed == set(PUBLIC_API) | top


def test_the_top_level_loads_nothing_until_asked():
    # the names of skf_ref are declared, not imported: the command line starts fast
    tree = ast.parse(Path(skf_ref.__file__).read_text())
    imports = [n for n in tree.body if isinstance(n, ast.Import | ast.ImportFrom)]
    assert {n.module for n in imports} == {"_utils.lazy", "_version"}
    with pytest.raises(AttributeError, match="has no attribute 'nothing'"):
        skf_ref.nothing  # noqa: B018
    assert set(PUBLIC_API["skf_ref"]) <= set(dir(skf_ref))
