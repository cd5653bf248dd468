"""What every figure of the study shares: its colours, labels, size and how it is saved."""

__all__ = ["AXIS_LABELS", "COLOURS", "DPI", "LABELS", "VIEWS", "figure", "finish"]

COLOURS = ("tab:green", "tab:red")  # deep, superficial (the paper's colours)
LABELS = ("deep", "superficial")
DPI = 150


def figure(width, height):
    """A matplotlib Figure (no pyplot, constrained layout) of the given size in inches."""
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


def finish(fig, path):
    """Save ``fig`` to ``path`` if given (no software stamp: the same figure, the same
    bytes; whole or absent, through a temporary file), and return it."""
    if path is not None:  # no software version in the file: the same figure, the same bytes
        from ..._utils.atomic_files import atomic_path

        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=DPI, metadata={"Software": None})
    return fig


#: Maximum-intensity projections: (name, axis projected away, horizontal axis, vertical axis).
VIEWS = (("sagittal", 0, 1, 2), ("coronal", 1, 0, 2), ("axial", 2, 0, 1))
#: Axis labels in head coordinates (MNE): x towards the right ear, y towards the nasion, z up.
AXIS_LABELS = ("x (mm), L \u2192 R", "y (mm), P \u2192 A", "z (mm), I \u2192 S")
