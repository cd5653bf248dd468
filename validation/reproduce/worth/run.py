"""The study of the SKF's worth (v2), start to end: tasks, the rule, summaries, contrasts.

:func:`start_worth` draws the sets and hands out the jobs of phase A (the SKF candidates
on the choice set, MNE's methods, LCMV, irMxNE's alpha), which the caller runs in parallel
beside its own; :func:`finish_worth` applies the rule, runs what depends on the default
(phase B: the default and the best SKF setting scored, the temporal controls, irMxNE
scored, the priors chosen by the data), and gathers everything a report needs in a
:class:`Worth`. Results files live in ``out/worth/``; a rerun reuses them unless the study's
manifest changed.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from skf_ref._utils.atomic_files import atomic_path

from .design import (
    DESIGNS,
    IRMXNE_ALPHAS,
    LAMBDA2,
    NAMED,
    SETS,
    SNRS,
    STATIC_METHODS,
    SKFSetting,
    Static,
    candidates,
)
from .runs import irmxne_runs, lcmv_runs, run_irmxne, run_lcmv, run_tuned, tuned_runs
from .tasks import run_file, run_linear

__all__ = ["FOLDER", "Worth", "finish_worth", "start_worth"]

#: The study's folder in the report folder.
FOLDER = "worth"
#: Runs per LCMV task.
LCMV_CHUNK = 40


@dataclass(eq=False)
class Worth:
    """Everything the report's sections on the SKF's worth are written from."""

    study: object = field(repr=False)
    sizes: object
    folder: Path = None  # the study's results folder (out/worth)
    candidates: list = field(default_factory=list, repr=False)  # the SKF settings compared
    settings: dict = field(default_factory=dict, repr=False)  # key -> SKFSetting or Static
    named: dict = field(default_factory=dict)  # "N1".. -> key
    summaries: pd.DataFrame = field(default=None, repr=False)
    thresholds: dict = field(default_factory=dict)  # (key, design) -> {snr: tau}
    rule: tuple = None  # (setting, met_all, table)
    best: dict = field(default_factory=dict)  # "skf", "minimum norm", "control" -> key
    windows: dict = field(default_factory=dict)  # window label -> (setting, h at t_d)
    irmxne_alpha: dict = field(default_factory=dict)
    tuned: pd.DataFrame = field(default=None, repr=False)
    contrasts: pd.DataFrame = field(default=None, repr=False)
    scored_runs: dict = field(default_factory=dict, repr=False)
    lcmv: pd.DataFrame = field(default=None, repr=False)
    irmxne: pd.DataFrame = field(default=None, repr=False)
    summarized: dict = field(default_factory=dict, repr=False)  # results file -> its summary

    def label(self, key):
        """A method's label in tables."""
        return self.settings[key].label if key in self.settings else key

    @property
    def window_settings(self):
        """The canonical settings of N1's, N2's and N4's windows (distinct)."""
        names = [name for name in ("N1", "N2", "N4") if name in self.named]
        return list(dict.fromkeys(_window_setting(self.settings[self.named[n]]) for n in names))


def _parallel(jobs, n_jobs):
    from joblib import Parallel, delayed

    if jobs:
        Parallel(n_jobs=n_jobs)(delayed(function)(*args) for function, *args in jobs)


def _manifest(study, sizes, skf):
    from ..settings import source_digest, versions

    return dict(
        sizes=sizes.__dict__ | dict(designs=list(sizes.designs)),
        candidates=[s.key for s in skf],
        head=study.head_kwargs | dict(testing_data=None, cache_dir=None),
        a_ref=round(study.a_ref, 15),
        versions=versions(),
        skf_ref_sources_sha256=source_digest(),
    )


def _prepare(folder, manifest, fresh):
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "manifest.json"
    previous = json.loads(path.read_text()) if path.exists() else None
    if fresh or previous != json.loads(json.dumps(manifest)):
        shutil.rmtree(folder / "runs", ignore_errors=True)
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")


def _chunks(items, size):
    return [items[k : k + size] for k in range(0, len(items), size)]


def _statics(windows=()):
    plain = [Static(m, rule) for m in STATIC_METHODS for rule in LAMBDA2]
    controls = [
        Static(m, rule, window) for window in windows for m in ("sLORETA", "eLORETA")
        for rule in LAMBDA2
    ]  # fmt: skip
    return plain + controls


def _window_setting(setting):
    """The canonical setting that names a window (its priors, and whether it smooths)."""
    smoother = "rts-state" if setting.smooths else "none"
    return SKFSetting(0.5, smoother, "column", *setting.priors)


def _phase_a(study, sizes, skf, folder):
    named = set(NAMED.values())
    jobs = [
        (run_linear, study, s, sizes.designs if s in named else ("D1",),
         SETS if s in named else ("choice",), sizes, folder)
        for s in skf
    ]  # fmt: skip
    jobs += [(run_linear, study, s, sizes.designs, SETS, sizes, folder) for s in _statics()]
    for k, chunk in enumerate(_chunks(lcmv_runs(study, sizes), LCMV_CHUNK)):
        path = Path(folder) / "runs" / "lcmv" / f"part-{k:02d}.csv.gz"
        if not path.exists():
            jobs.append((run_lcmv, study, chunk, sizes, path))
    alphas = {snr: IRMXNE_ALPHAS for snr in SNRS}
    for snr in SNRS:
        path = Path(folder) / "runs" / "irmxne" / f"choice-snr{snr:g}.csv.gz"
        runs = [run for run in irmxne_runs(study, sizes) if run[3] == snr]
        if not path.exists():
            jobs.append((run_irmxne, study, runs, alphas, sizes, path))
    return jobs


def _irmxne_alpha(folder):
    """Per SNR, the alpha whose median residual ratio is closest to 1 (ties: the larger)."""
    table = pd.concat(
        pd.read_csv(p) for p in sorted((folder / "runs" / "irmxne").glob("choice-*"))
    )
    chosen = {}
    for snr, group in table.groupby("snr_db"):
        distance = group.groupby("alpha")["residual_ratio"].median().map(lambda r: abs(np.log(r)))
        best = distance[distance <= distance.min() + 1e-12]
        chosen[float(snr)] = float(best.index.max())
    return chosen


def _phase_b(study, sizes, worth, folder):
    jobs = []
    for key in {worth.named["N1"], worth.best["skf"]}:
        setting = worth.settings[key]
        jobs.append((run_linear, study, setting, sizes.designs, SETS, sizes, folder))
    for static in _statics(worth.window_settings):
        jobs.append((run_linear, study, static, ("D1",), SETS, sizes, folder))
    alphas = {snr: [worth.irmxne_alpha[snr]] for snr in SNRS}
    path = Path(folder) / "runs" / "irmxne" / "scored.csv.gz"
    if not path.exists():
        jobs.append((run_irmxne, study, irmxne_runs(study, sizes, alphas), alphas, sizes, path))
    tuned = {}
    for name in ("N1", "N2", "N4"):  # one entry per distinct setting, named by all its names
        setting = worth.settings[worth.named[name]]
        same = [label for label, other in tuned.items() if other == setting]
        if same:
            tuned[f"{same[0]}, {name}"] = tuned.pop(same[0])
        else:
            tuned[name] = setting
    for k, chunk in enumerate(_chunks(tuned_runs(study, sizes), 6)):
        path = Path(folder) / "runs" / "tuned" / f"part-{k:02d}.csv.gz"
        if not path.exists():
            jobs.append((run_tuned, study, chunk, tuned, sizes, path, folder / "runs" / "kernels"))
    return jobs


def _summaries(worth, folder, keys, designs):
    """Thresholds from the choice set, summaries of both sets, for every linear method.

    Each results file is read and summarized once (``worth.summarized``): the second call,
    after phase B, adds only phase B's files.
    """
    from .summary import read_runs, summarize, thresholds

    parts = []
    for key in keys:
        for design in designs:
            if not run_file(folder, "choice", design, key).exists():
                continue
            for set_name in SETS:  # "choice" first: its nulls set the thresholds
                path = run_file(folder, set_name, design, key)
                if not path.exists():
                    continue
                if path not in worth.summarized:
                    runs = read_runs(path)
                    if set_name == "choice":
                        worth.thresholds[key, design] = thresholds(runs["nulls"])
                    if set_name == "scored" and design == "D1":
                        worth.scored_runs[key] = runs
                    summary = summarize(runs, worth.thresholds[key, design])
                    worth.summarized[path] = summary.assign(
                        method=key, design=design, set=set_name
                    )
                parts.append(worth.summarized[path])
    return pd.concat(parts, ignore_index=True)


def _inputs(summaries, key, set_name="choice"):
    from .rule import inputs

    part = summaries[
        (summaries["method"] == key)
        & (summaries["design"] == "D1")
        & (summaries["set"] == set_name)
    ]
    return inputs(part)


def _choose(worth, skf):
    from .rule import best_of, choose_default

    reference = _inputs(worth.summaries, Static("eLORETA", "1/9").key)
    candidates_ = {s: _inputs(worth.summaries, s.key) for s in skf}
    worth.rule = choose_default(candidates_, reference)
    worth.named["N1"] = worth.rule[0].key
    worth.best["skf"] = best_of({s.key: v for s, v in candidates_.items()})
    plain = {s.key: _inputs(worth.summaries, s.key) for s in _statics()}
    worth.best["minimum norm"] = best_of(plain)


def _per_run_tables(folder, name, pattern):
    paths = sorted((Path(folder) / "runs" / name).glob(pattern))
    return pd.concat([pd.read_csv(p) for p in paths], ignore_index=True) if paths else None


def _lcmv_summary(worth, folder):
    from .summary import as_linear_tables, summarize, thresholds

    rows = _per_run_tables(folder, "lcmv", "part-*")
    worth.lcmv = rows
    choice = as_linear_tables(rows[rows["set"] == "choice"])
    scored = as_linear_tables(rows[rows["set"] == "scored"])
    levels = thresholds(choice["nulls"])
    worth.thresholds["LCMV", "D1"] = levels
    return summarize(scored, levels).assign(method="LCMV", design="D1", set="scored")


def _irmxne_summary(worth, folder):
    from .summary import as_linear_tables, summarize

    rows = _per_run_tables(folder, "irmxne", "scored*")
    worth.irmxne = rows
    levels = {snr: 0.0 for snr in SNRS}  # detection: any thalamic activity at all
    worth.thresholds["irMxNE", "D1"] = levels
    summary = summarize(as_linear_tables(rows), levels)
    return summary.assign(method="irMxNE", design="D1", set="scored")


def _control(worth):
    """The best static variant on data in N1's window (lowest mean error, choice set)."""
    from .rule import best_of

    window = _window_setting(worth.settings[worth.named["N1"]])
    pool = {
        s.key: _inputs(worth.summaries, s.key) for s in _statics([window]) if s.window is not None
    }
    return best_of(pool)


def _contrasts(worth):
    from .contrasts import contrast_table

    n1 = worth.named["N1"]
    pairs = [
        ("C1: the default vs the paper's setting", n1, worth.named["N2"]),
        ("C2: the default vs eLORETA (λ² 1/9)", n1, Static("eLORETA", "1/9").key),
        ("C3: the best SKF setting vs the best minimum-norm method", worth.best["skf"],
         worth.best["minimum norm"]),
        ("C4: the default vs its temporal control", n1, worth.best["control"]),
    ]  # fmt: skip
    levels = {key: worth.thresholds[key, "D1"] for key in worth.scored_runs}
    return contrast_table(pairs, worth.scored_runs, levels)


def _register(worth, skf):
    for setting in [*skf, *_statics()]:
        worth.settings[setting.key] = setting
    for name, setting in NAMED.items():
        if setting.key in worth.settings:
            worth.named[name] = setting.key


def _write(worth, folder):
    worth.summaries.to_csv(folder / "summary.csv", index=False, float_format="%.6g",
                           lineterminator="\n")  # fmt: skip
    table = worth.rule[2].assign(setting=lambda t: t["setting"].map(lambda s: s.key))
    table.to_csv(folder / "rule.csv", index=False, float_format="%.6g", lineterminator="\n")
    worth.contrasts.to_csv(folder / "contrasts.csv", index=False, float_format="%.6g",
                           lineterminator="\n")  # fmt: skip
    worth.study.sources_table().to_csv(folder / "sources.csv", index=False,
                                       float_format="%.6g", lineterminator="\n")  # fmt: skip


def start_worth(settings, out, testing_data=None, cache_dir=None, fresh=False):
    """Prepare the study and its first phase: a :class:`Worth` and the jobs of phase A.

    Parameters
    ----------
    settings : validation.reproduce.settings.Settings
        The report run's settings (``quick`` selects the smoke sizes; ``realistic`` the BEM
        head, else the sphere's cortex + thalamus).
    out : path-like
        The report folder.
    testing_data, cache_dir : path-like or None
    fresh : bool
        Recompute every run.

    Returns
    -------
    worth : Worth
    jobs : list of tuple
        ``(function, *args)``, each writing its results files (resumable): run them on
        any workers (beside other jobs), then :func:`finish_worth`.
    """
    from skf_ref.study.head import make_head

    from ..cells import head_kwargs
    from ..settings import CELLS
    from .design import FULL, QUICK
    from .sets import make_study

    sizes = QUICK if settings.quick else FULL
    name = "bem-anatomical" if settings.realistic else "sphere-anatomical"
    cell = next(c for c in CELLS if c.name == name)
    kwargs = head_kwargs(cell, settings, testing_data, cache_dir)
    study = make_study(make_head(**kwargs), kwargs, sizes)
    skf = candidates()
    if not sizes.all_candidates:
        skf = [s for s in skf if s in NAMED.values()]
    folder = Path(out) / FOLDER
    _prepare(folder, _manifest(study, sizes, skf), fresh)
    worth = Worth(study, sizes, folder=folder, candidates=skf)
    _register(worth, skf)
    return worth, _phase_a(study, sizes, skf, folder)


def finish_worth(worth, n_jobs=1):
    """After phase A's jobs: apply the rule, run phase B on ``n_jobs`` workers, gather
    every summary, contrast and window; write the study's tables; return ``worth``."""
    study, sizes, folder, skf = worth.study, worth.sizes, worth.folder, worth.candidates
    keys = [s.key for s in [*skf, *_statics()]]
    worth.summaries = _summaries(worth, folder, keys, sizes.designs)
    _choose(worth, skf)
    for key in (worth.named["N1"], worth.best["skf"]):
        worth.settings.setdefault(key, next(s for s in skf if s.key == key))
    worth.irmxne_alpha = _irmxne_alpha(folder)
    _parallel(_phase_b(study, sizes, worth, folder), n_jobs)
    statics = _statics(worth.window_settings)
    for static in statics:
        worth.settings[static.key] = static
    keys = list(dict.fromkeys([*keys, *(s.key for s in statics)]))
    worth.summaries = pd.concat(
        [_summaries(worth, folder, keys, sizes.designs), _lcmv_summary(worth, folder),
         _irmxne_summary(worth, folder)],
        ignore_index=True,
    )  # fmt: skip
    worth.best["control"] = _control(worth)
    worth.windows = _windows(study, worth)
    worth.tuned = _per_run_tables(folder, "tuned", "part-*")
    worth.contrasts = _contrasts(worth)
    _write(worth, folder)
    return worth


def _windows(study, worth):
    """Each window's weights at the thalamic peak sample (D1) and its effective samples."""
    from .linear import skf_window
    from .skf import Prepared
    from .tasks import design_waves, head, thalamic_direction

    _, samples, n_times = design_waves(DESIGNS[0])
    out = {}
    for setting in worth.window_settings:
        prepared = Prepared(head(study).leadfield, setting.priors, n_times)
        h = skf_window(prepared, thalamic_direction(study), setting.smooths)[samples[0]]
        out[setting.key] = (setting, h, float(h.sum() ** 2 / np.sum(h**2)))
    return out
