"""The study's work items, each run in a worker and written to its own results file.

Every task rebuilds the head from the study's keyword arguments (cached in the worker), skips
what its results files already hold (a run resumes), and writes each file atomically.
"""

from __future__ import annotations

import functools
import gzip
from pathlib import Path

import numpy as np
import pandas as pd

from skf_ref._utils.atomic_files import atomic_path

from .design import DESIGNS, SNRS, SKFSetting
from .linear import (
    Response,
    matched_lambda2,
    mne_kernel,
    noise_parts,
    signal_parts,
    skf_window,
    static_response,
)
from .measure import Geometry, measure
from .skf import Prepared

__all__ = ["design_waves", "geometry", "head", "run_file", "run_linear", "thalamic_direction",
           "write_table"]  # fmt: skip

#: Significant digits of the results files.
DIGITS = "%.6g"


@functools.lru_cache(maxsize=2)
def _head(items):
    from skf_ref.study.head import make_head

    return make_head(**dict(items))


def head(study):
    """The study's head (built once per process)."""
    return _head(tuple(sorted(study.head_kwargs.items())))


def geometry(study):
    """Positions, thalamus and the columns within 15 mm of any thalamic source."""
    points = np.concatenate([s.thalamic.points for s in study.sets.values()])
    return Geometry(study.positions, study.thalamus, points)


def design_waves(design):
    """Unit-peak waveforms, the two peak samples and the number of samples of a design."""
    scenario = design.scenario()
    waves = {
        name: wave / wave.max()
        for name, wave in zip(("thalamic", "cortical"), scenario.waveforms, strict=True)
    }
    peaks = np.abs(scenario.times[None] - scenario.peak_times[:, None]).argmin(axis=1)
    return waves, tuple(int(p) for p in peaks), len(scenario.times)


def thalamic_direction(study):
    """The leading eigenvector of sum_j g_j g_j^T over the choice set's thalamic fields."""
    gain = study.sets["choice"].thalamic.gain
    _, vectors = np.linalg.eigh(gain @ gain.T)
    u = vectors[:, -1]
    return u * np.sign(u[np.argmax(np.abs(u))])


def run_file(folder, set_name, design_name, key):
    """Where the runs of a method, set and design are written."""
    return Path(folder) / "runs" / set_name / design_name / f"{key}.csv.gz"


def write_table(path, table):
    """Write a table atomically (gzip when the name ends with .gz), columns as given.

    The gzip header names no file and no time: a rerun writes the same bytes (pandas'
    gzip names the temporary file the table is written to).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = table.to_csv(index=False, float_format=DIGITS, lineterminator="\n")
    with atomic_path(path) as tmp:
        if path.suffix == ".gz":
            with open(tmp, "wb") as raw, gzip.GzipFile("", "wb", fileobj=raw, mtime=0) as out:
                out.write(text.encode())
        else:
            tmp.write_text(text)


def _stack(tables):
    return pd.concat(
        [table.assign(table=name) for name, table in tables.items()], ignore_index=True
    )


def static_lambda2(study, method):
    """The lambda2 of a Static method: 1/9, or matched to the SKF's PM-SNR of 0 dB."""
    if method.lambda2 == "1/9":
        return 1.0 / 9.0
    return matched_lambda2(0.0, study.n_channels, study.rank)


def _static_kernel(study, method, folder):
    cache = Path(folder) / "runs" / "kernels"
    return mne_kernel(head(study), method.method, static_lambda2(study, method), cache)


def _window(study, setting, n_times):
    prepared = Prepared(head(study).leadfield, setting.priors, n_times)
    return skf_window(prepared, thalamic_direction(study), setting.smooths)


def run_linear(study, method, designs, sets, sizes, folder):
    """All runs of a linear method (SKF setting or Static) in the designs and sets given.

    The signal responses are computed once per design (they do not depend on the set), the
    noise responses once per set and design.
    """
    geo = geometry(study)
    kernel = None if isinstance(method, SKFSetting) else _static_kernel(study, method, folder)
    for design_name in designs:
        index = next(k for k, d in enumerate(DESIGNS) if d.name == design_name)
        paths = {s: run_file(folder, s, design_name, method.key) for s in sets}
        if all(path.exists() for path in paths.values()):
            continue
        waves, samples, n_times = design_waves(DESIGNS[index])
        if kernel is None:
            prepared = Prepared(head(study).leadfield, method.priors, n_times)

            def outputs(Y, prepared=prepared):
                return prepared.z(Y, method)

            signal = signal_parts(outputs, waves, samples, geo.near_columns, study.n_channels)
        else:
            window = None if method.window is None else _window(study, method.window, n_times)
        for set_name, path in paths.items():
            if path.exists():
                continue
            pool = study.pool(set_name, index, sizes.pool, n_times)
            if kernel is None:
                response = Response(
                    *signal, *noise_parts(outputs, pool, samples, geo.near_columns)
                )
            else:
                response = static_response(kernel, waves, samples, geo.near_columns, pool, window)
            tables = measure(
                geo, response, study.sets[set_name], samples,
                {snr: study.sigma(snr) for snr in SNRS}, waves["thalamic"],
                with_lone=design_name == "D1", with_courses=set_name == "scored",
            )  # fmt: skip
            write_table(path, _stack(tables))
