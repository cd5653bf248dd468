"""Data and noise in different units, told by the whitened data's level.

Whitened with the noise covariance (or ``noise_std``) of the data's own units, noise has
unit variance: real baselines are within a factor of about 3 of 1. Data in uV with a
covariance in V^2 are whitened 1e6 times too large, and the reverse 1e6 times too small;
"auto" priors then end on a bound of their search range, whose warning would advise
widening it. :func:`units_mismatch` tells the mismatch from the level (over the samples
before the response when there are some, else over all of them, with a higher ceiling for
the signal they hold; the median over samples of their RMS over channels, which an
artefact does not move); :func:`units_cause` makes the bound warning name the units.
"""

from __future__ import annotations

import contextlib
import contextvars
import warnings
from collections.abc import Iterator

import numpy as np
from numpy.typing import ArrayLike

from .._utils.log import caller_stacklevel

__all__ = ["current_cause", "units_cause", "units_mismatch", "warn_units"]

#: The factors off 1 beyond which the level says units, not data: 100 (40 dB) over noise
#: alone, 1000 above over all samples (a strong response raises their level).
NOISE_FACTOR, SIGNAL_FACTOR = 100.0, 1000.0
_MIN_BASELINE = 10  # fewer samples before the response: all samples are used

_CAUSE: contextvars.ContextVar[str | None] = contextvars.ContextVar("units_cause", default=None)


def units_mismatch(whitened: ArrayLike, baseline: ArrayLike | None = None) -> str | None:
    """What the whitened data's level says of the units, or None when it says nothing.

    Parameters
    ----------
    whitened : array_like, shape (n_channels, n_times)
        The data whitened with the noise covariance (NaN columns: missing steps).
    baseline : array_like of bool, shape (n_times,), optional
        The samples before the response (``times <= 0``): the level is taken over them
        when there are at least 10, else over all samples.

    Returns
    -------
    str or None
    """
    data = np.asarray(whitened, dtype=float)
    kept = ~np.isnan(data).any(axis=0)
    where, ceiling = "over all samples", SIGNAL_FACTOR
    if baseline is not None:
        before = np.asarray(baseline, dtype=bool) & kept
        if np.count_nonzero(before) >= _MIN_BASELINE:
            kept, where, ceiling = before, "before the response (t <= 0)", NOISE_FACTOR
    if not kept.any():
        return None
    # the median over samples of their RMS over channels: an artefact, or a strong
    # response, over a minority of the samples does not move it; units move every sample
    level = float(np.median(np.sqrt(np.mean(data[:, kept] ** 2, axis=0))))
    if 1 / NOISE_FACTOR <= level <= ceiling:
        return None
    if level > 1:
        likely = "data in uV with a noise covariance in V^2, or a noise_std in V for data in uV"
        size = "larger"
    else:
        likely = "data in V with a noise covariance in uV^2, or a noise_std in uV for data in V"
        size = "smaller"
    return (
        f"the whitened data's RMS (median over samples) {where} is {level:.3g} "
        f"({20 * np.log10(level):+.0f} dB), "
        f"where noise whitened in the data's units is near 1: the data are {size} than the "
        f"noise said by {max(level, 1 / level):.3g}, likely different units ({likely}; MNE "
        "keeps EEG in V): give data and noise in the same units"
    )


def warn_units(message: str | None) -> None:
    """Warn of a units mismatch (:func:`units_mismatch`'s message), if any."""
    if message is not None:
        warnings.warn(message, UserWarning, stacklevel=caller_stacklevel())


@contextlib.contextmanager
def units_cause(message: str | None) -> Iterator[None]:
    """Within it, a prior on a bound of its search range is said to be the units'."""
    token = _CAUSE.set(message)
    try:
        yield
    finally:
        _CAUSE.reset(token)


def current_cause() -> str | None:
    """The units mismatch :func:`units_cause` holds, or None."""
    return _CAUSE.get()
