"""Reproduce the paper's findings (docs/model.md §7) under decision rules fixed in advance.

``python -m validation.reproduce [--quick] [--out DIR] [--jobs N] [--fresh]``
``[--seeds N] [--n-positions N] [--fine-step DB]``

Runs two sweeps with :func:`skf_ref.study.sweep.run_sweep` and writes ``DIR/REPORT.md`` with the
decision rules (stated before any number), one verdict per finding, tables and figures:

- ``paper_grid.csv``: the paper's grid, :func:`skf_ref.study.sweep.paper_grid` (10/20/30 dB; EP,
  PM in {0, 20} dB; exponents 0.5, 1, 1.25, 1.5; no smoothing, "rts-standardized",
  "rts-state"; seeds 0 .. n-1);
- ``fine_grid.csv``: a finer EP x PM map, -20 .. 40 dB, for (exponent 0.5, no smoothing)
  and (exponent 1.25, "rts-standardized"), at the same noise levels and seeds.

Presets: the full run uses 10 seeds (20 in the realistic cortex + thalamus cell's
specificity tables), the default head models (about 3000 positions in the sphere's volume
grid) and a 10 dB step of the fine map; ``--quick`` uses 2 seeds, 500 positions, 12 mm
grids where a head's spacing is fixed, a 60 dB step, the baselines of the main condition
only, and the first cell's figures only. ``--seeds``, ``--n-positions`` and
``--fine-step`` override the preset.

Output folder. Only the full preset writes the committed report, ``validation/report/``
(its default ``DIR``). Any other run (``--quick``, or an override that changes the
preset) writes by default to ``reproduce-quick/`` in the current directory (ignored by
git), and is refused, with exit status 2, if ``--out`` is the committed report folder or
inside it: a trial run never replaces the 10-seed report.

Resuming and regenerating. The results files are resumable: an interrupted run picks up
the rows already written. ``DIR/settings.json`` records everything the rows depend on (the
grids, the head model, the package versions and a digest of the ``skf_ref`` sources); when
it differs from the current settings, or is missing, the results files are stale and are
deleted before the sweeps start, so a report never mixes rows computed under different
settings or code. ``--fresh`` deletes them regardless. After the sweeps each results file
is rewritten sorted by its key, so with fixed seeds a fresh run reproduces it exactly.

Everything in REPORT.md is regenerable byte for byte except its one ``Generated:`` line
(date and wall time). PNGs are saved without a software/date stamp.

The decision rules are pure functions of a sweep table (:func:`rule_f1` .. :func:`rule_f6`,
:func:`evaluate`), so they can be checked on hand-made tables.

Modules: ``settings`` (grid constants, presets, the manifest), ``stats`` (statistics over
seeds of a sweep table), ``rules`` (the decision rules), ``runs`` (the figure runs checked
against the sweep, post-hoc diagnostics), ``sensitivity`` (post hoc: F5 and F6 on the grid
above the lowest electrode, ``sensitivity.csv``), ``figures`` (matplotlib, imported lazily),
``report`` and ``discussion`` (a cell's CELL.md), ``cli`` (arguments, results files, sweeps,
:func:`main`). The 2 x 2 design: ``cells`` (each cell's sweeps and the variants),
``overview`` (REPORT.md, assembled from ``findings``: the rule sets and verdicts,
``controls``: the controls and lone sources, and ``deviations``), ``rules_v2`` and
``rules_v3``, ``tuned`` (priors chosen by the data against the best fixed priors). What the
SKF is worth: ``baselines`` (every method on identical simulations, the real-noise
condition), ``specificity`` (ROC areas, detection rates, the recommendation),
``recommend`` (the rule, committed before the numbers) and ``specificity_report`` (its
section, tables and figures).
"""

from .cells import CellResult, Variant, best_cell, run_cell_sweeps, run_variants
from .cli import main, output_folder, prepare_out
from .figures import make_figures, plot_fine_map
from .report import ReportData, report_text
from .rules import Finding, evaluate, rule_f1, rule_f2, rule_f3, rule_f4, rule_f5, rule_f6, verdict
from .runs import CheckedRuns, Diagnostic, diagnostics, electrode_floor
from .settings import Settings, manifest
from .stats import cell_stats, corner_stats, summary_table

__all__ = [
    "CheckedRuns",
    "Diagnostic",
    "Finding",
    "ReportData",
    "Settings",
    "cell_stats",
    "corner_stats",
    "electrode_floor",
    "evaluate",
    "diagnostics",
    "main",
    "make_figures",
    "manifest",
    "output_folder",
    "plot_fine_map",
    "prepare_out",
    "report_text",
    "rule_f1",
    "rule_f2",
    "rule_f3",
    "rule_f4",
    "rule_f5",
    "rule_f6",
    "run_cell_sweeps",
    "run_variants",
    "best_cell",
    "CellResult",
    "Variant",
    "summary_table",
    "verdict",
]
