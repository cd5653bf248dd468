"""Load the recordings and run every setting on them."""

import numpy as np
import pandas as pd

from skf_ref import datasets

from . import criteria
from .geometry import make_recording, measure
from .methods import run
from .settings import settings

#: The noise windows (s): A0206's preprocessing excludes the 20 ms before the stimulus; the
#: 256-channel recording's baseline is the whole pre-stimulus interval.
NOISE_WINDOW = {"A0206": (None, -0.020), "sep256": (None, 0.0)}
#: The sphere's grid spacing (mm) for the 256-channel recording.
SPHERE_SPACING_MM = 10.0


def load_recordings(data=None):
    """The recordings found: A0206 (if its folder is) and the 256-channel one.

    Returns
    -------
    recordings : list of Recording
    missing : str or None
        Why A0206 is absent, if it is.
    """
    recordings, missing = [], None
    try:
        folder = datasets.data_path(data)
    except FileNotFoundError as err:
        missing = str(err)
    else:
        evoked = datasets.load_fecnn_evoked("A0206", folder)
        forward = datasets.load_fecnn_forward(folder)
        cov = datasets.baseline_noise_cov(evoked, *NOISE_WINDOW["A0206"])
        recordings.append(
            make_recording("A0206", evoked, forward, cov, criteria.N20_NEAR["A0206"])
        )
    evoked = datasets.load_sep256_evoked()
    forward, _ = datasets.sphere_forward(evoked.info, spacing_mm=SPHERE_SPACING_MM)
    cov = datasets.baseline_noise_cov(evoked, *NOISE_WINDOW["sep256"])
    recordings.append(make_recording("sep256", evoked, forward, cov, criteria.N20_NEAR["sep256"]))
    return recordings, missing


def sensor_checks(data=None):
    """Each feCNN subject's N20 at the sensors: the CP3 minimum in 15-30 ms, CP3 and Fz there.

    Returns
    -------
    pandas.DataFrame or None
        None where the files are not found.
    """
    try:
        folder = datasets.data_path(data)
    except FileNotFoundError:
        return None
    rows = []
    for subject in datasets.FECNN_SUBJECTS:
        evoked = datasets.load_fecnn_evoked(subject, folder)
        window = np.flatnonzero((evoked.times > 0.015) & (evoked.times < 0.030))
        cp3, fz = (evoked.ch_names.index(name) for name in ("CP3", "Fz"))
        at = window[np.argmin(evoked.data[cp3, window])]
        baseline = evoked.data[:, evoked.times <= -0.020]
        rows.append(
            dict(
                subject=subject,
                channels=len(evoked.ch_names),
                nave=evoked.nave,
                n20_ms=evoked.times[at] * 1e3,
                cp3_uv=evoked.data[cp3, at] * 1e6,
                fz_uv=evoked.data[fz, at] * 1e6,
                gfp_uv=evoked.data[:, at].std() * 1e6,
                baseline_gfp_uv=np.sqrt((baseline.std(axis=0) ** 2).mean()) * 1e6,
            )
        )
    return pd.DataFrame(rows)


def analyse(recordings, rows=None, progress=print):
    """Every setting on every recording.

    Returns
    -------
    table : pandas.DataFrame
        One row per (recording, setting): :func:`validation.real_sep.geometry.measure`'s
        numbers, what was chosen (``note``), wall and CPU seconds.
    courses : dict
        ``(recording, setting)`` -> the time courses of :func:`measure`.
    """
    rows = settings() if rows is None else rows
    table, courses = [], {}
    for recording in recordings:
        for name, family, params in rows:
            amplitude, note, wall, cpu = run(recording, family, params)
            row, course = measure(recording, amplitude)
            table.append(
                dict(
                    recording=recording.name,
                    setting=name,
                    family=family,
                    priors=params["priors"],
                    note=note,
                    **row,
                    seconds=wall,
                    cpu_seconds=cpu,
                )
            )
            courses[recording.name, name] = course
            progress(f"{recording.name:7s} {name:32s} {wall:6.1f} s  {note}")
    return pd.DataFrame(table), courses
