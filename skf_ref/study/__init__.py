"""The P20/N20 study: head models, the scenario, metrics, figures, sweeps, baselines, demo.

- head models: MNE's sphere and the sample subject's BEM, with their source spaces
  (:func:`make_head_model`, :func:`make_realistic_head`, :func:`make_sphere_head`);
- the scenario: the paper's two dipoles and their simulated EEG (:func:`p20n20_scenario`,
  :func:`simulate`), and sources drawn over cortex and thalamus (:func:`draw_sources`);
- what a reconstruction is scored by: peak errors, the earth mover's distance, regions,
  the calibrated detector (:func:`peak_localization_error`, :func:`summarize`, ...);
- the figures (the only place matplotlib is imported): ``plot_*``;
- sweeps: grids of settings over seeds, resumable, in parallel (:func:`run_sweep`);
- MNE-Python's inverse methods on the same heads and data (:func:`apply_minimum_norm`);
- what ``skf-ref demo`` runs (:func:`run_demo`).

The study imports the method and needs MNE-Python, nibabel, joblib, tqdm and filelock (the
``study`` extra: its head models and its sweeps say so when one is missing); nothing below it
imports the study. Its modules (leading underscore) are the implementation. Names load on
first use.
"""

from .._utils.lazy import attach

#: Public name -> the module that defines it.
_HOMES = {
    "Anatomy": "_head",
    "HeadModel": "_head",
    "cache_dir": "_head",
    "find_testing_data": "_head",
    "grid_size": "_head",
    "make_head": "_head",
    "make_head_model": "_head",
    "make_realistic_head": "_head",
    "make_sphere_head": "_head",
    "Scenario": "_scenario",
    "Simulation": "_scenario",
    "Truth": "_scenario",
    "p20n20_scenario": "_scenario",
    "simulate": "_scenario",
    "draw_sources": "_sources",
    "detected": "_metrics",
    "earth_movers_distance": "_metrics",
    "echo": "_metrics",
    "peak_localization_error": "_metrics",
    "separation": "_metrics",
    "summarize": "_metrics",
    "time_course_correlation": "_metrics",
    "region_db": "_regions",
    "region_mask": "_regions",
    "region_time_course": "_regions",
    "spatial_dispersion": "_resolution",
    "calibrate": "_detection",
    "apply_minimum_norm": "_baselines",
    "plot_comparison": "_plots",
    "plot_estimate": "_plots",
    "plot_landscape": "_plots",
    "plot_time_courses": "_plots",
    "paper_grid": "_sweep",
    "read_results": "_sweep",
    "run_sweep": "_sweep",
    "run_demo": "_demo",
}

__all__ = sorted(_HOMES)
__getattr__, __dir__ = attach(__name__, _HOMES)
