"""The study's figures: the cortex-to-thalamus cross-talk map and the SKF's windows.

matplotlib is imported when a figure is drawn; figures are saved without a date stamp.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cross_talk_figure", "windows_figure"]

_PNG = dict(dpi=110, metadata={"Software": None})


def cross_talk_figure(worth, keys, path):
    """Cortical positions coloured by the thalamus' level when the source is alone (dB)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(keys), 2, figsize=(9, 3.2 * len(keys)), squeeze=False)
    image = None
    for row, key in zip(axes, keys, strict=True):
        lone = worth.scored_runs[key]["lone"]
        lone = lone[(lone["kind"] == "cortical") & np.isinf(lone["snr_db"])]
        talk = lone.groupby("position")["cross_talk_db"].median()
        xyz = worth.study.positions[talk.index.to_numpy(dtype=int)] * 1e3
        for ax, (a, b, names) in zip(row, ((0, 1, "x, y"), (1, 2, "y, z")), strict=True):
            image = ax.scatter(
                xyz[:, a], xyz[:, b], c=talk.to_numpy(), s=9, cmap="magma", vmin=-20, vmax=0
            )
            ax.set_aspect("equal")
            ax.set_xlabel(f"{names.split(', ')[0]} (mm, head)")
            ax.set_ylabel(f"{names.split(', ')[1]} (mm, head)")
        row[0].set_title(worth.label(key), loc="left", fontsize=9)
    fig.colorbar(image, ax=axes, label="thalamus re. map maximum (dB)", shrink=0.6)
    fig.savefig(path, **_PNG)
    plt.close(fig)
    return path


def windows_figure(worth, path):
    """The SKF's effective windows at the thalamic peak sample (D1)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.2))
    for setting, h, effective in worth.windows.values():
        kind = "RTS smoother" if setting.smooths else "filter"
        times = np.arange(len(h)) / 10.0  # D1: 10 kHz, ms
        ax.plot(times, h, marker=".", label=(
            f"EP {setting.ep_snr_db:g} / PM {setting.pm_snr_db:g} dB, {kind} "
            f"({effective:.1f} samples)"))  # fmt: skip
    ax.axvline(1.5, color="0.5", lw=0.8, ls="--")
    ax.set_xlabel("data sample (ms)")
    ax.set_ylabel("weight at 1.5 ms")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, **_PNG)
    plt.close(fig)
    return path
