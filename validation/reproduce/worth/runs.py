"""Which data sets the per-run methods see, and their tasks (LCMV, irMxNE, tuned priors).

A *run* is one data set: ``(set, kind, index, snr_db, moment)`` with kind ``"thalamic"``
or ``"cortical"`` (a lone source at its own peak SNR), ``"noise"`` (a noise-only null),
``"cortical-null"`` (a cortical null at the configurations' noise level) or ``"config"`` (a
configuration). :func:`data_of` builds its data exactly as the linear study adds them up.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pandas as pd

from .design import DESIGNS, SNRS
from .perrun import (
    discrepancy_lambda2,
    irmxne,
    lcmv,
    measure_run,
    minimum_norm_amplitude,
    run_data,
)
from .sets import PEAK_MOMENT
from .tasks import design_waves, geometry, head, write_table

__all__ = ["data_of", "irmxne_runs", "lcmv_runs", "run_lcmv", "run_irmxne", "run_tuned",
           "tuned_runs"]  # fmt: skip

_D1 = DESIGNS[0]


def lcmv_runs(study, sizes):
    """LCMV's runs: lone sources (scored, 20 and 30 dB) and detection at 20 dB, D1."""
    runs = []
    scored = study.sets["scored"]
    n_positions = len(scored.thalamic) // 3
    for snr in (20.0, 30.0):
        runs += [("scored", "thalamic", 3 * j, snr, 1.0) for j in range(n_positions)]
        runs += [("scored", "cortical", 3 * j, snr, 1.0) for j in range(n_positions)]
    for name in ("choice", "scored"):
        configs = range(0, study.sets[name].n_configurations, sizes.lcmv_step)
        runs += [(name, "noise", k, 20.0, 0.0) for k in range(sizes.lcmv_noise)]
        runs += [
            (name, "cortical-null", int(study.sets[name].cortical_of(i)), 20.0, 0.0)
            for i in configs
        ]
        if name == "scored":
            runs += [(name, "config", i, 20.0, 1.0) for i in configs]
    return runs


def irmxne_runs(study, sizes, alphas=None):
    """irMxNE's runs: the alpha choice (``alphas`` None) or the scored configurations."""
    if alphas is None:
        configs = range(0, 3 * sizes.irmxne_choice, 3)
        return [("choice", "config", i, snr, 1.0) for snr in SNRS for i in configs]
    configs = range(0, 3 * sizes.irmxne_scored, 3)
    runs = [("scored", "config", i, snr, 1.0) for snr in SNRS for i in configs]
    partner = study.sets["scored"].cortical_of
    return runs + [
        ("scored", "cortical-null", int(partner(i)), snr, 0.0) for snr in SNRS for i in configs
    ]


def tuned_runs(study, sizes):
    """The configurations whose priors and lambda2 are chosen from each data set."""
    configs = range(0, 3 * sizes.tuned, 3)
    return [("scored", "config", i, snr, 1.0) for snr in sizes.tuned_snrs for i in configs]


def data_of(study, run, pool_size):
    """The data set of a run (volts), its noise level and its sources' exact points."""
    set_name, kind, index, snr, moment = run
    study_set = study.sets[set_name]
    waves, _, n_times = design_waves(_D1)
    n_thalamic = len(study_set.thalamic)
    if kind == "noise":
        draw, parts, points = index, [], (None, None)
    elif kind in ("thalamic", "cortical"):
        sources = study_set.thalamic if kind == "thalamic" else study_set.cortical
        gain = sources.gain[:, index]
        draw = index + (n_thalamic if kind == "cortical" else 0)
        parts = [(gain, PEAK_MOMENT * waves[kind])]
        points = (
            (sources.points[index], None) if kind == "thalamic" else (None, sources.points[index])
        )
    elif kind == "cortical-null":
        draw = index
        parts = [(study_set.cortical.gain[:, index], PEAK_MOMENT * waves["cortical"])]
        points = (None, study_set.cortical.points[index])
    else:
        partner = int(study_set.cortical_of(index))
        draw = partner
        parts = [
            (study_set.thalamic.gain[:, index], moment * PEAK_MOMENT * waves["thalamic"]),
            (study_set.cortical.gain[:, partner], PEAK_MOMENT * waves["cortical"]),
        ]
        points = (study_set.thalamic.points[index], study_set.cortical.points[partner])
    noise = _pool(study, set_name, pool_size, n_times)[draw % pool_size]
    if kind in ("thalamic", "cortical"):
        sigma = np.abs(np.outer(*parts[0])).max() * 10.0 ** (-snr / 20.0)
    else:
        sigma = study.sigma(snr)
    return run_data(head(study), parts, sigma, noise), points


@functools.lru_cache(maxsize=4)
def _pool(study, set_name, pool_size, n_times):
    """A set's D1 noise pool, drawn once per process."""
    return study.pool(set_name, 0, pool_size, n_times)


def _row(run, measured, **extra):
    set_name, kind, index, snr, moment = run
    return dict(set=set_name, kind=kind, index=index, snr_db=snr, moment=moment, **measured,
                **extra)  # fmt: skip


def run_lcmv(study, runs, sizes, path):
    """LCMV on each run; one results file."""
    geo = geometry(study)
    waves, samples, _ = design_waves(_D1)
    rows = []
    for run in runs:
        sim, points = data_of(study, run, sizes.pool)
        amplitude = lcmv(head(study), sim)
        rows.append(_row(run, measure_run(amplitude, geo, points, samples, waves["thalamic"])))
    write_table(path, pd.DataFrame(rows))


def run_irmxne(study, runs, alphas, sizes, path):
    """irMxNE on each run, at every alpha of ``alphas`` (SNR -> list of % of alpha_max)."""
    geo = geometry(study)
    waves, samples, _ = design_waves(_D1)
    rows = []
    for run in runs:
        sim, points = data_of(study, run, sizes.pool)
        for alpha in alphas[run[3]]:
            amplitude, ratio = irmxne(head(study), sim, alpha)
            measured = measure_run(amplitude, geo, points, samples, waves["thalamic"])
            rows.append(_row(run, measured, alpha=alpha, residual_ratio=ratio))
    write_table(path, pd.DataFrame(rows))


def _tuned_skf(study, sim, settings, n_times):
    """(amplitude, columns) of each setting at the priors each criterion chooses."""
    import skf_ref

    from .skf import Prepared

    L = head(study).leadfield
    for criterion in ("likelihood", "discrepancy"):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            tuned = skf_ref.tune(L, sim.Y, noise_std=sim.sigma, criterion=criterion)
        prepared = Prepared(L, None, n_times, theta0=tuned.theta0, q=tuned.q)
        for label, setting in settings.items():
            z = prepared.z(sim.Y / sim.sigma, setting)
            amplitude = np.sqrt(np.square(z.reshape(-1, 3, n_times)).sum(axis=1))
            yield amplitude, dict(
                method=label, criterion=criterion, ep_snr_db=tuned.ep_snr_db,
                pm_snr_db=tuned.pm_snr_db, lambda2=np.nan,
                bound=",".join(sorted(tuned.at_bound)), warnings=len(caught),
            )  # fmt: skip


def _tuned_mne(study, sim, cache):
    """(amplitude, columns) of MNE's methods at the discrepancy principle's lambda2."""
    from .design import STATIC_METHODS
    from .linear import mne_kernel

    lambda2, bound = discrepancy_lambda2(head(study).leadfield, sim.Y, sim.sigma)
    for method in STATIC_METHODS:
        kernel = mne_kernel(head(study), method, lambda2, cache)
        amplitude = minimum_norm_amplitude(kernel, sim.Y, sim.sigma)
        yield amplitude, dict(
            method=method, criterion="discrepancy", ep_snr_db=np.nan, pm_snr_db=np.nan,
            lambda2=lambda2, bound=bound or "", warnings=0,
        )  # fmt: skip


def run_tuned(study, runs, settings, sizes, path, cache=None):
    """Each run with priors (SKF) and lambda2 (MNE's methods) chosen from its data alone.

    ``settings``: label -> SKFSetting whose exponent, smoother and standardization the tuned
    priors are applied with; ``cache``: where MNE's kernels are kept
    (:func:`.linear.mne_kernel`).
    """
    geo = geometry(study)
    waves, samples, n_times = design_waves(_D1)
    rows = []
    for run in runs:
        sim, points = data_of(study, run, sizes.pool)
        for part in (_tuned_skf(study, sim, settings, n_times), _tuned_mne(study, sim, cache)):
            for amplitude, extra in part:
                measured = measure_run(amplitude, geo, points, samples, waves["thalamic"])
                rows.append(_row(run, measured, **extra))
    write_table(path, pd.DataFrame(rows))
