"""Calibrated detection of thalamic activity: a threshold set on runs without a thalamic source.

"Within 6 dB of the maximum" says where an estimate is largest, not whether a deep source is
there: a cortical source alone can fill the thalamus of an estimate. A calibrated detector
instead compares the thalamus' *absolute* level with what runs without a thalamic source
produce (with the same head, method and noise level):

- the statistic, :func:`thalamic_level`: the maximum amplitude over the thalamus' positions
  at the thalamic source's peak time;
- the threshold, ``null_threshold``: the largest of the 95th percentiles of the
  statistic over each kind of null run (noise only; a single cortical source at a random
  position and orientation), each taken as an order statistic, so that at most 5 % of every
  kind of null run exceeds it;
- a run detects a thalamic source when its statistic exceeds the threshold;
- ``null_levels`` simulates the null runs for a head, a noise level and any methods;
  :func:`calibrate` turns them into each method's threshold for one simulated data set.

The threshold holds only for the head, method, setting and noise level it was calibrated
with: amplitudes are in each method's own units.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._utils.checks import InputError, check_real

if TYPE_CHECKING:
    from ._head import HeadModel
    from ._scenario import Simulation

#: A method: data (n_channels, n_times) in volts -> position amplitudes (n_positions, n_times).
Method = Callable[[np.ndarray], np.ndarray]

__all__ = [
    "FALSE_DETECTION_RATE",
    "calibrate",
    "null_levels",
    "null_threshold",
    "thalamic_level",
]

#: The share of null runs a threshold lets through (at most), per kind of null.
FALSE_DETECTION_RATE = 0.05


def null_threshold(*nulls: ArrayLike, rate: float = FALSE_DETECTION_RATE) -> float:
    """The largest of the nulls' ``1 - rate`` quantiles (order statistics, never interpolated).

    Parameters
    ----------
    *nulls : array_like, shape (n_k,)
        The statistic over each kind of null run (at least one run each).
    rate : float
        The false-detection rate allowed in every kind, in (0, 1).

    Returns
    -------
    float
        At most ``rate`` of each kind's runs lie strictly above it.

    Examples
    --------
    >>> null_threshold(np.arange(1.0, 101.0), np.arange(20.0))
    96.0
    """
    rate = check_real("rate", rate, positive=True, maximum=1.0)
    if not nulls:
        raise InputError("null_threshold needs at least one set of null runs")
    levels = []
    for k, values in enumerate(nulls):
        values = np.asarray(values, dtype=float).ravel()
        if not values.size or not np.isfinite(values).all():
            raise InputError(f"nulls[{k}] must hold finite values, at least one")
        levels.append(np.quantile(values, 1.0 - rate, method="higher"))
    return float(max(levels))


def thalamic_level(amplitude: ArrayLike, thalamus: ArrayLike) -> Any:
    """The maximum amplitude over the thalamus' positions (the detection statistic).

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions,) or (n_positions, n_runs)
        Position amplitudes at the thalamic peak time.
    thalamus : ndarray of bool, shape (n_positions,)
        The thalamus' positions, at least one.

    Returns
    -------
    float or ndarray, shape (n_runs,)
        The largest amplitude over the thalamus (of each run).

    Examples
    --------
    >>> thalamic_level(np.array([[1.0, 5.0], [2.0, 0.5]]), np.array([False, True]))
    array([2. , 0.5])
    """
    amplitude = np.asarray(amplitude, dtype=float)
    thalamus = np.asarray(thalamus, dtype=bool)
    if thalamus.shape != amplitude.shape[:1] or not thalamus.any():
        raise InputError(
            f"thalamus must be a boolean array of shape ({amplitude.shape[0]},) with a True entry"
        )
    return amplitude[thalamus].max(axis=0)


def null_levels(
    head: HeadModel,
    methods: Mapping[str, Method],
    sigma: float,
    cortical_wave: ArrayLike,
    peak_index: int,
    *,
    n_noise: int = 100,
    n_cortical: int = 100,
    seed: int = 0,
) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The statistic over null runs simulated for a head, noise level and set of methods.

    Null runs: ``n_noise`` data sets of white noise alone, and ``n_cortical`` with one
    cortical source at a random grid cell and orientation (:func:`~.sources.draw_sources`,
    peak moment 10 nAm on ``cortical_wave``) plus noise; every method sees the same data.

    Parameters
    ----------
    head : HeadModel
        A cortex + thalamus head.
    methods : dict
        Name -> callable taking data (n_channels, n_times) in volts and returning the
        position amplitude (n_positions, n_times).
    sigma : float
        The white noise's standard deviation (V).
    cortical_wave : ndarray, shape (n_times,)
        The cortical source's moment over time (A m).
    peak_index : int
        The sample the statistic is read at (the thalamic source's peak).
    n_noise, n_cortical : int
        Null runs of each kind.
    seed : int
        Seed of the positions, orientations and noise.

    Returns
    -------
    dict
        Name -> (levels over noise-only runs, levels over cortical runs).
    """
    from ._sources import draw_sources, position_structures

    rng = np.random.default_rng(seed)
    structures = position_structures(head)
    thalamus = structures == "thalamus"
    cortex = np.flatnonzero(structures == "cortex")
    positions = rng.choice(cortex, size=n_cortical, replace=False)
    sources = draw_sources(head, positions, seed=int(rng.integers(2**31)), n_orientations=1)
    wave = np.asarray(cortical_wave, dtype=float)
    levels: dict[str, tuple[list[float], list[float]]] = {name: ([], []) for name in methods}
    for k in range(n_noise + n_cortical):
        Y = sigma * rng.standard_normal((head.n_channels, len(wave)))
        if k >= n_noise:
            Y = Y + np.outer(sources.gain[:, k - n_noise], wave)
        for name, method in methods.items():
            level = thalamic_level(method(Y)[:, peak_index], thalamus)
            levels[name][int(k >= n_noise)].append(float(level))
    return {
        name: (np.array(noise), np.array(cortical)) for name, (noise, cortical) in levels.items()
    }


def calibrate(
    head: HeadModel,
    sim: Simulation,
    methods: Mapping[str, Method],
    *,
    n_runs: int = 50,
    seed: int = 0,
) -> dict[str, float]:
    """Each method's threshold on the thalamus' level, for the head and noise of ``sim``.

    The null runs (``null_levels``, ``n_runs`` of each kind) have the noise level of
    ``sim`` and its superficial source's waveform, read at the deep source's peak sample.

    Parameters
    ----------
    head : HeadModel
        A cortex + thalamus head.
    sim : Simulation
        The P20/N20 data set the thresholds are for (:func:`~skf_ref.study.simulate`).
    methods : dict
        Name -> callable taking data (n_channels, n_times) in volts and returning the
        position amplitude (n_positions, n_times).
    n_runs : int
        Null runs of each kind: with 5 %, ``n_runs >= 20`` puts the threshold below the
        largest null level.
    seed : int
        Seed of the null runs (positions, orientations, noise).

    Returns
    -------
    dict
        Name -> threshold (``null_threshold``): a run detects when its level exceeds it.
    """
    from .._utils.checks import check_int

    n_runs = check_int("n_runs", n_runs, minimum=1)
    peak = int(sim.truth.peak_indices[0])
    levels = null_levels(
        head, methods, sim.sigma, sim.truth.waveforms[1], peak, n_noise=n_runs,
        n_cortical=n_runs, seed=seed,
    )  # fmt: skip
    return {name: null_threshold(*pair) for name, pair in levels.items()}
