"""Maximum-intensity projections of amplitudes on a head's source grid."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..._utils.checks import InputError, check_instance, check_real
from .._regions import DYNAMIC_RANGE_DB, as_amplitude
from .style import AXIS_LABELS, COLOURS, LABELS, VIEWS, figure, finish

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["plot_average_reconstruction", "plot_comparison"]


def _grid_frame(head: Any) -> tuple[np.ndarray, str]:
    """Affine from head coordinates to the frame the grid is axis aligned in, and its name."""
    anatomy = getattr(head, "anatomy", None)
    if anatomy is None:
        return np.eye(4), "head"
    return np.asarray(anatomy.grid_transform, dtype=float), anatomy.grid_frame


def _in_frame(affine: np.ndarray, points: Any) -> np.ndarray:
    xyz = np.asarray(points, dtype=float)
    return xyz @ affine[:3, :3].T + affine[:3, 3]


def _lattice(head: Any) -> tuple[np.ndarray, float]:
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


def plot_average_reconstruction(
    reconstruction: Any,
    head: Any,
    truth: Any,
    times_ms: Sequence[float] = (1.5, 2.5),
    dynamic_range_db: float = DYNAMIC_RANGE_DB,
    title: str | None = None,
    path: str | os.PathLike | None = None,
) -> Figure:
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
        The exact sources (``Truth``).
    times_ms : sequence of float
        Times to show, in ms; each uses the nearest sample.
    dynamic_range_db : float
        Colour range in dB below each time's maximum.
    title : str, optional
        The figure's title; None: none.
    path : str or path-like, optional
        Where to save the figure (its format from the suffix); None: not saved.

    Returns
    -------
    fig : matplotlib.figure.Figure
        The figure (saved to ``path`` if given).
    """
    positions = np.asarray(head.positions, dtype=float)
    amplitude = as_amplitude(reconstruction, positions.shape[0])
    times = np.asarray(truth.times, dtype=float)
    if amplitude.shape[1] != times.size:
        raise InputError(
            f"reconstruction amplitude must have shape (n_positions, n_times) = "
            f"({positions.shape[0]}, {times.size}), got shape {amplitude.shape}"
        )
    shown_ms = np.atleast_1d(np.asarray(times_ms, dtype=float))
    half_step = 0.5 * (times[-1] - times[0]) / max(times.size - 1, 1) * 1e3
    if (
        shown_ms.ndim != 1
        or not shown_ms.size
        or (np.abs(shown_ms[:, None] - times[None, :] * 1e3).min(axis=1) > half_step + 1e-9).any()
    ):
        raise InputError(
            f"times_ms must be times within {times[0] * 1e3:g}..{times[-1] * 1e3:g} ms, "
            f"got {shown_ms.tolist()}"
        )
    dynamic_range = check_real("dynamic_range_db", dynamic_range_db, positive=True)
    grid = _Projections(head, truth)
    fig = figure(9.0, 2.9 * shown_ms.size + 0.5)
    axes = fig.subplots(shown_ms.size, 3, squeeze=False)
    for row, t_ms in enumerate(shown_ms):
        k = int(np.abs(times * 1e3 - t_ms).argmin())
        for col, view in enumerate(VIEWS):
            image = grid.draw(axes[row, col], amplitude[:, k], view, dynamic_range)
            axes[row, col].set_title(f"{view[0]} MIP, {times[k] * 1e3:g} ms")
    fig.colorbar(image, ax=axes, label="dB re. maximum at that time", extend="min", shrink=0.8)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=2, fontsize="small")
    if title is not None:
        fig.suptitle(title)
    return finish(fig, path)


class _Projections:
    """Maximum-intensity projections of amplitudes on a head's grid, with the true sources."""

    def __init__(self, head: Any, truth: Any, hollow: Sequence[int] = ()) -> None:
        import matplotlib as mpl

        self.index, self.spacing = _lattice(head)
        frame, frame_name = _grid_frame(head)
        positions = _in_frame(frame, np.asarray(head.positions, dtype=float))
        self.truth = _in_frame(frame, truth.positions)
        self.hollow = hollow  # indices of the sources drawn dashed (absent from the data)
        tag = "" if frame_name == "head" else f", {frame_name}"
        self.labels = [label.replace(" (mm)", f" (mm{tag})") for label in AXIS_LABELS]
        self.corner_mm = positions.min(axis=0) * 1e3
        cmap = mpl.colormaps["Blues"].resampled(256)
        cmap = mpl.colors.ListedColormap(cmap(np.linspace(0.3, 1.0, 256)))
        self.cmap = cmap.with_extremes(under="0.85", bad="white")

    def draw(
        self, ax: Any, a: np.ndarray, view: tuple[str, int, int, int], dynamic_range_db: float
    ) -> Any:
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
        for k, (pos, colour, label) in enumerate(zip(self.truth, COLOURS, LABELS, strict=True)):
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
    estimates: Mapping[tuple[str, str], Any],
    head: Any,
    truth: Any,
    absent: Mapping[str, Sequence[str]] | None = None,
    time_ms: float = 1.5,
    view: str = "coronal",
    title: str | None = None,
    path: str | os.PathLike | None = None,
    thresholds: Mapping[str, float] | None = None,
) -> Figure:
    """Methods side by side, each with a source present and absent: one MIP a panel.

    A grid of panels, one row per data set (e.g. both sources, and the deep source left
    out) and one column per method, each the maximum-intensity projection of the amplitude
    at ``time_ms``, in dB re. its maximum then (the paper's 6 dB range). Each panel is
    annotated with the deep region's level (its maximum re. the global maximum, dB) and
    whether that counts as a detection (within 6 dB), or, with ``thresholds``, with the
    thalamus' level against a calibrated threshold (:mod:`skf_ref.study._detection`): a
    detection in a row without the deep source is a false one. True sources are circles,
    drawn faint where absent.

    Parameters
    ----------
    estimates : dict
        ``{(method, data): amplitude}`` with amplitudes of shape (n_positions, n_times)
        (or objects with ``amplitude(3)``); ``data`` labels the rows, in order of first
        appearance, ``method`` the columns.
    head : HeadModel
        Its positions must form a regular cubic grid.
    truth : Truth
        The exact sources (``Truth``).
    absent : dict, optional
        ``{data: names}``: the sources (``"deep"``, ``"superficial"``) left out of a data
        set; drawn faint, and a deep detection there is marked as false (red).
    time_ms : float
        Time shown (nearest sample); 1.5 ms is the deep source's peak.
    view : {"sagittal", "coronal", "axial"}
        The projection.
    title : str, optional
        The figure's title; None: none.
    path : str or path-like, optional
        Where to save the figure (its format from the suffix); None: not saved.
    thresholds : dict, optional
        ``{method: threshold}`` on the thalamus' level (a cortex + thalamus head): a panel
        detects when the largest amplitude over the thalamus at ``time_ms`` exceeds its
        method's threshold (:func:`skf_ref.study._detection.calibrate`). None: the deep
        region within 6 dB of the maximum, the paper's reading.

    Returns
    -------
    fig : matplotlib.figure.Figure
        The figure (saved to ``path`` if given).
    """
    from ..._utils.checks import check_choice
    from .._regions import region_db

    check_instance("estimates", estimates, dict, "a dict {(method, data): amplitude}")
    if not estimates or not all(isinstance(k, tuple) and len(k) == 2 for k in estimates):
        raise InputError("estimates must be a non-empty dict {(method, data): amplitude}")
    check_choice("view", view, [name for name, *_ in VIEWS])
    absent = {} if absent is None else check_instance("absent", absent, dict, "a dict")
    projection = next(v for v in VIEWS if v[0] == view)
    methods = list(dict.fromkeys(method for method, _ in estimates))
    if thresholds is not None:
        from .._sources import position_structures

        check_instance("thresholds", thresholds, dict, "a dict {method: threshold}")
        missing = [method for method in methods if method not in thresholds]
        if missing:
            raise InputError(f"thresholds has no threshold for {missing}")
        thalamus = position_structures(head) == "thalamus"
    rows = list(dict.fromkeys(data for _, data in estimates))
    times = np.asarray(truth.times, dtype=float)
    k = int(np.abs(times * 1e3 - check_real("time_ms", time_ms)).argmin())
    fig = figure(3.4 * len(methods) + 0.9, 3.0 * len(rows) + 0.9)
    axes = fig.subplots(len(rows), len(methods), squeeze=False)
    for row, data in enumerate(rows):
        for col, method in enumerate(methods):
            ax = axes[row, col]
            if (method, data) not in estimates:
                ax.set_axis_off()
                continue
            amplitude = as_amplitude(estimates[method, data], len(head.positions))
            left_out = absent.get(data, ())
            hollow = [i for i, name in enumerate(LABELS) if name in left_out]
            image = _Projections(head, truth, hollow).draw(
                ax, amplitude[:, k], projection, DYNAMIC_RANGE_DB
            )
            level = region_db(amplitude, head.positions, truth.positions[0], k)
            detected = level >= -DYNAMIC_RANGE_DB
            text = f"deep region {level:.1f} dB"
            if thresholds is not None:
                thalamic = float(amplitude[thalamus, k].max())
                detected = thalamic > thresholds[method]
                text = f"thalamus {thalamic:.3g}, threshold {thresholds[method]:.3g}"
            verdict = "detected" if detected else "not detected"
            ax.text(
                0.02, 0.02, f"{text}: {verdict}", transform=ax.transAxes,
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
    fig.suptitle(title or f"{projection[0]} MIP at {times[k] * 1e3:g} ms")
    return finish(fig, path)
