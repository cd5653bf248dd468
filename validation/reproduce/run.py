"""The study's runs: sources drawn once, then one task per set, condition and design.

Phase A runs every candidate (and what the rule compares them with) on the choice set;
the rule chooses the default; phase B runs the named settings, the baselines and the
controls on the scored set (and the choice nulls the new methods' thresholds need). Each
task writes its rows to ``work/cells/`` atomically, so an interrupted run resumes.
"""

from __future__ import annotations

import functools
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

from skf_ref._utils.atomic_files import atomic_path

from . import measure, methods
from .conditions import condition
from .design import (
    CANDIDATES,
    CONDITIONS,
    CORTICAL_PER_HEMISPHERE,
    COSTLY_CELLS,
    DESIGN_CONDITIONS,
    DESIGNS,
    IRMXNE_RUNS,
    LAMBDA2,
    MINIMUM_NORM,
    PAPER,
    QUICK_CANDIDATES,
    QUICK_SIZES,
    SEEDS,
    SETS,
    SIZES,
    Setting,
    named,
)  # fmt: skip

MEMORYLESS = "memoryless SKF ({})"
WINDOW = "sLORETA, lambda2 matched, on N1's window"
KINDS = ("configuration", "cortical null", "noise null", "two", "lone thalamic", "lone cortical")


def _interleave(a, b):
    n = min(len(a), len(b))
    out = np.empty(2 * n, dtype=int)
    out[0::2], out[1::2] = a[:n], b[:n]
    return out


def draw(head, quick):
    """Both sets' sources: ``{set: {"thalamic"|"cortical"|"left"|"right": (points, orients)}}``."""
    from skf_ref.study._sources import draw_sources, position_labels

    labels = np.asarray(position_labels(head)).astype(str)
    sizes = QUICK_SIZES if quick else SIZES
    rng = np.random.default_rng(SEEDS["thalamic split"])
    thal = {s: [] for s in SETS}
    for side in ("Left-Thalamus", "Right-Thalamus"):
        perm = rng.permutation(np.flatnonzero(labels == side))
        thal["choice"].append(perm[: len(perm) // 2])
        thal["scored"].append(perm[len(perm) // 2 :])
    rng = np.random.default_rng(SEEDS["cortical split"])
    hemis = [rng.permutation(np.flatnonzero(labels == f"{s}-Cerebral-Cortex"))
             for s in ("Left", "Right")]  # fmt: skip
    out = {}
    first = 0
    for name in SETS:
        k = CORTICAL_PER_HEMISPHERE[name]
        left, right = (h[first : first + k] for h in hemis)
        first += k
        n = sizes[name]
        thalamic = _interleave(*thal[name])[:n]
        cortical = _interleave(left, right)[: max(n, 30)]
        chosen = np.r_[thalamic, cortical, left[:n], right[:n]]
        unique, where = np.unique(chosen, return_inverse=True)
        sources = draw_sources(head, unique, SEEDS[name])
        pts = sources.points.reshape(len(unique), 3, 3)[:, 0]
        ori = sources.orientations.reshape(len(unique), 3, 3)
        parts = np.split(where, np.cumsum([len(thalamic), len(cortical), n]))
        shift = {"thalamic": 0, "cortical": 1, "left": 1, "right": 2}
        out[name] = {
            kind: (pts[idx], ori[idx, (np.arange(len(idx)) + shift[kind]) % 3])
            for kind, idx in zip(("thalamic", "cortical", "left", "right"), parts, strict=True)
        }
    return out


def _rng(set_name, cond, design, kind, i):
    seed = SEEDS[f"noise {set_name}"]
    return np.random.default_rng(
        [seed, list(CONDITIONS).index(cond), list(DESIGNS).index(design), KINDS.index(kind), i]
    )


def _moment(cond, sources):
    """The moment (A m) that puts a typical choice cortical source at the study's SNR."""
    from .design import SNR_DB

    pts, ori = sources["choice"]["cortical"]
    peaks = np.abs(cond.W @ cond.gains(pts, ori)).max(axis=0)
    return 10.0 ** (SNR_DB / 20.0) / float(np.median(peaks))


def runs(cond, design, sources, set_name, n, moment):
    """Every run of a task: ``(kind, index, Y, truth)``, truth as :mod:`.measure` takes it."""
    spec = DESIGNS[design]
    waves = spec.waveforms()
    src = sources[set_name]

    def field(kind, i):
        pts, ori = src[kind]
        return cond.gains(pts[i : i + 1], ori[i : i + 1])[:, 0], pts[i]

    def noise(kind, i):
        return cond.noise(_rng(set_name, cond.name, design, kind, i), spec.n_times, spec.sfreq)

    for i in range(n):
        if spec.kind == "pair":
            (gd, pd_), (gc, pc) = field("thalamic", i), field("cortical", i)
            cortical = moment * np.outer(gc, waves["cortical"])
            yield ("configuration", i,
                   moment * np.outer(gd, waves["deep"]) + cortical
                   + noise("configuration", i), (pd_, pc, (moment, moment)))  # fmt: skip
            yield "cortical null", i, cortical + noise("configuration", i), None
            yield "noise null", i, noise("noise null", i), None
        elif spec.kind == "two":
            (gl, pl), (gr, pr) = field("left", i), field("right", i)
            Y = moment * np.outer(gl + gr, waves["left"]) + noise("two", i)
            yield "two", i, Y, (pl, pr)
        else:
            for kind, wave in (("lone thalamic", "deep"), ("lone cortical", "cortical")):
                g, p = field(kind.split()[1], i)
                yield kind, i, moment * np.outer(g, waves[wave]) + noise(kind, i), p


def _metrics(kind, A, geometry, spec, truth):
    if kind == "configuration":
        return measure.pair(A, geometry, spec, *truth)
    if kind in ("cortical null", "noise null"):
        return measure.null(A, geometry, spec)
    if kind == "two":
        return measure.two(A, geometry, spec, *truth)
    return measure.lone(A, geometry, spec, truth, kind.split()[1])


@functools.lru_cache(maxsize=8)
def _sources(work):
    return json.loads((Path(work) / "sources.json").read_text())


def _loaded(work):
    raw = _sources(work)
    return {s: {k: (np.array(v[0]), np.array(v[1])) for k, v in d.items()} for s, d in raw.items()}


def task(work, root, quick, set_name, cond_name, design, skf_settings, extras):
    """One set x condition x design: every method's rows, written to ``work/cells``."""
    path = Path(work) / "cells" / f"{set_name}-{cond_name}-{design}-{extras['tag']}.csv"
    if path.exists():
        return path
    started = time.process_time()
    sources = _loaded(work)
    cond = condition(cond_name, root, quick)
    spec = DESIGNS[design]
    geometry = measure.Geometry.of(cond.head)
    skf = methods.SKF(cond, spec)
    moment = _moment(cond, sources)
    n = (QUICK_SIZES if quick else SIZES)[set_name]
    memoryless = {std: skf.memoryless_kernel(Setting("walk EP 0", std, "none"))
                  for std in extras["memoryless"]}  # fmt: skip
    window = None
    if extras.get("window") is not None:
        window = _window(
            work,
            cond,
            skf,
            sources,
            extras["window"],
            extras.get("window_tag", extras["tag"]),
            design,
        )
    rows = []
    for kind, i, Y, truth in runs(cond, design, sources, set_name, n, moment):
        if extras.get("nulls only") and kind not in ("cortical null", "noise null"):
            continue
        maps, tau, bound = skf.amplitudes(Y, skf_settings)
        maps = {s.label: A for s, A in maps.items()}
        for method in extras["minimum norm"]:
            for label in LAMBDA2:
                maps[f"{method}, lambda2 {label}"] = methods.minimum_norm(cond, method, label, Y)
        for std, K in memoryless.items():
            maps[MEMORYLESS.format(std)] = methods._norms(K @ (cond.W @ Y))
        if window is not None:
            maps[WINDOW] = methods.minimum_norm(cond, "sLORETA", "matched", Y @ window.T)
        if extras.get("lcmv"):
            maps["LCMV"] = methods.lcmv(cond, Y, spec)
        if extras.get("irmxne") and kind == "configuration" and i < IRMXNE_RUNS:
            maps["irMxNE"] = methods.irmxne(cond, Y, spec)
        for method, A in maps.items():
            row = dict(set=set_name, condition=cond_name, design=design, kind=kind, run=i,
                       method=method, **_metrics(kind, A, geometry, spec, truth))  # fmt: skip
            if tau is not None and "AR auto" in method:
                row.update(tau_ms=tau, at_bound=bound)
            rows.append(row)
    frame = pd.DataFrame(rows)
    frame["cpu_s"] = time.process_time() - started
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False)
    return path


def _window(work, cond, skf, sources, window, tag, design):
    """N1's effective window in this condition and design, computed once (``work/windows``)."""
    path = Path(work) / "windows" / f"{cond.name}-{design}-{tag}.npy"
    if path.exists():
        return np.load(path)
    setting, tau = window
    pts, ori = sources["choice"]["thalamic"]
    fields = cond.W @ cond.gains(pts, ori)
    u = np.linalg.eigh(fields @ fields.T)[1][:, -1]
    h = skf.window(setting, tau, u)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        np.save(tmp, h)
    return h


def _parallel(calls, jobs):
    # the MEG cells take longest (their forward is built in the cell): first, so that
    # the other worker is not left idle at the end; the rows do not depend on the order
    calls = sorted(calls, key=lambda call: call[1][5] != "MEG")
    if jobs == 1:
        return [f(*a) for f, a in calls]
    from joblib import Parallel, delayed

    return Parallel(n_jobs=jobs)(delayed(f)(*a) for f, a in calls)


def phase_a(work, root, quick, jobs):
    """Every candidate, MNE's methods, N2 and the memoryless SKF on the choice set."""
    candidates = QUICK_CANDIDATES if quick else CANDIDATES
    settings = (*candidates, PAPER)
    extras = dict(tag="a", **{"minimum norm": MINIMUM_NORM}, memoryless=("column", "position"))
    calls = [
        (task, (work, root, quick, "choice", c, d, settings, extras))
        for d in _designs(quick) for c in _conditions(d, quick)
    ]  # fmt: skip
    return _parallel(calls, jobs)


def phase_b(work, root, quick, jobs, default, tau_ms):
    """The named settings, baselines and controls on the scored set (and new choice nulls)."""
    settings = tuple(dict.fromkeys(named(default).values()))
    tag = "b-" + "".join(c for c in default.label if c.isalnum())[-40:]
    calls = []
    for d in _designs(quick):
        for c in _conditions(d, quick):
            costly = (c, d) in COSTLY_CELLS or (quick and d == "D1")
            windowed = DESIGNS[d].kind != "lone" and not (quick and d != "D1")
            extras = dict(tag=tag, **{"minimum norm": MINIMUM_NORM},
                          memoryless=(default.standardize,),
                          window=(default, tau_ms) if windowed else None,
                          lcmv=costly, irmxne=costly and not quick)  # fmt: skip
            calls.append((task, (work, root, quick, "scored", c, d, settings, extras)))
            if DESIGNS[d].kind == "pair":
                nulls = dict(extras, **{"minimum norm": (), "nulls only": True}, memoryless=(),
                             irmxne=False, tag=tag + "-nulls", window_tag=tag)  # fmt: skip
                calls.append((task, (work, root, quick, "choice", c, d, (), nulls)))
    return _parallel(calls, jobs)


def _designs(quick):
    return ("D1", "ERP") if quick else tuple(DESIGNS)


def _conditions(design, quick):
    return ("b64-white",) if quick else DESIGN_CONDITIONS[design]


def save_sources(work, root, quick):
    """Draw the sources once (on the BioSemi head) and keep them in ``work/sources.json``."""
    path = Path(work) / "sources.json"
    if not path.exists():
        head = condition("b64-white", root, quick).head
        drawn = draw(head, quick)
        plain = {s: {k: (v[0].tolist(), v[1].tolist()) for k, v in d.items()}
                 for s, d in drawn.items()}  # fmt: skip
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            Path(tmp).write_text(json.dumps(plain))
    return path


def read_cells(work, pattern="*.csv"):
    """Every row written so far."""
    files = sorted((Path(work) / "cells").glob(pattern))
    return pd.concat([pd.read_csv(f) for f in files], ignore_index=True)
