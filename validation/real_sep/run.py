"""Load the recordings and run every setting on them."""

import numpy as np
import pandas as pd

from skf_ref import datasets
from skf_ref.datasets._fecnn import FECNN_SUBJECTS

from . import criteria, neck
from .geometry import make_recording, measure
from .methods import run
from .settings import AR1_PRIORS, CANDIDATES, SKF_PRIORS, settings

#: The noise windows (s): A0206's preprocessing excludes the 20 ms before the stimulus; the
#: 256-channel recording's baseline is the whole pre-stimulus interval.
NOISE_WINDOW = {"A0206": (None, -0.020), "sep256": (None, 0.0)}
#: The 256-channel recording without its neck rows (criteria.NECK_RULE): its baseline is
#: the all-channel one's.
HEAD_ONLY = "sep256-head"
NOISE_WINDOW[HEAD_ONLY] = NOISE_WINDOW["sep256"]
#: The time courses kept (s): the figures' window.
COURSE_WINDOW = (-0.020, 0.060)
#: The sphere's grid spacing (mm) for the 256-channel recording.
SPHERE_SPACING_MM = 10.0


def load_recordings(data=None):
    """The recordings found: A0206 (if its folder is), the 256-channel one, and the
    256-channel one without its neck rows.

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
    sep256 = make_recording("sep256", evoked, forward, cov, criteria.N20_NEAR["sep256"])
    recordings += [sep256, without_neck_rows(sep256)]
    return recordings, missing


def without_neck_rows(recording, name=HEAD_ONLY, rows=None):
    """The 256-channel recording without its neck rows (criteria.NECK_RULE).

    The same average without the rows :func:`validation.real_sep.neck.neck_rows` finds (or
    the channels ``rows`` names), re-referenced to the average of the channels kept; its
    noise covariance from the same baseline; the all-channel forward with those rows
    removed; the all-channel recording's geometry and latencies.
    """
    import mne

    if rows is None:
        rows = neck.neck_rows(recording.evoked, neck.sep256_triangles()).names
    evoked = recording.evoked.copy().del_proj()
    evoked.drop_channels(rows)
    evoked.set_eeg_reference("average", projection=True, verbose=False)
    cov = datasets.baseline_noise_cov(evoked, *NOISE_WINDOW["sep256"])
    forward = mne.pick_channels_forward(
        recording.forward, include=evoked.ch_names, ordered=True, verbose=False
    )
    return make_recording(name, evoked, forward, cov, None, like=recording)


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
    for subject in FECNN_SUBJECTS:
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


def course_window(recording):
    """The samples of :data:`COURSE_WINDOW`: the time courses saved and drawn."""
    times = recording.evoked.times
    return (times >= COURSE_WINDOW[0] - 1e-9) & (times <= COURSE_WINDOW[1] + 1e-9)


def analyse(recordings, rows=None, progress=print):
    """Every setting on every recording.

    Returns
    -------
    table : pandas.DataFrame
        One row per (recording, setting): :func:`validation.real_sep.geometry.measure`'s
        numbers, what was chosen (``note``), wall and CPU seconds.
    courses : dict
        ``(recording, setting)`` -> the time courses of :func:`measure` in
        :data:`COURSE_WINDOW`, float32.
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
            window = course_window(recording)
            courses[recording.name, name] = {
                key: c[window].astype(np.float32) for key, c in course.items()
            }
            progress(f"{recording.name:7s} {name:32s} {wall:6.1f} s  {note}")
    return pd.DataFrame(table), courses


def variant_settings():
    """The settings run on the rule's neighbours: the SKF's candidates and MNE's
    minimum-norm methods (where the report says they land)."""
    candidates = {
        f"SKF {setting}, {priors}"
        for setting in CANDIDATES
        for priors in (*SKF_PRIORS, *AR1_PRIORS)
        if priors != "auto"
    }
    return [
        (name, family, params)
        for name, family, params in settings()
        if name in candidates or family == "minimum_norm"
    ]


def neck_variants(recordings, progress=print):
    """The settings of :func:`variant_settings` without the neck rows of each of the rule's
    neighbours (:data:`validation.real_sep.neck.VARIANTS`): how much the answer hangs on
    the rows at the plane.

    Returns
    -------
    pandas.DataFrame or None
        As :func:`analyse`'s table, ``recording`` the variant's name, ``rows`` the number
        of rows dropped; None without the 256-channel recording.
    """
    found = [r for r in recordings if r.name == "sep256"]
    if not found:
        return None
    triangles = neck.sep256_triangles()
    tables = []
    for label, options in neck.VARIANTS.items():
        rows = neck.neck_rows(found[0].evoked, triangles, **options).names
        variant = without_neck_rows(found[0], name=label, rows=rows)
        table, _ = analyse([variant], variant_settings(), progress=progress)
        tables.append(table.assign(rows=len(rows)))
    return pd.concat(tables, ignore_index=True)
