"""A run's settings: the two the package names, and the one check of every setting.

A setting is an exponent and a smoother, the two keyword arguments of
:func:`skf_ref.reconstruct` and :func:`skf_ref.apply_skf` they fill:
``reconstruct(L, Y, ..., **PAPER_SETTING)``. :func:`check_settings` checks what a run is
asked to do (the exponent, the smoother, the standardization, the computational path) for
every route that runs the SKF (:func:`skf_ref.reconstruct`, an operator's
``reconstruct``), once.
"""

from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike

from .._utils.checks import InputError, check_choice, check_int, check_real

__all__ = [
    "PATHS",
    "PAPER_SETTING",
    "RECOMMENDED_SETTING",
    "SMOOTHERS",
    "STANDARDIZATIONS",
    "Settings",
    "check_gaps",
    "check_settings",
    "check_smoother",
]

#: The exponent and smoother the package recommends and defaults to: exponent 0.5 with the
#: smoother whose standardization uses the smoothed covariances ("rts-smoothed-weights").
#: Chosen by the evidence study v3's rule, committed before the numbers it read
#: (validation/reproduce/PREREGISTRATION.md, section 6; validation/report/REPORT.md): of 48
#: settings (evolution prior x standardization x smoother), the one meeting the success
#: criteria against the best minimum-norm method at the matched regularization in all five
#: designs (the paper's pulses, an ERP, 10 Hz, two cortical sources, MEG), "SKF 0.5, AR auto,
#: position, rts-smoothed-weights". Its other parts are not in this mapping, which
#: ``reconstruct(L, Y, ..., **RECOMMENDED_SETTING)`` takes on bare arrays: the
#: standardization ``standardize="position"`` (each source position's block; needs
#: ``n_orient``, which an array does not carry, so :func:`skf_ref.reconstruct` defaults to
#: ``"column"`` and the MNE routes, which take ``n_orient`` from the forward, to
#: ``"position"``), and the priors: PM-SNR 0 dB and the stationary AR(1) prior with its time
#: constant chosen by the data (``time_constant_ms="auto"``, the default of
#: :func:`skf_ref.make_skf_operator`, :func:`skf_ref.apply_skf` and the command line's MNE
#: route, which know the sampling rate; an array does not, and takes the random walk).
RECOMMENDED_SETTING = MappingProxyType({"exponent": 0.5, "smoother": "rts-smoothed-weights"})
#: The paper's setting (exponent 1.25, its smoother), one argument away:
#: ``reconstruct(L, Y, ..., **PAPER_SETTING)``. In the study it "detects" a deep source that
#: is absent from the data in most runs at 20-30 dB.
PAPER_SETTING = MappingProxyType({"exponent": 1.25, "smoother": "rts-standardized"})
#: The smoothers (docs/model.md §3); None is the filter alone.
SMOOTHERS = (None, "rts-standardized", "rts-state", "rts-smoothed-weights")
#: What is standardized as a whole (docs/model.md §2): each column of the lead field (the
#: paper's), or each source position's ``n_orient`` columns together.
STANDARDIZATIONS = ("column", "position")
#: The computational paths; "auto" takes the spectral one whenever the model allows it.
PATHS = ("auto", "filterpy", "dense", "spectral")


@dataclass(frozen=True)
class Settings:
    """What a run computes, checked (:func:`check_settings`).

    Attributes
    ----------
    exponent : float
        The standardization exponent alpha of §2.2 eq. (7), >= 0.
    smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}
    path : {"auto", "filterpy", "dense", "spectral"}
    standardize : {"column", "position"}
    n_orient : {1, 3} or None
        Columns per source position (None: not given, allowed with ``"column"`` only).
    """

    exponent: float = 0.5
    smoother: str | None = None
    path: str = "auto"
    standardize: str = "column"
    n_orient: int | None = None

    @property
    def block(self) -> int:
        """int : The size of the blocks standardized together: ``n_orient`` for
        ``"position"``, 1 (each column) for ``"column"``."""
        return self.n_orient if self.standardize == "position" and self.n_orient else 1


def check_smoother(smoother: object) -> str | None:
    """The smoother, with ``"none"`` (the command line's and the results tables' word) as None.

    Examples
    --------
    >>> check_smoother("none") is None, check_smoother("rts-state")
    (True, 'rts-state')
    """
    if isinstance(smoother, str) and smoother == "none":
        return None
    try:
        return check_choice("smoother", smoother, SMOOTHERS)
    except InputError:
        raise InputError(
            f"smoother must be one of {[*SMOOTHERS, 'none']!r}, got {smoother!r}"
        ) from None


def check_settings(
    exponent: object = 0.5,
    smoother: object = None,
    path: object = "auto",
    standardize: object = "column",
    n_orient: object = None,
    n_sources: int | None = None,
) -> Settings:
    """Check a run's settings, naming the parameter, what it may be and what it got.

    Parameters
    ----------
    exponent : float
        >= 0.
    smoother : {None, "none", "rts-standardized", "rts-state", "rts-smoothed-weights"}
    path : {"auto", "filterpy", "dense", "spectral"}
    standardize : {"column", "position"}
        ``"position"`` needs ``n_orient``.
    n_orient : {1, 3}, optional
        Columns per source position, MNE's order.
    n_sources : int, optional
        The lead field's columns, which ``n_orient`` must divide.

    Returns
    -------
    Settings

    Examples
    --------
    >>> check_settings(1, "none")
    Settings(exponent=1.0, smoother=None, path='auto', standardize='column', n_orient=None)
    >>> check_settings(path="kalman")
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: path must be one of ['auto', 'filterpy', 'dense', \
'spectral'], got 'kalman'
    >>> check_settings(standardize="position")
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: standardize='position' needs n_orient, the columns \
per source position (3 for free orientation, 1 for fixed)
    """
    form: str = check_choice("standardize", standardize, STANDARDIZATIONS)
    if n_orient is not None:
        n_orient = check_int("n_orient", n_orient, minimum=None)
        if n_orient not in (1, 3):
            raise InputError(f"n_orient must be 1 or 3, got {n_orient!r}")
        if n_sources is not None and n_sources % n_orient:
            raise InputError(
                f"n_orient={n_orient} must divide the {n_sources} columns of L (positions "
                "of n_orient columns each, MNE's order)"
            )
    elif form == "position":
        raise InputError(
            "standardize='position' needs n_orient, the columns per source position (3 for "
            "free orientation, 1 for fixed)"
        )
    return Settings(
        exponent=check_real("exponent", exponent, nonnegative=True),
        smoother=check_smoother(smoother),
        path=check_choice("path", path, PATHS),
        standardize=form,
        n_orient=n_orient,
    )


def check_gaps(smoother: str | None, missing: ArrayLike) -> None:
    """Refuse the paper's smoother over data with missing steps (docs/model.md §2).

    ``"rts-standardized"`` runs the RTS recursion over the standardized sequence
    ``z_{t|t}``, which a missing step does not have (no weights, no standardization); its
    backward pass would carry the gap's NaN into every earlier step. ``"rts-state"``
    smooths the state, which is defined over a gap.

    Examples
    --------
    >>> check_gaps("rts-standardized", [False, True])
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: smoother='rts-standardized' is undefined over missing \
steps ...
    """
    n_missing = int(np.count_nonzero(missing))
    if smoother == "rts-standardized" and n_missing:
        raise InputError(
            "smoother='rts-standardized' is undefined over missing steps (the data have "
            f"{n_missing}): it smooths z_t|t, which a step without a measurement does not "
            "have; use smoother='rts-state' (the state is smoothed across the gap) or None, "
            "or reconstruct the segments between the gaps one by one"
        )
