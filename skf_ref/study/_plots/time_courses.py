"""Region time courses: one panel, a grid of prior parameters, a row of exponents."""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..._utils.checks import InputError, check_instance
from .._regions import as_amplitude, region_time_course
from .style import COLOURS, LABELS, figure, finish

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["plot_exponent_comparison", "plot_prior_grid", "plot_time_courses"]


def _draw_time_courses(ax: Axes, reconstruction: Any, head: Any, truth: Any) -> None:
    """Region maxima (solid) and true waveform magnitudes (dashed), each pair normalized."""
    positions = np.asarray(head.positions, dtype=float)
    amplitude = as_amplitude(reconstruction, positions.shape[0])
    times_ms = np.asarray(truth.times, dtype=float) * 1e3
    if amplitude.shape[1] != times_ms.size:
        raise InputError(
            f"reconstruction amplitude must have shape (n_positions, n_times) = "
            f"({positions.shape[0]}, {times_ms.size}), got shape {amplitude.shape}"
        )
    courses = [region_time_course(amplitude, positions, pos) for pos in truth.positions]
    waves = np.abs(np.asarray(truth.waveforms, dtype=float))
    scale = max(course.max() for course in courses) or 1.0
    wave_scale = waves.max() or 1.0
    for course, wave, colour, label in zip(courses, waves, COLOURS, LABELS, strict=True):
        ax.plot(times_ms, course / scale, color=colour, lw=1.8, label=f"{label} (region max)")
        ax.plot(
            times_ms, wave / wave_scale, color=colour, lw=1.2, ls="--", label=f"{label} (true)"
        )
    ax.set_xlim(times_ms[0], times_ms[-1])
    ax.set_ylim(-0.03, 1.08)
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("normalized amplitude")


def plot_time_courses(
    reconstruction: Any,
    head: Any,
    truth: Any,
    ax: Axes | None = None,
    title: str | None = None,
    path: str | os.PathLike | None = None,
) -> Figure:
    """Plot each source region's maximum amplitude over time against the true waveforms.

    Solid: the maximum of the amplitude over the region (positions within 15 mm) of the
    deep (green) and superficial (red) source; dashed: the true waveform magnitudes. The
    two reconstructed curves share one scale (their joint maximum is 1), as do the true
    ones, so the relative size of the deep and superficial activity stays visible.

    Parameters
    ----------
    reconstruction : object with ``amplitude(n_components)``, or ndarray
        Amplitude shape (n_positions, n_times).
    head : HeadModel
        Its ``positions`` (n_positions, 3), metres.
    truth : Truth
        The exact sources (``Truth``).
    ax : matplotlib.axes.Axes, optional
        Axes to draw in; a new figure if None.
    title : str, optional
        The figure's title; None: none.
    path : str or path-like, optional
        Where to save the figure (format from the extension).

    Returns
    -------
    fig : matplotlib.figure.Figure
        The figure (saved to ``path`` if given).
    """
    fig = figure(5.0, 3.2) if ax is None else cast("Figure", ax.figure)
    ax = fig.add_subplot() if ax is None else ax
    _draw_time_courses(ax, reconstruction, head, truth)
    ax.set_ylim(top=1.4)  # room for the legend above the curves
    ax.legend(fontsize="small", loc="upper center", ncols=2, framealpha=0.9)
    if title is not None:
        ax.set_title(title, fontsize="medium")  # a two-line setting fits the 5-inch figure
    return finish(fig, path)


def _panel_grid(
    panels: Mapping[tuple[int, int], tuple[Any, str]],
    head: Any,
    truth: Any,
    nrows: int,
    ncols: int,
    title: str | None,
    path: str | os.PathLike | None,
) -> Figure:
    """Time-course panels ``{(row, col): (reconstruction, title)}`` with one shared legend."""
    fig = figure(3.3 * ncols, 2.5 * nrows + 0.6)
    axes = fig.subplots(nrows, ncols, sharex=True, sharey=True, squeeze=False)
    for (row, col), (reconstruction, panel_title) in panels.items():
        ax = axes[row, col]
        _draw_time_courses(ax, reconstruction, head, truth)
        ax.set_title(panel_title)
        ax.label_outer()
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=4, fontsize="small")
    if title is not None:
        fig.suptitle(title)
    return finish(fig, path)


def plot_prior_grid(
    reconstructions: Mapping[tuple[float, float], Any],
    head: Any,
    truth: Any,
    title: str | None = None,
    path: str | os.PathLike | None = None,
) -> Figure:
    """Time courses over a grid of prior parameters (the paper's 2 x 2 EP/PM figures).

    Parameters
    ----------
    reconstructions : dict
        ``{(ep_snr_db, pm_snr_db): reconstruction}``, a full grid, e.g. over {0, 20}^2.
        Columns: EP-SNR ascending; rows: PM-SNR ascending. Panel titles "EP 0, PM 20".
    head : HeadModel
        Its ``positions`` (n_positions, 3), metres.
    truth : Truth
        The exact sources (``Truth``).
    title : str, optional
        Figure title (e.g. the noise level and smoothing).
    path : str or path-like, optional
        Where to save the figure (its format from the suffix); None: not saved.

    Returns
    -------
    fig : matplotlib.figure.Figure
        The figure (saved to ``path`` if given).
    """
    check_instance("reconstructions", reconstructions, dict, "a dict {(ep, pm): reconstruction}")
    if not reconstructions:
        raise InputError("reconstructions must be a non-empty dict {(ep, pm): reconstruction}")
    if not all(isinstance(key, tuple) and len(key) == 2 for key in reconstructions):
        raise InputError(
            f"reconstructions keys must be (ep, pm) pairs, got {list(reconstructions)}"
        )
    eps = sorted({ep for ep, _ in reconstructions})
    pms = sorted({pm for _, pm in reconstructions})
    missing = [(ep, pm) for pm in pms for ep in eps if (ep, pm) not in reconstructions]
    if missing:
        raise InputError(f"reconstructions must fill the EP x PM grid; missing {missing}")
    panels = {
        (row, col): (reconstructions[ep, pm], f"EP {ep:g}, PM {pm:g}")
        for row, pm in enumerate(pms)
        for col, ep in enumerate(eps)
    }
    return _panel_grid(panels, head, truth, len(pms), len(eps), title, path)


def plot_exponent_comparison(
    reconstructions: Mapping[float, Any],
    head: Any,
    truth: Any,
    title: str | None = None,
    path: str | os.PathLike | None = None,
) -> Figure:
    """Time courses side by side, one panel per standardization exponent.

    Parameters
    ----------
    reconstructions : dict
        ``{exponent: reconstruction}``; panels in ascending exponent order.
    head : HeadModel
        Its ``positions`` (n_positions, 3), metres.
    truth : Truth
        The exact sources (``Truth``).
    title : str, optional
        The figure's title; None: none.
    path : str or path-like, optional
        Where to save the figure (its format from the suffix); None: not saved.

    Returns
    -------
    fig : matplotlib.figure.Figure
        The figure (saved to ``path`` if given).
    """
    check_instance("reconstructions", reconstructions, dict, "a dict {exponent: reconstruction}")
    if not reconstructions:
        raise InputError("reconstructions must be a non-empty dict {exponent: reconstruction}")
    panels = {
        (0, col): (reconstructions[alpha], f"exponent {alpha:g}")
        for col, alpha in enumerate(sorted(reconstructions))
    }
    return _panel_grid(panels, head, truth, 1, len(panels), title, path)
