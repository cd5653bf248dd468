"""What every figure of the study shares: its colours, labels, size and how it is saved."""

import os
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["AXIS_LABELS", "COLOURS", "DPI", "LABELS", "VIEWS", "figure", "finish"]

COLOURS = ("tab:green", "tab:red")  # deep, superficial (the paper's colours)
LABELS = ("deep", "superficial")
DPI = 150


def figure(width: float, height: float) -> "Figure":
    """A matplotlib Figure (no pyplot, constrained layout) of the given size.

    Parameters
    ----------
    width, height : float
        In inches.

    Returns
    -------
    matplotlib.figure.Figure
        Not registered with pyplot: nothing to close.
    """
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


def finish(fig: "Figure", path: str | os.PathLike | None, *, overwrite: bool = True) -> "Figure":
    """Save a figure if a path is given, and return it.

    The file holds no software stamp (the same figure, the same bytes), and appears whole
    or not at all (written to a temporary file, then renamed).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : path-like or None
        Where to save it (its format from the suffix); None: not saved.
    overwrite : bool
        Replace a file at ``path``; False: one there when the figure is published stays,
        and this one is not kept (an error).

    Returns
    -------
    matplotlib.figure.Figure
        ``fig``.
    """
    if path is not None:  # no software version in the file: the same figure, the same bytes
        from ..._utils.atomic_files import atomic_path

        with atomic_path(path, overwrite=overwrite) as tmp:
            fig.savefig(tmp, dpi=DPI, metadata={"Software": None})
    return fig


#: Maximum-intensity projections: (name, axis projected away, horizontal axis, vertical axis).
VIEWS = (("sagittal", 0, 1, 2), ("coronal", 1, 0, 2), ("axial", 2, 0, 1))
#: Axis labels in head coordinates (MNE): x towards the right ear, y towards the nasion, z up.
AXIS_LABELS = ("x (mm), L \u2192 R", "y (mm), P \u2192 A", "z (mm), I \u2192 S")
