"""The reconstructions behind the figures, checked against the sweep, and their diagnostics.

The figures show single runs and seed averages; :class:`CheckedRuns` recomputes them the
way :func:`skf_ref.study.sweep.run_group` does and checks each against its sweep row, so a figure
never shows a run the tables do not summarize. :func:`diagnostics` describes the same runs
post hoc (no decision rule uses it).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np

from .settings import EXPONENTS, NOISE_LEVELS, SMOOTHERS, TUNED_PRIOR
from .stats import _mean_se, _select, quartiles

__all__ = ["CheckedRuns", "Diagnostic", "diagnostics", "electrode_floor"]


class CheckedRuns:
    """Reconstructions for the figures, one prepared spectral model per noise level and priors.

    Mirrors :func:`skf_ref.study.sweep.run_group`, and checks every run against its sweep row
    (same peak localization errors), so the figures show the runs the tables summarize.

    Parameters
    ----------
    head : skf_ref.study.scenario.HeadModel
    table : pandas.DataFrame
        The paper-grid sweep rows every run is checked against.
    """

    def __init__(self, head, table):
        from skf_ref.study import scenario as simulate

        self.head, self.table = head, table
        self.scenario = simulate.p20n20_scenario()
        self.models, self.sims, self.truth = {}, {}, None

    def _model(self, snr, ep, pm, sim):
        from skf_ref.method import SpectralModel, StateSpaceModel, priors_from_snr

        if (snr, ep, pm) not in self.models:
            L, T = self.head.leadfield, sim.Y.shape[1]
            theta0, q = priors_from_snr(L, sim.sigma, pm, ep, T)
            model = StateSpaceModel.create(L, noise_std=sim.sigma, theta0=theta0, q=q)
            self.models[snr, ep, pm] = SpectralModel(model, T)
        return self.models[snr, ep, pm]

    def _simulation(self, snr, seed):
        from skf_ref.study import scenario as simulate

        if (snr, seed) not in self.sims:
            self.sims[snr, seed] = simulate.simulate(self.head, self.scenario, snr, seed)
            self.truth = self.sims[snr, seed].truth
        return self.sims[snr, seed]

    def _check(self, rec, snr, ep, pm, exponent, smoother, seed):
        """Raise if a run's peak errors differ from its sweep row (stale results)."""
        from skf_ref.study import metrics

        summary = metrics.summarize(rec, self.head, self.truth)
        row = _select(self.table, snr, ep, pm, exponent, smoother)
        row = row[row["seed"] == seed]
        for key in ("deep_error_mm", "superficial_error_mm"):
            if row.empty or not np.isclose(row[key].iloc[0], summary[key], atol=1e-6):
                raise RuntimeError(
                    f"the figure run (snr {snr:g}, EP {ep:g}, PM {pm:g}, exponent "
                    f"{exponent:g}, {smoother}, seed {seed}) does not match its sweep row: "
                    "stale results; rerun with --fresh"
                )

    def amplitudes(self, snr, ep, pm, exponent, smoother, seeds):
        """Position amplitudes of the runs at one setting, one per seed.

        Parameters
        ----------
        snr, ep, pm, exponent : float
        smoother : str
            Label as in the sweep table (``"none"`` for no smoothing).
        seeds : iterable of int

        Returns
        -------
        list of ndarray, shape (n_positions, n_times)

        Raises
        ------
        RuntimeError
            If a run's peak errors differ from its sweep row (stale results files).
        """
        out = []
        for seed in seeds:
            sim = self._simulation(snr, seed)
            rec = self._model(snr, ep, pm, sim).apply(
                sim.Y, exponent, None if smoother == "none" else smoother
            )
            self._check(rec, snr, ep, pm, exponent, smoother, seed)
            out.append(rec.amplitude(3))
        return out


def electrode_floor(head):
    """Height (m, head coordinates) of the lowest electrode.

    Parameters
    ----------
    head : skf_ref.study.scenario.HeadModel

    Returns
    -------
    float
    """
    return float(min(ch["loc"][2] for ch in head.info["chs"]))


@dataclass(frozen=True)
class Diagnostic:
    """Post-hoc descriptions of one setting's runs (not used by any decision rule).

    Attributes
    ----------
    low : tuple of int
        Seeds whose global maximum lies below the lowest electrode, at the deep (1.5 ms)
        and at the superficial (2.5 ms) peak.
    n : int
        Seeds.
    balance : tuple of float
        Mean and SE over seeds of the deep-to-superficial peak balance (dB):
        ``20 log10`` of the deep region's maximum at 1.5 ms over the superficial region's
        maximum at 2.5 ms, what the paper's jointly normalized time courses show.
    balance_quartiles : tuple of float
        Median, first and third quartiles over seeds of the same balance.
    """

    low: tuple
    n: int
    balance: tuple
    balance_quartiles: tuple


def _diagnose(rows, floor):
    """A setting's :class:`Diagnostic` from its sweep rows (heights and region maxima)."""
    low = tuple(
        int((rows[f"max_height_at_{peak}_peak"] < floor).sum()) for peak in ("deep", "superficial")
    )
    balance = 20.0 * np.log10(
        rows["deep_max_at_deep_peak"] / rows["superficial_max_at_superficial_peak"]
    )
    return Diagnostic(
        low=low,
        n=len(rows),
        balance=_mean_se(balance)[:2],
        balance_quartiles=quartiles(balance)[:3],
    )


def diagnostics(runs, seeds):
    """Post-hoc diagnostics of every exponent and smoother at EP 20, PM 0.

    Added after the verdicts were seen, to explain them; no rule uses them. Where the
    global maximum lies (the volume grid fills the whole inner sphere, also below the
    electrode cap, where the lead field is weak and an exponent above 0.5 amplifies the
    estimate most), and the deep-to-superficial peak balance of the region maxima. Read
    from the sweep rows (the height of each run's maximum and its region maxima at the two
    peaks), so nothing is recomputed.

    Parameters
    ----------
    runs : CheckedRuns
        Its head and table.
    seeds : int

    Returns
    -------
    dict
        (snr_db, exponent, smoother) -> :class:`Diagnostic`.
    """
    floor = electrode_floor(runs.head)
    out = {}
    for snr, exponent, smoother in product(NOISE_LEVELS, EXPONENTS, SMOOTHERS):
        rows = _select(runs.table, snr, *TUNED_PRIOR, exponent, smoother)
        out[snr, exponent, smoother] = _diagnose(rows[rows["seed"] < seeds], floor)
    return out
