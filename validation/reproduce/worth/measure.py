"""Every run of one set, design and linear method, measured from the method's responses.

Three kinds of runs (docs: the pre-registration's sections 2-6):

- **lone** sources (design D1 only): each thalamic and cortical source alone, noise-free and
  at its own peak SNR of 10, 20, 30 dB: peak error, whether the maximum lies in the source's
  structure, spatial dispersion; for cortical sources noise-free, the cross-talk into the
  thalamus;
- **nulls**: noise alone, and each cortical source alone at the configurations' noise level:
  the thalamic level and its ratio to the map's maximum at the thalamic peak sample;
- **configurations**: a thalamic source (1x, 0.5x, 0.25x the cortical moment) with its
  cortical source: the same two readings, the deep error at the thalamic peak; at 1x the
  superficial error at the cortical peak and the deep time-course correlation.

Estimates are sums of :class:`.linear.Response` parts in whitened units; runs are processed
in blocks of :data:`BLOCK` so that no (n_columns, n_runs) array grows large.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from skf_ref.study.resolution import level_db, peak_errors, position_amplitudes, spatial_dispersion

from .design import MOMENTS, SNRS
from .sets import PEAK_MOMENT

__all__ = ["BLOCK", "Geometry", "measure"]

#: Runs per block.
BLOCK = 128
#: The region of the time-course correlation (mm), the metrics' region.
REGION_MM = 15.0


class Geometry:
    """Positions, the thalamus and the columns near it (for the time courses)."""

    def __init__(self, positions, thalamus, points):
        self.positions = np.asarray(positions)
        self.thalamus = np.asarray(thalamus, dtype=bool)
        distance = np.linalg.norm(self.positions[:, None] - np.asarray(points)[None], axis=2)
        self.near = np.flatnonzero(distance.min(axis=1) * 1e3 <= REGION_MM + 1e-9)
        self.near_columns = (3 * self.near[:, None] + np.arange(3)).ravel()


def _amplitude(z):
    return position_amplitudes(z, 3)


def _noise(response, sample, draws):
    return response.noise_at[sample][:, draws]


def _lone_rows(geometry, response, sources, waveform, sample, first_draw, kind):
    """Lone sources of one kind: noise-free and at 10, 20, 30 dB (own peak SNR)."""
    n_draws = next(iter(response.noise_at.values())).shape[1]
    rows = []
    for start in range(0, len(sources), BLOCK):
        index = np.arange(start, min(start + BLOCK, len(sources)))
        gain = sources.gain[:, index]
        signal = response.at[waveform, sample] @ gain
        draws = (first_draw + index) % n_draws
        scale = 1.0 / np.abs(gain).max(axis=0)
        for snr in (np.inf, *SNRS):
            z = signal * scale if snr == np.inf else signal * (scale * 10 ** (snr / 20))
            if snr != np.inf:
                z = z + _noise(response, sample, draws)
            a = _amplitude(z)
            errors, peak = peak_errors(a, geometry.positions, sources.points[index])
            own = geometry.thalamus[peak] == (sources.structure[index] == "thalamus")
            cross = level_db(a, geometry.thalamus) if kind == "cortical" else np.nan
            rows.append(
                pd.DataFrame(
                    dict(
                        kind=kind,
                        index=index,
                        position=sources.position[index],
                        snr_db=snr,
                        error_mm=errors,
                        own_structure=own,
                        dispersion_mm=spatial_dispersion(
                            a, geometry.positions, sources.points[index]
                        ),
                        cross_talk_db=cross,
                    )
                )
            )
    return rows


def lone(geometry, response, study_set, samples):
    """Rows of every lone source of a set (design D1)."""
    t_d, t_c = samples
    n_thalamic = len(study_set.thalamic)
    rows = _lone_rows(geometry, response, study_set.thalamic, "thalamic", t_d, 0, "thalamic")
    rows += _lone_rows(
        geometry, response, study_set.cortical, "cortical", t_c, n_thalamic, "cortical"
    )
    return pd.concat(rows, ignore_index=True)


def _levels(a, geometry):
    return a[geometry.thalamus].max(axis=0), level_db(a, geometry.thalamus)


def nulls(geometry, response, study_set, samples, sigmas):
    """Noise-only and cortical nulls at each SNR: thalamic level and ratio at t_d."""
    t_d = samples[0]
    n_draws = response.noise_at[t_d].shape[1]
    level, ratio = _levels(_amplitude(response.noise_at[t_d]), geometry)
    rows = [
        pd.DataFrame(dict(kind="noise", index=np.arange(n_draws), snr_db=snr, level=level,
                          ratio_db=ratio))
        for snr in SNRS
    ]  # fmt: skip
    cortical = study_set.cortical
    for start in range(0, len(cortical), BLOCK):
        index = np.arange(start, min(start + BLOCK, len(cortical)))
        signal = response.at["cortical", t_d] @ cortical.gain[:, index]
        noise = _noise(response, t_d, index % n_draws)
        for snr in SNRS:
            a = _amplitude(signal * (PEAK_MOMENT / sigmas[snr]) + noise)
            level, ratio = _levels(a, geometry)
            rows.append(
                pd.DataFrame(dict(kind="cortical", index=index, snr_db=snr, level=level,
                                  ratio_db=ratio))
            )  # fmt: skip
    return pd.concat(rows, ignore_index=True)


def _time_course_r(geometry, response, thalamic, cortical, draws, scale, wave, points):
    """Deep time-course correlation of configurations at 1x (region maximum vs |waveform|)."""
    n_times, n_near, n_channels = response.near["thalamic"].shape
    near = response.near["thalamic"].reshape(-1, n_channels) @ thalamic
    near += response.near["cortical"].reshape(-1, n_channels) @ cortical
    z = near.reshape(n_times, n_near, -1) * scale + response.noise_near[:, :, draws]
    a = position_amplitudes(np.moveaxis(z, 0, 1), 3)  # (n_near, n_times, n_runs)
    distance = np.linalg.norm(geometry.positions[geometry.near][:, None] - points[None], axis=2)
    region = (distance * 1e3 <= REGION_MM + 1e-9)[:, None, :]
    course = np.where(region, a, -np.inf).max(axis=0)  # (n_times, n_runs)
    target = np.abs(wave) - np.abs(wave).mean()
    centred = course - course.mean(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (target @ centred) / (np.linalg.norm(target) * np.linalg.norm(centred, axis=0))


def configurations(geometry, response, study_set, samples, sigmas, deep_wave, with_courses):
    """Every configuration at each SNR and moment: thalamic level, ratio, errors, r."""
    t_d, t_c = samples
    n_draws = response.noise_at[t_d].shape[1]
    thalamic, cortical = study_set.thalamic, study_set.cortical
    rows = []
    for start in range(0, study_set.n_configurations, BLOCK):
        index = np.arange(start, min(start + BLOCK, study_set.n_configurations))
        partner = study_set.cortical_of(index)
        g_th, g_cx = thalamic.gain[:, index], cortical.gain[:, partner]
        draws = partner % n_draws
        deep = response.at["thalamic", t_d] @ g_th
        spread = response.at["cortical", t_d] @ g_cx
        late = response.at["thalamic", t_c] @ g_th + response.at["cortical", t_c] @ g_cx
        for snr in SNRS:
            scale = PEAK_MOMENT / sigmas[snr]
            noise_d, noise_c = _noise(response, t_d, draws), _noise(response, t_c, draws)
            a_late = _amplitude(late * scale + noise_c)
            superficial = peak_errors(a_late, geometry.positions, cortical.points[partner])[0]
            r = np.full(len(index), np.nan)
            if with_courses:
                r = _time_course_r(
                    geometry, response, g_th, g_cx, draws, scale, deep_wave,
                    thalamic.points[index],
                )  # fmt: skip
            for moment in MOMENTS:
                a = _amplitude((moment * deep + spread) * scale + noise_d)
                level, ratio = _levels(a, geometry)
                first = moment == MOMENTS[0]
                rows.append(
                    pd.DataFrame(
                        dict(
                            config=index,
                            position=thalamic.position[index],
                            snr_db=snr,
                            moment=moment,
                            level=level,
                            ratio_db=ratio,
                            deep_error_mm=peak_errors(
                                a, geometry.positions, thalamic.points[index]
                            )[0],
                            superficial_error_mm=superficial if first else np.nan,
                            deep_r=r if first else np.nan,
                        )
                    )
                )
    return pd.concat(rows, ignore_index=True)


def measure(geometry, response, study_set, samples, sigmas, deep_wave, with_lone, with_courses):
    """Every run of a set: ``{"lone": ..., "nulls": ..., "configurations": ...}`` tables.

    Parameters
    ----------
    geometry : Geometry
    response : Response
    study_set : StudySet
    samples : (int, int)
        The thalamic and the cortical peak samples.
    sigmas : dict
        SNR (dB) -> the configurations' noise level over the unit of ``gain * moment``.
    deep_wave : ndarray, shape (n_times,)
        The thalamic waveform (for the time-course correlation).
    with_lone : bool
        Whether to measure the lone sources (design D1).
    with_courses : bool
        Whether to compute the deep time-course correlation.
    """
    out = dict(
        nulls=nulls(geometry, response, study_set, samples, sigmas),
        configurations=configurations(
            geometry, response, study_set, samples, sigmas, deep_wave, with_courses
        ),
    )
    if with_lone:
        out["lone"] = lone(geometry, response, study_set, samples)
    return out
