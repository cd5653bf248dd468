"""What a report run computes: the fixed grid constants, the presets and the manifest.

Everything here is data the sweeps, the rules, the figures and the report share; nothing
here runs a sweep.
"""

from __future__ import annotations

import hashlib
import json
import platform
from dataclasses import dataclass
from pathlib import Path

from skf_ref._utils.provenance import blas_threads, package_versions

__all__ = [
    "BEST_CELL_ORDER",
    "CELLS",
    "CONTROLS",
    "CORNERS",
    "DEFAULT_OUT",
    "EXPONENTS",
    "FINE_RANGE",
    "FULL",
    "MANIFEST",
    "MONTAGE",
    "NOISE_LEVELS",
    "QUICK",
    "QUICK_OUT",
    "RANKED_EXPONENTS",
    "RESULTS",
    "SMOOTHED",
    "SMOOTHERS",
    "STAGES",
    "TIE_MM",
    "TUNED_PRIOR",
    "TUNE_CRITERIA",
    "TUNE_GRID",
    "TUNING",
    "VARIANTS",
    "VERDICTS",
    "Cell",
    "Settings",
    "manifest",
    "source_digest",
    "versions",
]

NOISE_LEVELS = (10.0, 20.0, 30.0)
#: The 2 x 2 prior grid as (EP-SNR, PM-SNR) in dB; also the tie-break order.
CORNERS = ((0.0, 0.0), (0.0, 20.0), (20.0, 0.0), (20.0, 20.0))
#: The paper's tuning stage (exponent, smoother label) and its smoothed setting.
TUNING = (0.5, "none")
SMOOTHED = (1.25, "rts-standardized")
#: Both settings with the tag their figure files carry, in the order they are shown.
STAGES = (("nonsmoothed", TUNING), ("smoothed", SMOOTHED))
#: The priors the paper tuned for smoothing: (EP-SNR, PM-SNR).
TUNED_PRIOR = (20.0, 0.0)
EXPONENTS = (0.5, 1.0, 1.25, 1.5)
#: The smoothed exponents the paper ranks (F5): 1 too low, 1.25 best, 1.5 too high.
RANKED_EXPONENTS = (1.0, 1.25, 1.5)
#: Smoother labels of the paper grid, as in the sweep table ("none": no smoothing).
SMOOTHERS = ("none", "rts-standardized", "rts-state")
FINE_RANGE = (-20.0, 40.0)
#: Values per SNR of the coarse grid :func:`skf_ref.tune` searches for the tuned priors
#: (over FINE_RANGE, the fine map's span).
TUNE_GRID = 13
#: The criteria of :func:`skf_ref.tune` the tuned priors are chosen by, each on its own.
TUNE_CRITERIA = ("likelihood", "discrepancy")
#: Mean scores closer than this (mm) are tied: peak errors are grid distances, so exact ties
#: between cells are common; the tolerance only absorbs rounding of the means.
TIE_MM = 1e-6
VERDICTS = ("reproduced", "partly", "not reproduced")
MONTAGE = "biosemi64"
#: The committed report folder: only the full preset writes here.
DEFAULT_OUT = Path(__file__).resolve().parent.parent / "report"
#: Default folder of any other run (``--quick``, or a preset overridden): relative to the
#: current directory, untracked (``.gitignore``), so a trial run never replaces the report.
QUICK_OUT = Path("reproduce-quick")
RESULTS = ("paper_grid.csv", "fine_grid.csv")
MANIFEST = "settings.json"
#: The controls: data from one source only, with the noise of both (file name per source).
CONTROLS = {"deep": "control_deep.csv", "superficial": "control_superficial.csv"}


@dataclass(frozen=True)
class Cell:
    """One cell of the 2 x 2 design: a conductor and a source space."""

    conductor: str
    source_space: str

    @property
    def name(self):
        """Folder name, e.g. ``"bem-anatomical"``."""
        return f"{self.conductor}-{self.source_space}"

    @property
    def title(self):
        """E.g. ``"BEM, cortex + thalamus"``."""
        conductor = {"sphere": "sphere", "bem": "BEM"}[self.conductor]
        space = {"volume": "volume grid", "anatomical": "cortex + thalamus"}[self.source_space]
        return f"{conductor}, {space}"

    @property
    def realistic(self):
        """Whether the cell needs MNE's testing dataset."""
        return self.conductor == "bem"


#: The 2 x 2 design, sphere cells first (they need no dataset).
CELLS = tuple(Cell(c, s) for c in ("sphere", "bem") for s in ("volume", "anatomical"))
#: The deviations' variants (fixed before the runs), run on the best cell: name ->
#: (what changes, keyword arguments of the data, the tuning exponent).
VARIANTS = {
    "blackman-harris": ("Blackman-Harris pulse windows", dict(window="blackman-harris"), None),
    "grid-columns": ("data from the nearest grid columns", dict(forward="grid"), None),
    "tuning-exponent-1.25": ("exponent 1.25 in the tuning stage (F1-F4)", {}, 1.25),
}
#: Which cell is best (fixed before the runs): the most v2 findings reproduced (a partly
#: counts half); ties go to the cell nearest the paper's setup, in this order.
BEST_CELL_ORDER = ("bem-anatomical", "bem-volume", "sphere-anatomical", "sphere-volume")


@dataclass(frozen=True)
class Settings:
    """What a report run computes (everything its rows depend on, except the code).

    Parameters
    ----------
    seeds : int
        Noise seeds 0 .. seeds - 1 (at least 2, for a standard error).
    n_positions : int
        Requested source positions of the head model.
    fine_step : float
        Step (dB) of the fine EP x PM map over -20 .. 40 dB; must divide 60.
    quick : bool
        Whether the ``--quick`` preset was asked (for the command line in the report).
    realistic : bool
        Whether the BEM cells run (they need MNE's testing dataset).
    spacing_mm : float or None
        Spacing of the source spaces that have a fixed one (cortex + thalamus in both heads,
        the BEM's volume grid; the sphere's volume grid is sized by ``n_positions``); None:
        each head's own (6, 5 and 7.8 mm). The quick preset's coarser grids keep it near a
        minute.
    """

    seeds: int = 10
    n_positions: int = 3000
    fine_step: float = 10.0
    quick: bool = False
    realistic: bool = True
    spacing_mm: float | None = None

    @property
    def cells(self):
        """The cells this run computes."""
        return tuple(cell for cell in CELLS if self.realistic or not cell.realistic)

    def control_grids(self):
        """The controls' grids: F4's tuning corners, and every exponent and smoother at the
        tuned priors (F5, F6 and the lone-source question), at every noise level."""
        seeds = list(range(self.seeds))
        return [
            dict(
                snr_db=list(NOISE_LEVELS),
                ep_snr_db=[0.0, 20.0],
                pm_snr_db=[0.0, 20.0],
                exponent=[TUNING[0]],
                smoother=[None],
                seed=seeds,
            ),
            dict(
                snr_db=list(NOISE_LEVELS),
                ep_snr_db=[TUNED_PRIOR[0]],
                pm_snr_db=[TUNED_PRIOR[1]],
                exponent=list(EXPONENTS),
                smoother=[None if s == "none" else s for s in SMOOTHERS],
                seed=seeds,
            ),
        ]

    def rule_grids(self, tuning_exponent=None):
        """Only the settings the rules read (the variants run these)."""
        corners, tuned = self.control_grids()
        if tuning_exponent is not None:
            corners = dict(corners, exponent=[tuning_exponent])
        return [corners, dict(tuned, smoother=[None, SMOOTHED[1]])]

    def paper_grid(self):
        """The paper's grid with this run's seeds (:func:`skf_ref.study.sweep.paper_grid`)."""
        from skf_ref.study.sweep import paper_grid

        return paper_grid(seeds=self.seeds)

    def fine_values(self):
        """EP and PM values (dB) of the fine map."""
        n = round((FINE_RANGE[1] - FINE_RANGE[0]) / self.fine_step)
        return [FINE_RANGE[0] + k * self.fine_step for k in range(n + 1)]

    def fine_grids(self):
        """One full product grid per fine-map setting (run_sweep takes a product)."""
        return [
            dict(
                snr_db=list(NOISE_LEVELS),
                ep_snr_db=self.fine_values(),
                pm_snr_db=self.fine_values(),
                exponent=[exponent],
                smoother=[None if smoother == "none" else smoother],
                seed=list(range(self.seeds)),
            )
            for exponent, smoother in (TUNING, SMOOTHED)
        ]

    def is_full(self):
        """Whether these are the full preset's settings, the only ones DEFAULT_OUT holds."""
        return self == FULL

    def command(self):
        """The command line that regenerates these results (without --out and --jobs)."""
        preset = QUICK if self.quick else FULL
        parts = ["python -m validation.reproduce"] + (["--quick"] if self.quick else [])
        if self.seeds != preset.seeds:
            parts.append(f"--seeds {self.seeds}")
        if self.n_positions != preset.n_positions:
            parts.append(f"--n-positions {self.n_positions}")
        if self.fine_step != preset.fine_step:
            parts.append(f"--fine-step {self.fine_step:g}")
        if self.realistic:
            parts.append("--mne-testing-data DIR")
        return " ".join(parts)


FULL = Settings()
QUICK = Settings(seeds=2, n_positions=500, fine_step=60.0, quick=True, spacing_mm=12.0)


def source_digest():
    """SHA-256 of the skf_ref sources: results computed by other code are stale."""
    import skf_ref

    digest = hashlib.sha256()
    root = Path(skf_ref.__file__).parent
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def versions():
    packages = ("skf_ref", "numpy", "scipy", "pandas", "mne", "matplotlib", "joblib", "filterpy")
    return {"python": platform.python_version(), **package_versions(packages)}


def _dataset_digest(testing_data):
    from skf_ref.study.head import SENSOR_FILES, TESTING_FILES, input_digest

    files = {name: Path(testing_data) / rel for name, rel in TESTING_FILES.items()}
    files.update({name: Path(testing_data) / rel for name, rel in SENSOR_FILES.items()})
    return input_digest(files, {})


def manifest(settings, testing_data=None):
    """Everything the results files depend on, as a JSON-ready dict.

    Parameters
    ----------
    settings : Settings
    testing_data : path-like or None
        MNE's testing dataset (its files' digest is recorded, not its location).

    Returns
    -------
    dict
    """
    return dict(
        cells=[cell.name for cell in settings.cells],
        paper_grid=settings.paper_grid(),
        fine_grids=settings.fine_grids(),
        control_grids=settings.control_grids(),
        tuned_priors=dict(
            grid=TUNE_GRID,
            range_db=list(FINE_RANGE),
            stages=list(STAGES),
            criteria=list(TUNE_CRITERIA),
        ),
        variants={name: [what, data, exp] for name, (what, data, exp) in VARIANTS.items()},
        testing_data_sha256=None if testing_data is None else _dataset_digest(testing_data),
        n_positions=settings.n_positions,
        spacing_mm=settings.spacing_mm,
        montage=MONTAGE,
        versions=versions(),
        # sorted: blas_threads' order varies from process to process (threadpoolctl's
        # order follows the string hash seed), which would make every rerun look stale
        blas=sorted(blas_threads(), key=lambda b: json.dumps(b, sort_keys=True)),
        skf_ref_sources_sha256=source_digest(),
    )
