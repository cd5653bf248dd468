"""The paper's figure types: region time courses and maximum-intensity projections.

The only module that imports matplotlib, and only inside functions. Figures are built with
:class:`matplotlib.figure.Figure` directly, not ``pyplot``: nothing is registered with a GUI
backend, sweeps need not close figures, notebooks display the returned figure, and
``path=...`` (or ``fig.savefig``) writes a file. ``reconstruction`` arguments are anything
:func:`skf_ref.study._regions.as_amplitude` accepts: an object with ``amplitude(3)`` (e.g.
``skf_ref.Reconstruction``) or an amplitude array of shape (n_positions, n_times). ``head``
needs ``positions`` (n_positions, 3) in metres (and, for projections, ``spacing`` in metres,
else it is inferred); ``truth`` needs ``positions`` (2, 3) m, ``waveforms`` (2, n_times) and
``times`` (n_times,) s, source 0 deep, source 1 superficial.
"""

from .estimates import plot_estimate, plot_landscape
from .projections import plot_average_reconstruction, plot_comparison
from .time_courses import plot_exponent_comparison, plot_prior_grid, plot_time_courses

__all__ = [
    "plot_average_reconstruction",
    "plot_comparison",
    "plot_estimate",
    "plot_exponent_comparison",
    "plot_landscape",
    "plot_prior_grid",
    "plot_time_courses",
]
