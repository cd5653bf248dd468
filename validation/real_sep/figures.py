"""The report's figures: the sensor data, where each method puts its maxima, time courses."""

import numpy as np

from . import criteria

#: Colours by family, so that a glance tells the SKF from MNE's methods.
COLOURS = {"skf": "tab:red", "minimum_norm": "tab:blue", "lcmv": "tab:green", "mxne": "tab:purple"}
#: The SKF's AR(1) rows are drawn in orange (:func:`_colour`).
MARKERS = "osD^v<>phX*P8"


def _colour(row):
    """The family's colour; the SKF's AR(1) rows apart from its random walk's."""
    return "tab:orange" if "/AR" in row["setting"] else COLOURS[row["family"]]


def _figure(*args, **kwargs):
    from matplotlib.figure import Figure

    return Figure(*args, **kwargs, layout="constrained")


def sensors(recording):
    """Butterfly plot and GFP of one recording, its N20, P14 and P16 marked."""
    figure = _figure(figsize=(7, 3.2))
    ax = figure.subplots()
    times = recording.evoked.times * 1e3
    ax.plot(times, recording.evoked.data.T * 1e6, color="0.6", lw=0.5)
    ax.plot(times, recording.evoked.data.std(axis=0) * 1e6, color="k", lw=2, label="GFP")
    for event, latency in recording.latencies.items():
        ax.axvline(latency * 1e3, color="tab:orange", ls="--", lw=1)
        ax.text(latency * 1e3, ax.get_ylim()[1], f" {event}", va="top", fontsize=8)
    ax.set(xlim=(-20, 60), xlabel="time (ms)", ylabel="µV", title=recording.name)
    ax.legend(loc="lower right", fontsize=8)
    return figure


def maxima(recording, table):
    """Where each setting puts its maximum at the N20 and at the P14: two views each."""
    figure = _figure(figsize=(10, 8))
    axes = figure.subplots(2, 2)
    rows = table[table["recording"] == recording.name].reset_index(drop=True)
    for line, event in enumerate(("N20", "P14")):
        for column, (i, j, names) in enumerate(
            ((0, 2, "x (right), z (up)"), (0, 1, "x, y (front)"))
        ):
            ax = axes[line, column]
            _head(ax, recording, i, j)
            for k, row in rows.iterrows():
                point = [row[f"{event}_{a}_mm"] for a in "xyz"]
                ax.scatter(
                    point[i],
                    point[j],
                    color=_colour(row),
                    marker=MARKERS[k % len(MARKERS)],
                    s=40,
                    label=row["setting"],
                )
            ax.set(title=f"{recording.name}: {event} maxima, {names} (mm)", aspect="equal")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="outside right", fontsize=6)
    return figure


def _head(ax, recording, i, j):
    """The fitted head circle, the deep region and the central region, in one projection."""
    from matplotlib.patches import Circle

    c, p = recording.centre * 1e3, recording.central * 1e3
    ax.add_patch(Circle((c[i], c[j]), recording.radius * 1e3, fill=False, color="0.5"))
    ax.add_patch(Circle((c[i], c[j]), criteria.DEEP_RADIUS * 1e3, color="0.85", zorder=0))
    ax.add_patch(
        Circle((p[i], p[j]), criteria.CENTRAL_RADIUS * 1e3, color="gold", alpha=0.5, zorder=0)
    )
    positions = recording.positions * 1e3
    ax.scatter(positions[:, i], positions[:, j], s=0.2, color="0.8", zorder=0)


def time_courses(recording, table, courses):
    """Each setting's time courses, normalized by their maximum after the stimulus."""
    from .run import course_window

    rows = table[table["recording"] == recording.name].reset_index(drop=True)
    n = len(rows)
    columns = 6
    lines = int(np.ceil(n / columns))
    figure = _figure(figsize=(13, 1.45 * lines + 0.6))
    axes = figure.subplots(lines, columns, sharex=True, squeeze=False)
    window = course_window(recording)
    times = recording.evoked.times[window] * 1e3
    after = recording.evoked.times[window] > 0
    for ax, (_, row) in zip(axes.flat, rows.iterrows(), strict=False):
        course = courses[recording.name, row["setting"]]
        scale = max(course[name][after].max() for name in course) or 1.0
        for name, style in (
            ("central region", dict(color="tab:orange")),
            ("deep region", dict(color="k")),
            ("N20 maximum", dict(color="tab:red", ls="--")),
            ("P14 maximum", dict(color="tab:blue", ls=":")),
        ):
            ax.plot(times, course[name] / scale, lw=0.8, label=name, **style)
        for latency in recording.latencies.values():
            ax.axvline(latency * 1e3, color="0.7", lw=0.5)
        ax.set_title(row["setting"].removeprefix("SKF "), fontsize=6.5)
        ax.tick_params(labelsize=6)
        ax.set_xlim(times[0], times[-1])
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    axes.flat[0].legend(fontsize=5, loc="upper left")
    figure.supxlabel(f"time (ms); {recording.name}", fontsize=8)
    return figure


def neck(recording, rows):
    """The 256-channel cap from the left and from behind: the neck rows, the registered
    template's landmarks and the plane through the inion and the preauricular points."""
    figure = _figure(figsize=(8, 3.6))
    positions = np.array([ch["loc"][:3] for ch in recording.evoked.info["chs"]]) * 1e3
    landmarks = {k: v * 1e3 for k, v in rows.landmarks.items()}
    for ax, (i, name) in zip(
        figure.subplots(1, 2),
        ((1, "from the left: y (front)"), (0, "from behind: x (right)")),
        strict=True,
    ):
        for mask, style in (
            (~rows.below, dict(color="0.5", s=8)),
            (rows.below, dict(color="tab:red", s=14)),
        ):
            ax.scatter(positions[mask, i], positions[mask, 2], **style)
        for key, point in landmarks.items():
            ax.scatter(point[i], point[2], marker="x", color="k", s=30)
            ax.annotate(
                key, (point[i], point[2]), fontsize=7, xytext=(3, 3), textcoords="offset points"
            )
        # the plane's trace in this view, through the inion (x = its x, y = its y)
        n, p0 = rows.normal, landmarks["inion"]
        line = np.linspace(positions[:, i].min(), positions[:, i].max(), 2)
        z = p0[2] - n[i] * (line - p0[i]) / n[2]
        ax.plot(line, z, color="tab:red", lw=0.8)
        ax.set(xlabel=f"{name} (mm)", ylabel="z (up, mm)", aspect="equal")
    figure.suptitle(
        f"{len(rows.names)} neck rows (red): below the plane through the inion and the "
        "preauricular points",
        fontsize=9,
    )
    return figure
