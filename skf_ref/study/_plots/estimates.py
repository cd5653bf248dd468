"""A reconstruction of one's own data, and the priors' likelihood landscape."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, cast

import numpy as np
from numpy.typing import ArrayLike

from ..._utils.checks import InputError, check_array, check_int
from .._regions import DYNAMIC_RANGE_DB, check_amplitude
from .style import AXIS_LABELS, VIEWS, figure, finish

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

    from ...method._tuning import TuneResult

__all__ = ["plot_estimate", "plot_landscape"]


def plot_estimate(
    amplitude: ArrayLike,
    times: ArrayLike | None,
    positions: ArrayLike | None = None,
    n_strongest: int = 5,
    title: str | None = None,
    path: str | os.PathLike | None = None,
) -> Figure:
    """An estimate without ground truth: the strongest positions over time, and projections.

    Left: the time courses of the ``n_strongest`` positions (largest maximum over time).
    Right, when positions are given: sagittal, coronal and axial maximum-intensity
    projections at the time of the global maximum, each position a dot coloured in dB re.
    that maximum (6 dB range), drawn weakest first so that a dot shows the largest value
    along the projected axis; any source space works, regular grid or not.

    Parameters
    ----------
    amplitude : ndarray, shape (n_positions, n_times)
        Per-position amplitude (e.g. ``Reconstruction.amplitude(3)`` or ``stc.data``).
    times : ndarray, shape (n_times,), or None
        Seconds; None: the samples are numbered from 0 (the axis says "sample").
    positions : ndarray, shape (n_positions, 3), optional
        Metres, head coordinates.
    n_strongest : int
        How many of the strongest positions to draw.
    title : str, optional
        The figure's title; None: none.
    path : str or path-like, optional
        Where to save the figure (its format from the suffix); None: not saved.

    Returns
    -------
    fig : matplotlib.figure.Figure
        The figure (saved to ``path`` if given).
    """

    amplitude = check_amplitude(amplitude, "n_positions")
    if times is None:  # no times known: samples, never a made-up time axis
        times_ms, axis = np.arange(amplitude.shape[1], dtype=float), "sample"
    else:
        times_ms, axis = np.asarray(times, dtype=float) * 1e3, "time (ms)"
    if amplitude.shape[1] != times_ms.size:
        raise InputError(
            f"times must have shape ({amplitude.shape[1]},) like amplitude's columns, got "
            f"{times_ms.shape}"
        )
    count = check_int("n_strongest", n_strongest, minimum=1)
    fig = figure(12.0 if positions is not None else 5.0, 3.4)
    axes = fig.subplots(1, 4 if positions is not None else 1, squeeze=False)[0]
    strongest = np.argsort(amplitude.max(axis=1))[::-1][:count]
    for index in strongest:
        axes[0].plot(times_ms, amplitude[index], lw=1.4, label=f"position {index}")
    axes[0].set_xlabel(axis)
    axes[0].set_ylabel("amplitude")
    axes[0].legend(fontsize="x-small")
    axes[0].set_title(f"{len(strongest)} strongest positions")
    if positions is not None:
        points = check_array("positions", positions, (len(amplitude), 3)) * 1e3
        k = int(np.argmax(amplitude.max(axis=0)))
        with np.errstate(divide="ignore"):
            db = 20 * np.log10(amplitude[:, k] / amplitude[:, k].max())
        order = np.argsort(db)
        for ax, (name, _, horiz, vert) in zip(axes[1:], VIEWS, strict=True):
            dots = ax.scatter(
                points[order, horiz],
                points[order, vert],
                c=db[order],
                cmap="Blues",
                vmin=-DYNAMIC_RANGE_DB,
                vmax=0.0,
                s=12,
            )
            ax.set_aspect("equal")
            at = f"sample {k}" if times is None else f"{times_ms[k]:g} ms"
            ax.set_title(f"{name} MIP, {at}")
            ax.set_xlabel(AXIS_LABELS[horiz])
            ax.set_ylabel(AXIS_LABELS[vert])
        fig.colorbar(dots, ax=axes[1:], label="dB re. maximum at that time", shrink=0.8)
    if title is not None:
        fig.suptitle(title)
    return finish(fig, path)


# log-likelihood units shown below the chosen priors: a difference of more than a few units
# is already decisive, and the far corners of a grid lie thousands below
_LANDSCAPE_RANGE = 100.0


def plot_landscape(
    result: TuneResult, path: str | os.PathLike | None = None, title: str | None = None
) -> Figure:
    """The marginal likelihood over (EP-SNR, PM-SNR), with the chosen priors marked.

    For the stationary AR(1) prior the horizontal axis is the time constant (ms, a
    logarithmic axis) in place of the EP-SNR.

    Parameters
    ----------
    result : skf_ref.method.TuneResult
        Its ``landscape`` (the coarse grid) and chosen ``pm_snr_db``, ``ep_snr_db`` (or
        ``time_constant_ms``).
    path : str or path-like, optional
        Where to save the figure (its format from the suffix); None: not saved.
    title : str, optional
        The figure's title; None: none.

    Returns
    -------
    fig : matplotlib.figure.Figure
        A heat map of ``log p(Y) - max log p(Y)`` over the grid (a curve when one SNR was
        fixed) and a star at the chosen point.
    """
    landscape = cast("pd.DataFrame", result.landscape)
    if result.time_constant_ms is None:
        column, label = "ep_snr_db", "EP-SNR (dB)"
        chosen = cast(float, result.ep_snr_db)
        about = f"EP-SNR {chosen:.1f} dB"
    else:
        column, label = "time_constant_ms", "time constant (ms)"
        chosen = result.time_constant_ms
        about = f"time constant {chosen:.3g} ms"
    grid = landscape.pivot(index="pm_snr_db", columns=column, values="log_likelihood")
    relative = grid.to_numpy() - result.log_likelihood
    fig = figure(5.2, 4.0)
    ax = fig.add_subplot()
    if 1 in relative.shape:  # one SNR was fixed: a curve
        fixed_pm = relative.shape[0] == 1
        axis = grid.columns if fixed_pm else grid.index
        ax.plot(axis, relative.ravel(), "o-", color="tab:blue")
        ax.axvline(chosen if fixed_pm else result.pm_snr_db, color="tab:red")
        ax.set_xlabel(label if fixed_pm else "PM-SNR (dB)")
        if fixed_pm and column == "time_constant_ms":
            ax.set_xscale("log")
        ax.set_ylabel("log-likelihood re. the chosen priors")
    else:
        image = ax.pcolormesh(
            grid.columns,
            grid.index,
            relative,
            shading="nearest",
            cmap="viridis",
            vmin=-_LANDSCAPE_RANGE,
            vmax=0.0,
        )
        ax.plot(chosen, result.pm_snr_db, "*", ms=14, mfc="tab:red", mec="white")
        ax.set_xlabel(label)
        if column == "time_constant_ms":
            ax.set_xscale("log")
        ax.set_ylabel("PM-SNR (dB)")
        fig.colorbar(image, ax=ax, extend="min", label="log-likelihood re. the chosen priors")
    ax.set_title(title or f"chosen: {about}, PM-SNR {result.pm_snr_db:.1f} dB")
    return finish(fig, path)
