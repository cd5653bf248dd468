"""Sweep grids: the axes, the paper's grid, and the check every grid passes before work."""

from collections.abc import Mapping
from typing import Any

from ..._utils.checks import (
    InputError,
    InputTypeError,
    check_choice,
    check_db,
    check_int,
    check_real,
    describe,
)
from ...method._settings import SMOOTHERS, check_smoother

__all__ = ["AXES", "GROUP", "KEY", "check_grid", "paper_grid", "row_key", "smoother_label"]

#: Axes of a grid; every run is one point of their product.
AXES = ("snr_db", "ep_snr_db", "pm_snr_db", "exponent", "smoother", "seed")
#: Axes that fix the noise level and the priors: one prepared model serves a group.
GROUP = ("snr_db", "ep_snr_db", "pm_snr_db")
#: Columns that identify a run in a results file.
KEY = ("n_positions", "montage", *AXES)
#: Largest |dB| of a noise level or prior SNR: 10**(dB/10) stays far from overflow.


def paper_grid(seeds: int = 10) -> dict[str, list[Any]]:
    """The paper's grid: 10/20/30 dB; EP, PM in {0, 20}; four exponents; three smoothers.

    Parameters
    ----------
    seeds : int
        Number of noise seeds, ``0 .. seeds - 1``.

    Returns
    -------
    dict
        Axis name -> its values (``AXES``), 1440 runs with 10 seeds.

    Examples
    --------
    >>> grid = paper_grid(seeds=2)
    >>> grid["exponent"], grid["smoother"], grid["seed"]
    ([0.5, 1.0, 1.25, 1.5], [None, 'rts-standardized', 'rts-state'], [0, 1])
    """
    count = check_int("seeds", seeds, minimum=0)
    return dict(
        snr_db=[10.0, 20.0, 30.0],
        ep_snr_db=[0.0, 20.0],
        pm_snr_db=[0.0, 20.0],
        exponent=[0.5, 1.0, 1.25, 1.5],
        smoother=[None, "rts-standardized", "rts-state"],  # the three the study compares
        seed=list(range(count)),
    )


def check_grid(grid: Mapping[str, Any]) -> dict[str, list[Any]]:
    """Validate a grid before any work starts; returns it with normalized values.

    Parameters
    ----------
    grid : mapping
        Axis name -> non-empty list of values, for every name in ``AXES``.

    Returns
    -------
    dict
        Axis name -> its values, checked and normalized (``"none"`` as None, numbers as
        float, seeds as int), in the order of ``AXES``.

    Examples
    --------
    >>> check_grid(dict(paper_grid(1), exponent=[-1.0]))
    Traceback (most recent call last):
    ...
    skf_ref._utils.checks.InputError: grid['exponent'] values must be >= 0, got -1.0
    """
    if not hasattr(grid, "keys"):
        raise InputTypeError(f"grid must be a mapping of axis -> values, got {describe(grid)}")
    unknown = set(grid) - set(AXES)
    missing = set(AXES) - set(grid)
    if unknown or missing:
        raise InputError(
            f"grid must have exactly the axes {list(AXES)}; "
            f"missing {sorted(missing)}, unknown {sorted(unknown)}"
        )
    out = {}
    for axis in AXES:
        given = grid[axis]
        if isinstance(given, (str, bytes)) or not hasattr(given, "__iter__"):
            given = [given]
        values = [_check_value(axis, value) for value in given]
        if not values:
            raise InputError(f"grid[{axis!r}] is empty: give at least one value")
        if len(set(values)) != len(values):
            raise InputError(f"grid[{axis!r}] has repeated values: {values}")
        out[axis] = values
    return out


def _check_value(axis: str, value: Any) -> Any:
    name = f"grid[{axis!r}] values"
    if axis == "smoother":
        return check_smoother(check_choice(name, value, (*SMOOTHERS, "none")))
    if axis == "seed":
        return check_int(name, value, minimum=0)
    if axis == "exponent":
        return check_real(name, value, nonnegative=True)
    return check_db(name, value)


def smoother_label(smoother: str | None) -> str:
    """The smoother as written in a results file: ``"none"`` for None.

    Parameters
    ----------
    smoother : str or None
        A smoother of :func:`skf_ref.reconstruct`.

    Returns
    -------
    str
        Its name, or ``"none"``.
    """
    return "none" if smoother is None else smoother


def row_key(row: Mapping[str, Any]) -> tuple[Any, ...]:
    """The tuple that identifies a run (the :data:`KEY` columns, normalized).

    Parameters
    ----------
    row : mapping
        A results row, with every :data:`KEY` column.

    Returns
    -------
    tuple
        Its :data:`KEY` values: the montage as given, the smoother's label, numbers as float.
    """
    return tuple(
        smoother_label(row[k]) if k == "smoother" else row[k] if k == "montage" else float(row[k])
        for k in KEY
    )
