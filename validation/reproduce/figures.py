"""The report's figures: prior grids, the exponent comparison, seed averages, fine maps.

Matplotlib and :mod:`skf_ref.study.plots` are imported inside the functions, so importing this
module (or the rules) does not need a plotting backend.
"""

from __future__ import annotations

import numpy as np

from skf_ref._utils.atomic_files import atomic_path

from .settings import (
    CORNERS,
    EXPONENTS,
    NOISE_LEVELS,
    RANKED_EXPONENTS,
    SMOOTHED,
    STAGES,
    TUNED_PRIOR,
    TUNING,
)
from .stats import _best, _cell, _fine_means, _select, _setting_label, corner_stats, quartiles

__all__ = [
    "FIGURE_GROUPS",
    "make_figures",
    "plot_fine_map",
    "plot_seed_points",
    "plot_source_placement",
    "save_source_placement",
]

#: Seed of the horizontal jitter of the per-seed points (fixed: the PNGs regenerate exactly).
JITTER_SEED = 0
#: Half-width of that jitter and of the median's bar, in units of the x axis.
JITTER, MEDIAN_HALF_WIDTH = 0.05, 0.09


def _save(fig, path):
    """Save a PNG without a software/date stamp, so that reruns give identical bytes."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, metadata={"Software": None})


def _prior_grid_figures(out, runs):
    from skf_ref.study import plots

    names = {}
    for snr in NOISE_LEVELS:
        for tag, (exponent, smoother) in STAGES:
            amps = {
                (ep, pm): runs.amplitudes(snr, ep, pm, exponent, smoother, [0])[0]
                for ep, pm in CORNERS
            }
            fig = plots.plot_prior_grid(
                amps,
                runs.head,
                runs.truth,
                title=f"{snr:g} dB, {_setting_label(exponent, smoother)} (seed 0)",
            )
            names[snr, tag] = f"prior_grid_{snr:g}dB_{tag}.png"
            _save(fig, out / names[snr, tag])
    return names


def _exponent_figure(out, runs):
    from skf_ref.study import plots

    ep, pm = TUNED_PRIOR
    amps = {e: runs.amplitudes(30.0, ep, pm, e, SMOOTHED[1], [0])[0] for e in RANKED_EXPONENTS}
    fig = plots.plot_exponent_comparison(
        amps,
        runs.head,
        runs.truth,
        title=f"30 dB, EP {ep:g}, PM {pm:g}, {SMOOTHED[1]} (seed 0)",
    )
    _save(fig, out / "exponents_30dB.png")
    return "exponents_30dB.png"


def plot_seed_points(ax, groups, rng):
    """Each seed as a jittered point and the median as a bar, one group per x position.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    groups : list of (float, array_like, str)
        (x position, the values over seeds, colour); NaN values are left out.
    rng : numpy.random.Generator
        Draws the horizontal jitter (seed it for reproducible figures).
    """
    for x, values, colour in groups:
        values = np.asarray(values, dtype=float)
        values = values[np.isfinite(values)]
        jitter = rng.uniform(-JITTER, JITTER, values.size)
        ax.plot(x + jitter, values, "o", ms=3.5, mfc=colour, mec="none", alpha=0.75)
        median = quartiles(values)[0]
        if np.isfinite(median):
            ax.plot([x - MEDIAN_HALF_WIDTH, x + MEDIAN_HALF_WIDTH], [median] * 2, "k-", lw=2)


#: Colour of each smoother in the per-seed figures.
_SMOOTHER_COLOURS = {"none": "0.45", SMOOTHED[1]: "tab:blue"}


def _exponent_seeds_figure(out, table, seeds):
    """F5's numbers at 30 dB, EP 20, PM 0: every exponent, with and without smoothing."""
    from matplotlib.figure import Figure

    panels = (
        ("score", "score (mm)"),
        ("deep_region_db", "deep region at 1.5 ms (dB re. max)"),
        ("deep_region_at_superficial_peak_db", "deep region at 2.5 ms (dB re. max)"),
    )
    rng = np.random.default_rng(JITTER_SEED)
    fig = Figure(figsize=(12.0, 3.6), layout="constrained")
    axes = fig.subplots(1, len(panels))
    for ax, (column, label) in zip(axes, panels, strict=True):
        groups = []
        for i, exponent in enumerate(EXPONENTS):
            for offset, smoother in zip((-0.2, 0.2), _SMOOTHER_COLOURS, strict=True):
                rows = _select(table, 30.0, *TUNED_PRIOR, exponent, smoother)
                groups.append((i + offset, rows[column], _SMOOTHER_COLOURS[smoother]))
        plot_seed_points(ax, groups, rng)
        ax.set_xticks(range(len(EXPONENTS)), [f"{e:g}" for e in EXPONENTS])
        ax.set_xlabel("standardization exponent")
        ax.set_ylabel(label)
    for smoother, colour in _SMOOTHER_COLOURS.items():
        name = "no smoothing" if smoother == "none" else smoother
        axes[0].plot([], [], "o", mfc=colour, mec="none", label=name)
    axes[0].plot([], [], "k-", lw=2, label="median")
    axes[0].legend(fontsize=8)
    fig.suptitle(
        f"30 dB, EP {TUNED_PRIOR[0]:g}, PM {TUNED_PRIOR[1]:g}: each of {seeds} seeds a point"
    )
    _save(fig, out / "exponents_30dB_seeds.png")
    return "exponents_30dB_seeds.png"


def _bounds_figure(out, table, controls, seeds):
    """F4's and F6's readings per seed: the echo and its two bounds, and smoothing's change."""
    from matplotlib.figure import Figure

    from .rules_v3 import seed_bounds

    readings = (
        ("raw", "v1 echo (both sources)", "0.45"),
        ("lower", "lower bound: deep excess", "tab:blue"),
        ("upper", "upper bound: deep-only echo", "tab:orange"),
    )
    rng = np.random.default_rng(JITTER_SEED)
    fig = Figure(figsize=(11.0, 3.8), layout="constrained")
    left, right = fig.subplots(1, 2)
    placed = list(zip((-0.25, 0.0, 0.25), readings, strict=True))
    exponent, smoother = SMOOTHED
    for i, snr in enumerate(NOISE_LEVELS):
        best = _best(corner_stats(table, snr))[0]
        tuning = seed_bounds(table, controls, snr, *best, *TUNING)
        smooth = seed_bounds(table, controls, snr, *TUNED_PRIOR, exponent, smoother)
        plain = seed_bounds(table, controls, snr, *TUNED_PRIOR, exponent, "none")
        plot_seed_points(left, [(i + dx, tuning[key], c) for dx, (key, _, c) in placed], rng)
        changes = [(i + dx, smooth[key] - plain[key], c) for dx, (key, _, c) in placed]
        plot_seed_points(right, changes, rng)
    for ax in (left, right):
        ax.axhline(0.0, color="k", lw=0.8, ls=":")
        ax.set_xticks(range(len(NOISE_LEVELS)), [f"{snr:g} dB" for snr in NOISE_LEVELS])
    left.set_ylabel("echo (ratio at 2.5 / 1.5 ms minus 0.25)")
    left.set_title(f"F4: no smoothing, exponent {TUNING[0]:g}, best tuning cell")
    right.set_ylabel("smoothed minus not smoothed")
    right.set_title(f"F6 (a): {smoother}, exponent {exponent:g}, EP 20, PM 0")
    for _, label, colour in readings:
        left.plot([], [], "o", mfc=colour, mec="none", label=label)
    left.plot([], [], "k-", lw=2, label="median")
    left.legend(fontsize=8)
    fig.suptitle(f"The echo and its bounds: each of {seeds} seeds a point")
    _save(fig, out / "echo_bounds.png")
    return "echo_bounds.png"


def _average_figures(out, runs, seeds):
    """Seed-averaged amplitude maps at 1.5 and 2.5 ms, 10 and 30 dB, without/with smoothing.

    Without smoothing: exponent 0.5 at the noise level's best tuning cell (F4's setting);
    smoothed: exponent 1.25, "rts-standardized", EP 20, PM 0 (F6's setting).
    """
    from skf_ref.study import plots

    names = {}
    for snr in (10.0, 30.0):
        best = _best(corner_stats(runs.table, snr))[0]
        for tag, prior, (exponent, smoother) in (
            ("nonsmoothed", best, TUNING),
            ("smoothed", TUNED_PRIOR, SMOOTHED),
        ):
            amps = runs.amplitudes(snr, *prior, exponent, smoother, range(seeds))
            fig = plots.plot_average_reconstruction(
                np.mean(amps, axis=0),
                runs.head,
                runs.truth,
                times_ms=(1.5, 2.5),
                title=f"{snr:g} dB, {_cell(prior)}, {_setting_label(exponent, smoother)}: "
                f"amplitude averaged over {seeds} seeds",
            )
            names[snr, tag] = (f"average_{snr:g}dB_{tag}.png", prior)
            _save(fig, out / names[snr, tag][0])
    return names


def plot_fine_map(means, values, title):
    """Heat maps of the mean score over EP x PM, one panel per noise level.

    Parameters
    ----------
    means : dict
        Noise level (dB) -> ndarray, shape (len(values), len(values)): rows PM, columns EP.
    values : list of float
        EP and PM values (dB).
    title : str

    Returns
    -------
    fig : matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    fig = Figure(figsize=(4.1 * len(means), 3.9), layout="constrained")
    axes = fig.subplots(1, len(means), squeeze=False)[0]
    ticks = [f"{v:g}" for v in values]
    for ax, (snr, grid) in zip(axes, means.items(), strict=True):
        image = ax.imshow(grid, origin="lower", cmap="viridis", interpolation="nearest")
        ax.set_xticks(range(len(values)), ticks)
        ax.set_yticks(range(len(values)), ticks)
        ax.set_xlabel("EP-SNR (dB)")
        ax.set_ylabel("PM-SNR (dB)")
        ax.set_title(f"data SNR {snr:g} dB")
        mid = 0.5 * (np.nanmin(grid) + np.nanmax(grid))
        for (row, col), value in np.ndenumerate(grid):
            colour = "black" if value > mid else "white"
            ax.text(col, row, f"{value:.0f}", ha="center", va="center", fontsize=7, color=colour)
        row, col = np.unravel_index(np.nanargmin(grid), grid.shape)
        ax.add_patch(Rectangle((col - 0.5, row - 0.5), 1, 1, fill=False, ec="red", lw=2))
        fig.colorbar(image, ax=ax, label="mean localization error (mm)", shrink=0.85)
    fig.suptitle(title)
    return fig


def _fine_figures(out, fine, settings):
    names = {}
    for tag, (exponent, smoother) in STAGES:
        means = _fine_means(fine, settings.fine_values(), exponent, smoother)
        fig = plot_fine_map(
            means,
            settings.fine_values(),
            f"{_setting_label(exponent, smoother)}: mean localization error over "
            f"{settings.seeds} seeds (red box: lowest)",
        )
        names[tag] = f"fine_map_{tag}.png"
        _save(fig, out / names[tag])
    return names


#: The figures of a cell in two groups of about equal drawing time (5-7 s each at
#: ``--quick``'s sizes), drawn in parallel.
FIGURE_GROUPS = (
    ("prior_grid", "exponents", "exponent_seeds"),
    ("bounds", "average", "fine_map"),
)


def make_figures(out, runs, settings, fine, controls, names=None):
    """Draw the figures of the report into ``out``; return their file names.

    Parameters
    ----------
    out : Path
    runs : CheckedRuns
        Reconstructions checked against the paper-grid table.
    settings : Settings
    fine : pandas.DataFrame
        The fine-map sweep table.
    controls : dict
        ``"deep"`` and ``"superficial"`` control tables.
    names : sequence of str, optional
        The figures to draw (a group of :data:`FIGURE_GROUPS`; default all).

    Returns
    -------
    dict
        ``prior_grid``, ``exponents``, ``exponent_seeds``, ``bounds``, ``average``,
        ``fine_map`` (those drawn) -> file names.
    """
    draw = dict(
        prior_grid=lambda: _prior_grid_figures(out, runs),
        exponents=lambda: _exponent_figure(out, runs),
        exponent_seeds=lambda: _exponent_seeds_figure(out, runs.table, settings.seeds),
        bounds=lambda: _bounds_figure(out, runs.table, controls, settings.seeds),
        average=lambda: _average_figures(out, runs, settings.seeds),
        fine_map=lambda: _fine_figures(out, fine, settings),
    )
    return {name: draw[name]() for name in (draw if names is None else names)}


def plot_source_placement(heads, truth_by_head, title=None):
    """The paper's Fig. 1 type: the two sources in each head, and their waveforms.

    One row per head: sagittal, coronal and axial views (head coordinates, mm) of the source
    space (grey), the electrodes (black) and the two dipoles (deep green, superficial red;
    arrows: orientations); the last panel of the first row shows the waveforms.

    Parameters
    ----------
    heads : dict
        Label -> skf_ref.study.head.HeadModel.
    truth_by_head : dict
        Label -> skf_ref.study.scenario.Truth placed in that head.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    views = (("sagittal", 1, 2), ("coronal", 0, 2), ("axial", 0, 1))
    names = ("x (mm), L → R", "y (mm), P → A", "z (mm), I → S")
    colours = ("tab:green", "tab:red")
    fig = Figure(figsize=(14.0, 3.6 * len(heads) + 0.4), layout="constrained")
    axes = fig.subplots(len(heads), 4, squeeze=False)
    for row, (label, head) in enumerate(heads.items()):
        truth = truth_by_head[label]
        electrodes = np.array([ch["loc"][:3] for ch in head.info["chs"]]) * 1e3
        positions = head.positions * 1e3
        for col, (view, h, v) in enumerate(views):
            ax = axes[row, col]
            ax.scatter(positions[:, h], positions[:, v], s=1.5, c="0.8", lw=0, rasterized=True)
            ax.scatter(electrodes[:, h], electrodes[:, v], s=8, c="k", lw=0)
            for pos, ori, colour in zip(
                truth.positions * 1e3, truth.orientations, colours, strict=True
            ):
                ax.plot(pos[h], pos[v], "o", ms=8, mfc=colour, mec="k")
                ax.annotate(
                    "",
                    xy=(pos[h] + 25 * ori[h], pos[v] + 25 * ori[v]),
                    xytext=(pos[h], pos[v]),
                    arrowprops=dict(arrowstyle="->", color=colour, lw=2),
                )
            ax.set_aspect("equal")
            ax.set_xlabel(names[h])
            ax.set_ylabel(names[v])
            ax.set_title(f"{label}: {view}")
        if row > 0:
            axes[row, 3].axis("off")
    ax = axes[0, 3]
    truth = next(iter(truth_by_head.values()))
    for wave, colour, name in zip(truth.waveforms, colours, ("deep", "superficial"), strict=True):
        ax.plot(truth.times * 1e3, wave * 1e9, color=colour, lw=2, label=name)
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("dipole moment (nAm)")
    ax.set_title("waveforms")
    ax.legend()
    if title:
        fig.suptitle(title)
    return fig


def save_source_placement(out, heads, truth_by_head):
    """Draw :func:`plot_source_placement` into ``out / source_placement.png``; its name."""
    fig = plot_source_placement(
        heads, truth_by_head, "Source placement: thalamus (VPL, green) and postcentral (red)"
    )
    _save(fig, out / "source_placement.png")
    return "source_placement.png"
