"""The 2 x 2 design: each cell's sweeps and controls, its verdicts, and the variants.

A cell is a conductor (MNE's sphere, or the sample subject's BEM) and a source space (a grid
filling the brain compartment, or cortex + thalamus). Every cell runs the same paper grid,
fine map and controls (:meth:`Settings.control_grids`), with the same pulses, noise,
priors, seeds and rules. Results files live in ``out/<cell>/``; the variants of the
deviations (:data:`VARIANTS`) in ``out/variants/<name>/``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from skf_ref._utils.atomic_files import atomic_path

from .settings import BEST_CELL_ORDER, CONTROLS, MONTAGE, RESULTS, TUNING, VARIANTS, VERDICTS
from .tuned import TUNED, compare_tuned, run_tuned

__all__ = [
    "CellResult",
    "Variant",
    "best_cell",
    "head_kwargs",
    "result_files",
    "run_cell_sweeps",
    "run_variants",
    "sorted_rewrite",
]


def head_kwargs(cell, settings, testing_data=None, cache_dir=None):
    """Keyword arguments of :func:`skf_ref.study.head.make_head` for a cell (picklable)."""
    kwargs = dict(conductor=cell.conductor, source_space=cell.source_space)
    if cell.conductor == "sphere" and cell.source_space == "volume":
        kwargs["n_positions"] = settings.n_positions
    elif settings.spacing_mm is not None:
        kwargs["spacing_mm"] = settings.spacing_mm
    if cell.realistic:
        kwargs.update(testing_data=str(testing_data), cache_dir=cache_dir)
    return kwargs


def result_files(settings):
    """Every results file of a run, relative to the report folder."""
    names = [f"{cell.name}/{name}" for cell in settings.cells for name in RESULTS]
    names += [f"{cell.name}/{name}" for cell in settings.cells for name in CONTROLS.values()]
    names += [f"{cell.name}/{TUNED}" for cell in settings.cells]
    names += [
        f"variants/{variant}/{name}"
        for variant in VARIANTS
        for name in (RESULTS[0], CONTROLS["superficial"])
    ]
    return names


def sorted_rewrite(path):
    """Sort a results file by its key and rewrite it (atomically); return the table."""
    from skf_ref.study.sweep import KEY, read_results

    table = read_results(path)
    table = table.sort_values(list(KEY), kind="stable", ignore_index=True)
    if "blas" in table:
        table["blas"] = table["blas"].map(_sorted_words)
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False, lineterminator="\n")
    return table


def _sorted_words(value):
    """The words of a ``blas`` cell in sorted order.

    ``skf_ref._utils.provenance.blas_threads`` lists the loaded BLAS libraries in an order that
    varies from process to process (threadpoolctl's order follows the string hash seed), so
    sweep rows computed by different workers name the same libraries in different orders.
    Sorting them keeps the results files regenerable byte for byte.
    """
    return " ".join(sorted(value.split())) if isinstance(value, str) else value


def _sweep(grids, path, head, data, n_jobs, progress):
    from skf_ref.study.sweep import run_sweep

    path.parent.mkdir(parents=True, exist_ok=True)
    for grid in grids:
        run_sweep(
            grid, path, n_jobs=n_jobs, montage=MONTAGE, head=head, data=data, verbose=progress
        )
    return sorted_rewrite(path)


@dataclass
class CellResult:
    """A cell's tables, and later its verdicts, figures and diagnostics.

    Attributes
    ----------
    cell : Cell
    head : skf_ref.study.head.HeadModel
    paper, fine : pandas.DataFrame
    controls : dict
        ``"deep"`` and ``"superficial"`` -> the control tables.
    findings, findings_v2, findings_v3 : list of Finding
    figures, diagnostics : dict
    sensitivity : Sensitivity or None
    truth : skf_ref.study.scenario.Truth
        The sources placed in this head.
    tuned : list of TunedComparison
        The priors chosen by the data beside the fixed cells (``tuned.py``).
    """

    cell: object
    head: object
    paper: pd.DataFrame
    fine: pd.DataFrame
    controls: dict
    findings: list = field(default_factory=list)
    findings_v2: list = field(default_factory=list)
    findings_v3: list = field(default_factory=list)
    figures: dict = field(default_factory=dict)
    diagnostics: dict = field(default_factory=dict)
    sensitivity: object = None
    truth: object = None
    tuned: list = field(default_factory=list)


def run_cell_sweeps(cell, settings, out, n_jobs, progress, testing_data=None, cache_dir=None):
    """Run (or resume) a cell's paper grid, fine map, controls and tuned priors.

    Returns
    -------
    CellResult
        With the tables and the head (the verdicts are added by the caller).
    """
    from skf_ref.study.head import make_head

    kwargs = head_kwargs(cell, settings, testing_data, cache_dir)
    folder = Path(out) / cell.name
    paper = _sweep([settings.paper_grid()], folder / RESULTS[0], kwargs, None, n_jobs, progress)
    fine = _sweep(settings.fine_grids(), folder / RESULTS[1], kwargs, None, n_jobs, progress)
    controls = {
        source: _sweep(
            settings.control_grids(),
            folder / name,
            kwargs,
            dict(sources=(source,)),
            n_jobs,
            progress,
        )
        for source, name in CONTROLS.items()
    }
    from skf_ref.study.scenario import p20n20_scenario

    tuned = run_tuned(kwargs, settings.seeds, folder / TUNED, n_jobs)
    head = make_head(**dict(kwargs, montage=MONTAGE))
    truth = p20n20_scenario().dipoles(head)
    comparisons = compare_tuned(tuned, pd.concat([fine, paper]), settings.seeds)
    return CellResult(cell, head, paper, fine, controls, truth=truth, tuned=comparisons)


def _score(findings):
    return sum({VERDICTS[0]: 1.0, VERDICTS[1]: 0.5}.get(f.verdict, 0.0) for f in findings)


def best_cell(results):
    """The cell with the most v2 findings reproduced (partly: half); ties by closeness.

    Fixed before the runs, on v2; the v3 rules, written later, do not enter it, so the best
    cell (and the variants run on it) does not move with them.

    Parameters
    ----------
    results : dict
        Cell name -> :class:`CellResult` with ``findings_v2``.

    Returns
    -------
    str
        A cell name.
    """
    ranked = sorted(
        results, key=lambda name: (-_score(results[name].findings_v2), BEST_CELL_ORDER.index(name))
    )
    return ranked[0]


@dataclass(frozen=True)
class Variant:
    """A deviation's variant on the best cell, judged by both rule sets.

    Attributes
    ----------
    name, what : str
    cell : str
    findings, findings_v2 : list of Finding
        F1 .. F6, or F1 .. F4 for the tuning-exponent variant (F5 and F6 do not use it).
    table : pandas.DataFrame
    """

    name: str
    what: str
    cell: str
    findings: list
    findings_v2: list
    table: pd.DataFrame


def _as_tuning(table, exponent):
    """The rows of the tuning corners at ``exponent`` relabelled as the tuning stage's."""
    rows = table[(table["exponent"] == exponent) & (table["smoother"] == "none")]
    return rows.assign(exponent=TUNING[0])


def run_variants(cell, settings, out, n_jobs, progress, testing_data=None, cache_dir=None):
    """Run every variant of :data:`VARIANTS` on ``cell`` and judge it.

    Returns
    -------
    list of Variant
    """
    from .rules import RULES, evaluate
    from .rules_v2 import RULES_V2, evaluate_v2

    kwargs = head_kwargs(cell, settings, testing_data, cache_dir)
    variants = []
    for name, (what, data, exponent) in VARIANTS.items():
        folder = Path(out) / "variants" / name
        grids = settings.rule_grids(exponent)
        table = _sweep(grids, folder / RESULTS[0], kwargs, data, n_jobs, progress)
        control_data = dict(data, sources=("superficial",))
        control = _sweep(
            grids, folder / CONTROLS["superficial"], kwargs, control_data, n_jobs, progress
        )
        controls = {"superficial": control}
        if exponent is None:
            findings, findings_v2 = evaluate(table), evaluate_v2(table, controls)
        else:
            tuning = _as_tuning(table, exponent)
            controls = {"superficial": _as_tuning(control, exponent)}
            findings = [rule(tuning) for rule in RULES[:4]]
            findings_v2 = [
                rule(tuning) if i < 3 else rule(tuning, controls)
                for i, rule in enumerate(RULES_V2[:4])
            ]
        variants.append(Variant(name, what, cell.name, findings, findings_v2, table))
    return variants
