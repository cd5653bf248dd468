"""``python -m validation.real_sep [--data DIR] [--out DIR]``: the report on the real SEPs.

Writes ``OUT/REAL.md``, ``OUT/real.csv`` (every number), ``OUT/courses.npz`` (the time
courses), ``OUT/neck_variants.csv`` (the neck rule's neighbours), ``OUT/run.json`` (run
time, load, versions), ``OUT/sensors_*.png``,
``OUT/maxima_*.png``, ``OUT/time_courses_*.png`` and ``OUT/neck_rows_sep256.png`` (default OUT:
``validation/report/real``). ``--data``: the folder holding ``fecnn/``
(:func:`skf_ref.datasets.data_path` finds it otherwise; nothing is downloaded).
``--render``: the report and figures again from the saved numbers, without running a
method (a few seconds).
"""

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from skf_ref._utils.atomic_files import atomic_path
from skf_ref._utils.provenance import package_versions

from . import criteria, figures, neck
from .report import (
    TITLES,
    candidates_table,
    contrasts,
    criteria_and_unknowns,
    observations,
    results_table,
    summary,
    variants_table,
    verdict,
    where_they_land,
)
from .run import (
    HEAD_ONLY,
    NOISE_WINDOW,
    SPHERE_SPACING_MM,
    analyse,
    load_recordings,
    neck_variants,
    sensor_checks,
)

OUT = Path(__file__).resolve().parents[1] / "report" / "real"
#: The reading of the numbers, written by hand after a run and printed first: the report's
#: own text is generated, this is not (its numbers are those of the run it names).
READING = Path(__file__).with_name("reading.md")


def _recordings_table(recordings):
    lines = [
        "| recording | channels | nave | forward | positions | noise window (ms) | "
        "P14 / P16 / N20 (ms) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in recordings:
        start, end = NOISE_WINDOW[r.name]
        first = r.evoked.times[0] if start is None else start
        forward = (
            "FEM (duneuro), fixed"
            if r.orientations is not None
            else (f"3-shell sphere, {SPHERE_SPACING_MM:g} mm grid, free")
        )
        lat = " / ".join(f"{r.latencies[e] * 1e3:.1f}" for e in ("P14", "P16", "N20"))
        lines.append(
            f"| {r.name} | {len(r.evoked.ch_names)} | {r.evoked.nave} | {forward} | "
            f"{len(r.positions)} | {first * 1e3:.0f} ... {end * 1e3:.0f} | {lat} |"
        )
    return "\n".join(lines)


def _sensor_table(checks):
    if checks is None:
        return "(the feCNN files were not found)"
    lines = [
        "| subject | channels | nave | N20 (CP3 minimum, ms) | CP3 (µV) | Fz (µV) | GFP (µV) |"
        " baseline GFP (µV) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for _, r in checks.iterrows():
        lines.append(
            f"| {r['subject']} | {r['channels']} | {r['nave']} | {r['n20_ms']:.1f} | "
            f"{r['cp3_uv']:.2f} | {r['fz_uv']:.2f} | {r['gfp_uv']:.2f} | "
            f"{r['baseline_gfp_uv']:.2f} |"
        )
    return "\n".join(lines)


def _time_breakdown(table, variants=None):
    """Where the run's time went: the SKF's rows, MxNE with SURE, the rest."""
    sure = table["setting"] == "MxNE, alpha SURE"
    skf = table["family"] == "skf"
    per_recording = ", ".join(
        f"{name} {seconds:.0f} s"
        for name, seconds in table[sure].groupby("recording", sort=False)["seconds"].sum().items()
    )
    return (
        f"Of the settings' {table['seconds'].sum():.0f} s: the SKF's {skf.sum()} rows "
        f"{table[skf]['seconds'].sum():.0f} s (the AR(1) rows "
        f"{table[skf & table['setting'].str.contains('/AR')]['seconds'].sum():.0f} s), MxNE "
        f"with SURE {table[sure]['seconds'].sum():.0f} s ({per_recording}), the other "
        f"methods {table[~skf & ~sure]['seconds'].sum():.0f} s"
        + (
            f"; the neck rule's neighbours {variants['seconds'].sum():.0f} s more."
            if variants is not None
            else "."
        )
    )


def _variants_part(rows, variants, dropped):
    """The rule's sensitivity: its neighbours' rows beside its own (observations)."""
    if variants is None or not len(variants):
        return []
    return [
        "**How much the answer hangs on the rows at the plane** (run after the rule, as "
        "an observation, not a part of it): the SKF's candidates and MNE's minimum-norm "
        "methods again without the neck rows of the rule's two neighbours "
        "(`validation.real_sep.neck.VARIANTS`: the registration trimmed at 5 mm, and one that "
        "may turn); a cell: checks met, the N20 maximum's distance to the central region, "
        "**bold** where the three N20 checks are met.",
        "",
        variants_table(rows, variants, dropped),
        "",
    ]


def write_report(out, recordings, missing, table, checks, run, variants=None):
    criteria_text, unknowns = criteria_and_unknowns()
    versions = ", ".join(f"{k} {v}" for k, v in run["versions"].items())
    parts = [
        "# The real SEPs through the SKF and MNE-Python's methods",
        "",
        f"Generated by `python -m validation.real_sep` in {run['wall']:.0f} s wall, "
        f"{run['cpu']:.0f} s CPU, on {run['cpus']} cores with a load average of "
        f"{run['load'][0]:.1f} / {run['load'][1]:.1f} (1 / 5 minutes) at the end, with "
        f"{versions}. Every number is in `real.csv` (run times per setting in its "
        "`seconds` and `cpu_seconds`), the time courses (-20 ... 60 ms) in `courses.npz`. "
        + _time_breakdown(table, variants),
        "",
        *([READING.read_text(encoding="utf-8").rstrip(), ""] if READING.exists() else []),
        criteria_text,
        "",
        criteria.NECK_RULE.rstrip(),
        "",
        "![neck rows](neck_rows_sep256.png)",
        "",
        "## The recordings",
        "",
        _recordings_table(recordings),
        "",
        *([f"A0206 is absent: {missing}", ""] if missing else []),
        "The N20 at the sensors of the three feCNN subjects (the CP3 minimum in 15-30 ms):",
        "",
        _sensor_table(checks),
        "",
    ]
    channels = max(len(r.evoked.ch_names) for r in recordings)  # the 256-channel cap's
    for r in recordings:
        rows = table[table["recording"] == r.name]
        sensors = "sep256" if r.name == HEAD_ONLY else r.name
        parts += [
            f"## {TITLES[r.name]}",
            "",
            f"![sensors](sensors_{sensors}.png)",
            "",
            "Checks, in order: N20 left, N20 central, N20 cortical, P14 deep, P16 deep. "
            "*to the region / p\\**: the N20 maximum's distance to the central region (0 "
            "inside) and to its centre p\\*. *Deep share*: the deep region's largest amplitude "
            "at the P14 over the maximum's (1: the maximum is deep).",
            "",
            "The SKF's candidates (PM-SNR 0 dB; a cell: checks met, the N20 maximum's "
            "distance to the central region; **bold**: the three N20 checks met):",
            "",
            candidates_table(rows),
            "",
            *(
                _variants_part(rows, variants, channels - len(r.evoked.ch_names))
                if r.name == HEAD_ONLY
                else []
            ),
            "Every setting:",
            "",
            results_table(rows),
            "",
            summary(rows),
            "",
            "Where they land (generated from the table):",
            "",
            where_they_land(rows, r),
            "",
            contrasts(rows),
            "",
            f"![maxima](maxima_{r.name}.png)",
            "",
            f"![time courses](time_courses_{r.name}.png)",
            "",
        ]
    parts += [
        "## What the numbers say",
        "",
        verdict(table),
        "",
        observations(table, recordings),
        "",
        unknowns,
        "",
    ]
    with atomic_path(out / "REAL.md") as path:
        Path(path).write_text("\n".join(parts), encoding="utf-8")


def _save_run(out, table, courses, wall, cpu, variants=None):
    """real.csv, courses.npz, neck_variants.csv and run.json: what a rerun of the report
    reads (--render)."""
    run = dict(
        wall=wall,
        cpu=cpu,
        cpus=os.cpu_count(),
        load=list(os.getloadavg()),
        versions={
            k: v
            for k, v in package_versions().items()
            if k in ("skf_ref", "mne", "numpy", "scipy")
        },
    )
    with atomic_path(out / "real.csv") as path:
        table.to_csv(path, index=False, float_format="%.6g")
    if variants is not None:
        with atomic_path(out / "neck_variants.csv") as path:
            variants.to_csv(path, index=False, float_format="%.6g")
    arrays = {
        "|".join((*key, name)): c for key, course in courses.items() for name, c in course.items()
    }
    with atomic_path(out / "courses.npz") as path:
        np.savez_compressed(path, **arrays)
    with atomic_path(out / "run.json") as path:
        Path(path).write_text(json.dumps(run, indent=1), encoding="utf-8")
    return run


def _read_run(out):
    """The saved table, time courses, run and neck variants of a previous run (--render)."""
    table = pd.read_csv(out / "real.csv")
    courses = {}
    with np.load(out / "courses.npz") as arrays:
        for key in arrays.files:
            recording, setting, name = key.split("|")
            courses.setdefault((recording, setting), {})[name] = arrays[key]
    found = out / "neck_variants.csv"
    variants = pd.read_csv(found) if found.exists() else None
    return table, courses, json.loads((out / "run.json").read_text(encoding="utf-8")), variants


#: The figures' resolution, and the colours a PNG keeps: line drawings need few, and the
#: report stays small.
DPI, COLOURS = 80, 64


def _save_png(figure, path):
    """The figure as a PNG of at most :data:`COLOURS` colours."""
    import io

    from PIL import Image

    buffer = io.BytesIO()
    figure.savefig(buffer, dpi=DPI, format="png")
    buffer.seek(0)
    with Image.open(buffer) as image:
        image.convert("RGB").quantize(colors=COLOURS).save(path, format="png", optimize=True)


def write_outputs(out, recordings, missing, table, courses, checks, run, variants=None):
    """The figures and REAL.md."""
    for r in recordings:
        drawn = [
            ("maxima", figures.maxima(r, table)),
            ("time_courses", figures.time_courses(r, table, courses)),
        ]
        if r.name != HEAD_ONLY:  # its sensors are the all-channel recording's, drawn there
            drawn.insert(0, ("sensors", figures.sensors(r)))
        if r.name == "sep256":
            drawn.append(
                ("neck_rows", figures.neck(r, neck.neck_rows(r.evoked, neck.sep256_triangles())))
            )
        for name, figure in drawn:
            with atomic_path(out / f"{name}_{r.name}.png") as path:
                _save_png(figure, path)
    write_report(out, recordings, missing, table, checks, run, variants)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m validation.real_sep", description=__doc__)
    parser.add_argument("--data", help="the folder holding fecnn/ (found if not given)")
    parser.add_argument("--out", default=str(OUT), help="where the report goes")
    parser.add_argument(
        "--render",
        action="store_true",
        help="redraw REAL.md and the figures from OUT's real.csv, courses.npz and run.json "
        "(no method is run)",
    )
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    wall, cpu = time.perf_counter(), time.process_time()
    recordings, missing = load_recordings(args.data)
    if args.render:
        table, courses, run, variants = _read_run(out)
    else:
        table, courses = analyse(recordings)
        variants = neck_variants(recordings)
        run = _save_run(
            out,
            table,
            courses,
            time.perf_counter() - wall,
            time.process_time() - cpu,
            variants,
        )
    write_outputs(
        out, recordings, missing, table, courses, sensor_checks(args.data), run, variants
    )
    print(f"wrote {out / 'REAL.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
