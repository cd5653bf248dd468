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
        "ar1_priors",
        "apply_skf",
        "apply_skf_epochs",
        "apply_skf_raw",
        "apply_skf_bids",
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
        "PAPER_SETTING",
        "RECOMMENDED_SETTING",
        "Reconstruction",
        "SpectralBasis",
        "SpectralModel",
        "StandardizedKalmanFilter",
        "StateSpaceModel",
        "TuneResult",
        "amplitude_from_components",
        "ar1_priors",
        "evolution_variance",
        "lead_field_amplitude",
        "prior_variance",
        "priors_from_snr",
        "reconstruct",
        "tune",
    },
    "skf_ref.io": {
        "LeadField",
        "Recording",
        "SKFOperator",
        "apply_skf",
        "apply_skf_epochs",
        "apply_skf_raw",
        "apply_skf_bids",
        "baseline_covariance",
        "make_skf_operator",
        "make_stc",
        "read_data",
        "read_leadfield",
        "read_skf_operator",
        "read_skf_stream",
        "read_variables",
        "stc_to_zarr",
        "to_dask",
        "to_zarr",
        "write_reconstruction",
        "write_skf_operator",
        "write_stc",
    },
    "skf_ref.conformance": {
        "CONFORMANCE_VERSION",
        "Case",
        "EXTRAS",
        "FLOAT32_TOLERANCE",
        "FORMATS",
        "INPUTS",
        "OUTPUTS",
        "SUITE",
        "TOLERANCE",
        "build",
        "cases",
        "export",
        "generate",
        "manifest",
        "read_case",
        "verify",
        "write_case",
    },
    "skf_ref.datasets": {
        "DATA_ENV",
        "FECNN_FILES",
        "FECNN_SUBJECTS",
        "baseline_noise_cov",
        "data_path",
        "forward_from_leadfield",
        "load_fecnn_evoked",
        "load_fecnn_forward",
        "load_sep256_evoked",
        "sphere_forward",
    },
    "skf_ref.study": set(),
    "skf_ref.study.baselines": {
        "MINIMUM_NORM_METHODS",
        "amplitude_on_positions",
        "apply_minimum_norm",
        "inverse_operator",
        "mne_data",
    },
    "skf_ref.study.demo": {
        "COLUMNS",
        "DATA",
        "DETECTION_COLUMNS",
        "Demo",
        "HEADS",
        "OUTPUTS",
        "RENAMED",
        "run_demo",
    },
    "skf_ref.study.detection": {
        "FALSE_DETECTION_RATE",
        "calibrate",
        "null_levels",
        "null_threshold",
        "thalamic_level",
    },
    "skf_ref.study.head": {
        "ANATOMICAL_SPACING_MM",
        "Anatomy",
        "CACHE_ENV",
        "CONDUCTORS",
        "HeadModel",
        "LABELS",
        "MINDIST_MM",
        "MIN_POSITIONS",
        "SENSOR_FILES",
        "SHELL_DEPTH_MM",
        "SOURCE_SPACES",
        "SPHERE_ANATOMICAL_SPACING_MM",
        "SUBJECT_MONTAGE",
        "TESTING_FILES",
        "THALAMUS_MNI_MM",
        "THALAMUS_RADIUS_MM",
        "VOLUME_SPACING_MM",
        "cache_dir",
        "check_montage",
        "check_size",
        "find_testing_data",
        "grid_size",
        "input_digest",
        "make_head",
        "make_head_model",
        "make_realistic_head",
        "make_sphere_head",
        "required_memory",
        "subject_electrodes",
        "subject_mni_to_head",
        "template_mni_to_head",
    },
    "skf_ref.study.metrics": {
        "COLUMNS",
        "detected",
        "earth_movers_distance",
        "echo",
        "peak_localization_error",
        "separation",
        "summarize",
        "time_course_correlation",
    },
    "skf_ref.study.plots": {
        "plot_average_reconstruction",
        "plot_comparison",
        "plot_estimate",
        "plot_exponent_comparison",
        "plot_landscape",
        "plot_prior_grid",
        "plot_time_courses",
    },
    "skf_ref.study.regions": {
        "DYNAMIC_RANGE_DB",
        "REGION_RADIUS_MM",
        "as_amplitude",
        "check_amplitude",
        "check_positions",
        "check_time_index",
        "region_db",
        "region_mask",
        "region_time_course",
    },
    "skf_ref.study.resolution": {
        "level_db",
        "peak_errors",
        "position_amplitudes",
        "spatial_dispersion",
    },
    "skf_ref.study.scenario": {
        "DEEP_MNI_MM",
        "FORWARDS",
        "NOISES",
        "SOURCES",
        "SUPERFICIAL_MNI_MM",
        "Scenario",
        "Simulation",
        "Truth",
        "WINDOWS",
        "p20n20_scenario",
        "simulate",
    },
    "skf_ref.study.sources": {
        "STRUCTURES",
        "Sources",
        "draw_sources",
        "exact_gains",
        "position_labels",
        "position_structures",
        "random_rotation",
    },
    "skf_ref.study.sweep": {
        "AXES",
        "KEY",
        "TornLineWarning",
        "check_grid",
        "paper_grid",
        "read_results",
        "run_group",
        "run_on_head",
        "run_sweep",
    },
    "skf_ref.cli": {"build_parser", "console", "main"},
}
#: Modules without a leading underscore that are the implementation of a public package
#: (their package's docstring says so). Their files are not renamed while other branches
#: edit them; each is a rename to propose (``skf_ref.io.operator`` -> ``skf_ref.io._operator``).
IMPLEMENTATION = {
    "skf_ref.version",
    *(f"skf_ref.io.{name}" for name in ("apply", "channels", "files", "noise_cov")),
    *(f"skf_ref.io.{name}" for name in ("operator", "raw", "stc", "tables", "zarr_dask")),
    "skf_ref.io.variables",
    *(f"skf_ref.io.{name}" for name in ("make_operator", "operator_file", "stream", "bids")),
    *(f"skf_ref.conformance.{name}" for name in ("case_files", "cases", "compare", "mistakes")),
    *(f"skf_ref.conformance.{name}" for name in ("precision", "suite", "their_outputs")),
    *(f"skf_ref.cli.{name}" for name in ("compare", "conformance", "demo", "reconstruct")),
    "skf_ref.cli.bids",
    "skf_ref.cli.sweep",
    "skf_ref.cli.sys_info",
    "skf_ref.study.sizes",
    *(f"skf_ref.study.plots.{name}" for name in ("estimates", "projections", "style")),
    "skf_ref.study.plots.time_courses",
}


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


def test_every_other_module_is_private_or_an_implementation_module():
    others = _every_module() - set(PUBLIC_API)
    private = {m for m in others if any(part.startswith("_") for part in m.split("."))}
    assert others - private == IMPLEMENTATION


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
    assert {n.module for n in imports} == {"_utils.lazy", "version"}
    with pytest.raises(AttributeError, match="has no attribute 'nothing'"):
        skf_ref.nothing  # noqa: B018
    assert set(PUBLIC_API["skf_ref"]) <= set(dir(skf_ref))
