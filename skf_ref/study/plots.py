"""The paper's figure types: region time courses and maximum-intensity projections.

The only module that imports matplotlib, and only inside functions. Figures are built with
:class:`matplotlib.figure.Figure` directly, not ``pyplot``: nothing is registered with a GUI
backend, sweeps need not close figures, notebooks display the returned figure, and
``path=...`` (or ``fig.savefig``) writes a file. ``reconstruction`` arguments are anything
:func:`skf_ref.study.regions.as_amplitude` accepts: an object with ``amplitude(3)`` (e.g.
``skf_ref.Reconstruction``) or an amplitude array of shape (n_positions, n_times). ``head``
needs ``positions`` (n_positions, 3) in metres (and, for projections, ``spacing`` in metres,
else it is inferred); ``truth`` needs ``positions`` (2, 3) m, ``waveforms`` (2, n_times) and
``times`` (n_times,) s, source 0 deep, source 1 superficial.
"""

from __future__ import annotations

import numpy as np

from .._utils.checks import InputError, check_array, check_instance, check_int, check_real
from .regions import DYNAMIC_RANGE_DB, as_amplitude, check_amplitude, region_time_course

__all__ = [
    "plot_average_reconstruction",
    "plot_comparison",
    "plot_estimate",
    "plot_exponent_comparison",
    "plot_landscape",
    "plot_prior_grid",
    "plot_time_courses",
]

_COLOURS = ("tab:green", "tab:red")  # deep, superficial (the paper's colours)
_LABELS = ("deep", "superficial")
_DPI = 150


def _figure(width, height):
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


def _finish(fig, path):
    if path is not None:  # no software version in the file: the same figure, the same bytes
        fig.savefig(path, dpi=_DPI, metadata={"Software": None})
    return fig


def _draw_time_courses(ax, reconstruction, head, truth):
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
    for course, wave, colour, label in zip(courses, waves, _COLOURS, _LABELS, strict=True):
        ax.plot(times_ms, course / scale, color=colour, lw=1.8, label=f"{label} (region max)")
        ax.plot(
            times_ms, wave / wave_scale, color=colour, lw=1.2, ls="--", label=f"{label} (true)"
        )
    ax.set_xlim(times_ms[0], times_ms[-1])
    ax.set_ylim(-0.03, 1.08)
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("normalized amplitude")


def plot_time_courses(reconstruction, head, truth, ax=None, title=None, path=None):
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
    truth : Truth
    ax : matplotlib.axes.Axes, optional
        Axes to draw in; a new figure if None.
    title : str, optional
    path : str or path-like, optional
        Where to save the figure (format from the extension).

    Returns
    -------
    fig : matplotlib.figure.Figure
    """
    fig = _figure(5.0, 3.2) if ax is None else ax.figure
    ax = fig.add_subplot() if ax is None else ax
    _draw_time_courses(ax, reconstruction, head, truth)
    ax.set_ylim(top=1.4)  # room for the legend above the curves
    ax.legend(fontsize="small", loc="upper center", ncols=2, framealpha=0.9)
    if title is not None:
        ax.set_title(title, fontsize="medium")  # a two-line setting fits the 5-inch figure
    return _finish(fig, path)


def _panel_grid(panels, head, truth, nrows, ncols, title, path):
    """Time-course panels ``{(row, col): (reconstruction, title)}`` with one shared legend."""
    fig = _figure(3.3 * ncols, 2.5 * nrows + 0.6)
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
    return _finish(fig, path)


def plot_prior_grid(reconstructions, head, truth, title=None, path=None):
    """Time courses over a grid of prior parameters (the paper's 2 x 2 EP/PM figures).

    Parameters
    ----------
    reconstructions : dict
        ``{(ep_snr_db, pm_snr_db): reconstruction}``, a full grid, e.g. over {0, 20}^2.
        Columns: EP-SNR ascending; rows: PM-SNR ascending. Panel titles "EP 0, PM 20".
    head : HeadModel
    truth : Truth
    title : str, optional
        Figure title (e.g. the noise level and smoothing).
    path : str or path-like, optional

    Returns
    -------
    fig : matplotlib.figure.Figure
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


def plot_exponent_comparison(reconstructions, head, truth, title=None, path=None):
    """Time courses side by side, one panel per standardization exponent.

    Parameters
    ----------
    reconstructions : dict
        ``{exponent: reconstruction}``; panels in ascending exponent order.
    head : HeadModel
    truth : Truth
    title : str, optional
    path : str or path-like, optional

    Returns
    -------
    fig : matplotlib.figure.Figure
    """
    check_instance("reconstructions", reconstructions, dict, "a dict {exponent: reconstruction}")
    if not reconstructions:
        raise InputError("reconstructions must be a non-empty dict {exponent: reconstruction}")
    panels = {
        (0, col): (reconstructions[alpha], f"exponent {alpha:g}")
        for col, alpha in enumerate(sorted(reconstructions))
    }
    return _panel_grid(panels, head, truth, 1, len(panels), title, path)


def _grid_frame(head):
    """Affine from head coordinates to the frame the grid is axis aligned in, and its name."""
    anatomy = getattr(head, "anatomy", None)
    if anatomy is None:
        return np.eye(4), "head"
    return np.asarray(anatomy.grid_transform, dtype=float), anatomy.grid_frame


def _in_frame(affine, points):
    points = np.asarray(points, dtype=float)
    return points @ affine[:3, :3].T + affine[:3, 3]


def _lattice(head):
    """Integer grid indices (n_positions, 3) of the positions and the spacing (m)."""
    positions = _in_frame(_grid_frame(head)[0], head.positions)
    spacing = getattr(head, "spacing", None)
    if spacing is None or not np.isfinite(spacing):
        steps = np.concatenate([np.diff(np.unique(np.round(col, 9))) for col in positions.T])
        spacing = steps.min() if steps.size else 1.0
    cells = (positions - positions.min(axis=0)) / spacing
    index = np.rint(cells).astype(int)
    if np.abs(cells - index).max() > 1e-3:
        raise InputError("head.positions must lie on a regular cubic grid to be projected")
    return index, spacing


# projections: (name, axis projected away, horizontal axis, vertical axis)
_VIEWS = (("sagittal", 0, 1, 2), ("coronal", 1, 0, 2), ("axial", 2, 0, 1))
# head coordinates (MNE): x towards the right ear, y towards the nasion, z up
_AXIS_LABELS = ("x (mm), L \u2192 R", "y (mm), P \u2192 A", "z (mm), I \u2192 S")


def plot_average_reconstruction(
    reconstruction,
    head,
    truth,
    times_ms=(1.5, 2.5),
    dynamic_range_db=DYNAMIC_RANGE_DB,
    title=None,
    path=None,
):
    """Maximum-intensity projections of the amplitude at given times, in dB re. the max.

    One row per time, columns sagittal (y-z), coronal (x-z) and axial (x-y) maximum-
    intensity projections (MIP) in MNE's head coordinates (mm; x towards the right ear,
    y towards the nasion, z up), or, for a grid built in a subject's MRI coordinates
    (``head.anatomy.grid_frame == "MRI"``), in those (x right, y anterior, z superior).
    Colours span ``max - dynamic_range_db``
    to the maximum at that time; grid positions below the range are light grey, outside
    the grid white. True positions: deep green, superficial red circles. Pass an averaged
    amplitude (e.g. over noise realizations) to plot an average reconstruction.

    Parameters
    ----------
    reconstruction : object with ``amplitude(n_components)``, or ndarray
        Amplitude shape (n_positions, n_times).
    head : HeadModel
        Its positions must form a regular cubic grid.
    truth : Truth
    times_ms : sequence of float
        Times to show, in ms; each uses the nearest sample.
    dynamic_range_db : float
        Colour range in dB below each time's maximum.
    title : str, optional
    path : str or path-like, optional

    Returns
    -------
    fig : matplotlib.figure.Figure
    """
    positions = np.asarray(head.positions, dtype=float)
    amplitude = as_amplitude(reconstruction, positions.shape[0])
    times = np.asarray(truth.times, dtype=float)
    if amplitude.shape[1] != times.size:
        raise InputError(
            f"reconstruction amplitude must have shape (n_positions, n_times) = "
            f"({positions.shape[0]}, {times.size}), got shape {amplitude.shape}"
        )
    times_ms = np.atleast_1d(np.asarray(times_ms, dtype=float))
    half_step = 0.5 * (times[-1] - times[0]) / max(times.size - 1, 1) * 1e3
    if (
        times_ms.ndim != 1
        or not times_ms.size
        or (np.abs(times_ms[:, None] - times[None, :] * 1e3).min(axis=1) > half_step + 1e-9).any()
    ):
        raise InputError(
            f"times_ms must be times within {times[0] * 1e3:g}..{times[-1] * 1e3:g} ms, "
            f"got {times_ms.tolist()}"
        )
    dynamic_range_db = check_real("dynamic_range_db", dynamic_range_db, positive=True)
    grid = _Projections(head, truth)
    fig = _figure(9.0, 2.9 * times_ms.size + 0.5)
    axes = fig.subplots(times_ms.size, 3, squeeze=False)
    for row, t_ms in enumerate(times_ms):
        k = int(np.abs(times * 1e3 - t_ms).argmin())
        for col, view in enumerate(_VIEWS):
            image = grid.draw(axes[row, col], amplitude[:, k], view, dynamic_range_db)
            axes[row, col].set_title(f"{view[0]} MIP, {times[k] * 1e3:g} ms")
    fig.colorbar(image, ax=axes, label="dB re. maximum at that time", extend="min", shrink=0.8)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=2, fontsize="small")
    if title is not None:
        fig.suptitle(title)
    return _finish(fig, path)


class _Projections:
    """Maximum-intensity projections of amplitudes on a head's grid, with the true sources."""

    def __init__(self, head, truth, hollow=()):
        import matplotlib as mpl

        self.index, self.spacing = _lattice(head)
        frame, frame_name = _grid_frame(head)
        positions = _in_frame(frame, np.asarray(head.positions, dtype=float))
        self.truth = _in_frame(frame, truth.positions)
        self.hollow = hollow  # indices of the sources drawn dashed (absent from the data)
        tag = "" if frame_name == "head" else f", {frame_name}"
        self.labels = [label.replace(" (mm)", f" (mm{tag})") for label in _AXIS_LABELS]
        self.corner_mm = positions.min(axis=0) * 1e3
        cmap = mpl.colormaps["Blues"].resampled(256)
        cmap = mpl.colors.ListedColormap(cmap(np.linspace(0.3, 1.0, 256)))
        self.cmap = cmap.with_extremes(under="0.85", bad="white")

    def draw(self, ax, a, view, dynamic_range_db):
        """One MIP of the amplitudes ``a`` (n_positions,) in dB re. their maximum."""
        name, away, horiz, vert = view
        with np.errstate(divide="ignore"):
            db = 20.0 * np.log10(a / a.max()) if a.max() > 0 else np.full(a.shape, -np.inf)
        volume = np.full(self.index.max(axis=0) + 1, -np.inf)
        volume[tuple(self.index.T)] = db
        occupied = np.zeros(volume.shape, dtype=bool)
        occupied[tuple(self.index.T)] = True
        # mip axes: (horizontal, vertical), as horiz < vert in every view
        mip = np.where(occupied.any(axis=away), volume.max(axis=away), np.nan)
        lo = self.corner_mm - 0.5 * self.spacing * 1e3
        hi = self.corner_mm + (np.array(volume.shape) - 0.5) * self.spacing * 1e3
        image = ax.imshow(
            mip.T,
            origin="lower",
            extent=(lo[horiz], hi[horiz], lo[vert], hi[vert]),
            cmap=self.cmap,
            vmin=-dynamic_range_db,
            vmax=0.0,
            interpolation="nearest",
        )
        for k, (pos, colour, label) in enumerate(zip(self.truth, _COLOURS, _LABELS, strict=True)):
            absent = k in self.hollow
            ax.plot(
                pos[horiz] * 1e3,
                pos[vert] * 1e3,
                "o",
                ms=9,
                mfc="none",
                mec=colour,
                mew=1.2 if absent else 2.0,
                alpha=0.5 if absent else 1.0,
                label=f"{label} ({'absent from the data' if absent else 'true'})",
            )
        ax.set_xlabel(self.labels[horiz])
        ax.set_ylabel(self.labels[vert])
        return image


def plot_comparison(
    estimates, head, truth, absent=None, time_ms=1.5, view="coronal", title=None, path=None
):
    """Methods side by side, each with a source present and absent: one MIP a panel.

    A grid of panels, one row per data set (e.g. both sources, and the deep source left
    out) and one column per method, each the maximum-intensity projection of the amplitude
    at ``time_ms``, in dB re. its maximum then (the paper's 6 dB range). Each panel is
    annotated with the deep region's level (its maximum re. the global maximum, dB) and
    whether that counts as a detection (within 6 dB): a detection in a row without the deep
    source is a false one. True sources are circles, drawn faint where absent.

    Parameters
    ----------
    estimates : dict
        ``{(method, data): amplitude}`` with amplitudes of shape (n_positions, n_times)
        (or objects with ``amplitude(3)``); ``data`` labels the rows, in order of first
        appearance, ``method`` the columns.
    head : HeadModel
        Its positions must form a regular cubic grid.
    truth : Truth
    absent : dict, optional
        ``{data: names}``: the sources (``"deep"``, ``"superficial"``) left out of a data
        set; drawn faint, and a deep detection there is marked as false (red).
    time_ms : float
        Time shown (nearest sample); 1.5 ms is the deep source's peak.
    view : {"sagittal", "coronal", "axial"}
    title : str, optional
    path : str or path-like, optional

    Returns
    -------
    fig : matplotlib.figure.Figure
    """
    from .._utils.checks import check_choice
    from .regions import region_db

    check_instance("estimates", estimates, dict, "a dict {(method, data): amplitude}")
    if not estimates or not all(isinstance(k, tuple) and len(k) == 2 for k in estimates):
        raise InputError("estimates must be a non-empty dict {(method, data): amplitude}")
    check_choice("view", view, [name for name, *_ in _VIEWS])
    absent = {} if absent is None else check_instance("absent", absent, dict, "a dict")
    view = next(v for v in _VIEWS if v[0] == view)
    methods = list(dict.fromkeys(method for method, _ in estimates))
    rows = list(dict.fromkeys(data for _, data in estimates))
    times = np.asarray(truth.times, dtype=float)
    k = int(np.abs(times * 1e3 - check_real("time_ms", time_ms)).argmin())
    fig = _figure(3.4 * len(methods) + 0.9, 3.0 * len(rows) + 0.9)
    axes = fig.subplots(len(rows), len(methods), squeeze=False)
    for row, data in enumerate(rows):
        for col, method in enumerate(methods):
            ax = axes[row, col]
            if (method, data) not in estimates:
                ax.set_axis_off()
                continue
            amplitude = as_amplitude(estimates[method, data], len(head.positions))
            left_out = absent.get(data, ())
            hollow = [i for i, name in enumerate(_LABELS) if name in left_out]
            image = _Projections(head, truth, hollow).draw(
                ax, amplitude[:, k], view, DYNAMIC_RANGE_DB
            )
            level = region_db(amplitude, head.positions, truth.positions[0], k)
            detected = level >= -DYNAMIC_RANGE_DB
            verdict = "detected" if detected else "not detected"
            ax.text(
                0.02, 0.02, f"deep region {level:.1f} dB: {verdict}", transform=ax.transAxes,
                fontsize="small", va="bottom",
                color="tab:red" if detected and "deep" in left_out else "black",
                bbox=dict(facecolor="white", alpha=0.8, lw=0),
            )  # fmt: skip
            ax.set_title(f"{method}\n{data}", fontsize="small")
            ax.label_outer()
    fig.colorbar(image, ax=axes, label="dB re. maximum at that time", extend="min", shrink=0.8)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    labels = [f"{label}; faint: left out of the data" for label in labels]
    fig.legend(handles, labels, loc="outside lower center", ncols=2, fontsize="small")
    fig.suptitle(title or f"{view[0]} MIP at {times[k] * 1e3:g} ms")
    return _finish(fig, path)


def plot_estimate(amplitude, times, positions=None, n_strongest=5, title=None, path=None):
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
    times : ndarray, shape (n_times,)
        Seconds.
    positions : ndarray, shape (n_positions, 3), optional
        Metres, head coordinates.
    n_strongest : int
    title : str, optional
    path : str or path-like, optional

    Returns
    -------
    fig : matplotlib.figure.Figure
    """

    times_ms = np.asarray(times, dtype=float) * 1e3
    amplitude = check_amplitude(amplitude, len(amplitude))
    if amplitude.shape[1] != times_ms.size:
        raise InputError(
            f"times must have shape ({amplitude.shape[1]},) like amplitude's columns, got "
            f"{times_ms.shape}"
        )
    n_strongest = check_int("n_strongest", n_strongest, minimum=1)
    fig = _figure(12.0 if positions is not None else 5.0, 3.4)
    axes = fig.subplots(1, 4 if positions is not None else 1, squeeze=False)[0]
    strongest = np.argsort(amplitude.max(axis=1))[::-1][:n_strongest]
    for index in strongest:
        axes[0].plot(times_ms, amplitude[index], lw=1.4, label=f"position {index}")
    axes[0].set_xlabel("time (ms)")
    axes[0].set_ylabel("amplitude")
    axes[0].legend(fontsize="x-small")
    axes[0].set_title(f"{len(strongest)} strongest positions")
    if positions is not None:
        positions = check_array("positions", positions, (len(amplitude), 3)) * 1e3
        k = int(np.argmax(amplitude.max(axis=0)))
        with np.errstate(divide="ignore"):
            db = 20 * np.log10(amplitude[:, k] / amplitude[:, k].max())
        order = np.argsort(db)
        for ax, (name, _, horiz, vert) in zip(axes[1:], _VIEWS, strict=True):
            dots = ax.scatter(
                positions[order, horiz],
                positions[order, vert],
                c=db[order],
                cmap="Blues",
                vmin=-DYNAMIC_RANGE_DB,
                vmax=0.0,
                s=12,
            )
            ax.set_aspect("equal")
            ax.set_title(f"{name} MIP, {times_ms[k]:g} ms")
            ax.set_xlabel(_AXIS_LABELS[horiz])
            ax.set_ylabel(_AXIS_LABELS[vert])
        fig.colorbar(dots, ax=axes[1:], label="dB re. maximum at that time", shrink=0.8)
    if title is not None:
        fig.suptitle(title)
    return _finish(fig, path)


# log-likelihood units shown below the chosen priors: a difference of more than a few units
# is already decisive, and the far corners of a grid lie thousands below
_LANDSCAPE_RANGE = 100.0


def plot_landscape(result, path=None, title=None):
    """The marginal likelihood over (EP-SNR, PM-SNR), with the chosen priors marked.

    Parameters
    ----------
    result : skf_ref.method.tuning.TuneResult
        Its ``landscape`` (the coarse grid) and chosen ``pm_snr_db``, ``ep_snr_db``.
    path : str or path-like, optional
    title : str, optional

    Returns
    -------
    fig : matplotlib.figure.Figure
        A heat map of ``log p(Y) - max log p(Y)`` over the grid (a curve when one SNR was
        fixed) and a star at the chosen point.
    """
    grid = result.landscape.pivot(index="pm_snr_db", columns="ep_snr_db", values="log_likelihood")
    relative = grid.to_numpy() - result.log_likelihood
    fig = _figure(5.2, 4.0)
    ax = fig.add_subplot()
    if 1 in relative.shape:  # one SNR was fixed: a curve
        fixed_pm = relative.shape[0] == 1
        axis = grid.columns if fixed_pm else grid.index
        ax.plot(axis, relative.ravel(), "o-", color="tab:blue")
        ax.axvline(result.ep_snr_db if fixed_pm else result.pm_snr_db, color="tab:red")
        ax.set_xlabel("EP-SNR (dB)" if fixed_pm else "PM-SNR (dB)")
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
        ax.plot(result.ep_snr_db, result.pm_snr_db, "*", ms=14, mfc="tab:red", mec="white")
        ax.set_xlabel("EP-SNR (dB)")
        ax.set_ylabel("PM-SNR (dB)")
        fig.colorbar(image, ax=ax, extend="min", label="log-likelihood re. the chosen priors")
    ax.set_title(
        title or f"chosen: EP-SNR {result.ep_snr_db:.1f} dB, PM-SNR {result.pm_snr_db:.1f} dB"
    )
    return _finish(fig, path)
