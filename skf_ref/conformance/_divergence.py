"""Where an implementation first leaves the tolerance: the quantity, its equation, step and row.

The variables given (outputs and intermediates, :mod:`skf_ref.conformance._intermediates`)
are taken in the order the equations produce them, step by step; the first whose
difference at a step exceeds the tolerance is the *first divergence*. Everything given
that the equations produce before it agrees, so the mistake lies in it or in a quantity
computed before it that was not given: those are listed (``not_given``), for the next run
to give.

Each difference is relative to the quantity's own scale
(:func:`skf_ref.conformance._distances.relative_steps`).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._distances import relative_steps
from ._intermediates import Variable, production_order, variables

__all__ = ["Divergence", "first_divergence", "upstream"]


@dataclass(frozen=True)
class Divergence:
    """The first variable given, in the order of the equations, that leaves the tolerance.

    Attributes
    ----------
    quantity : str
        One of :data:`~skf_ref.conformance._intermediates.QUANTITIES`.
    output : str
        The variable (``P_filt``, ``z``, ...).
    equation : str
        Where docs/model.md states it.
    step : int or None
        The step, counting from 1; None for the priors and the log-likelihood.
    source : int or None
        The row of the largest difference at that step, counting from 1: a source, or a
        channel for ``S``; None for a scalar.
    difference : float
        The difference at that step, relative to the quantity's scale.
    not_given : tuple of str
        The variables it is computed from, directly or through others not given, that were
        not given: where the mistake may lie, besides in ``output`` itself.
    """

    quantity: str
    output: str
    equation: str
    step: int | None
    source: int | None
    difference: float
    not_given: tuple

    def to_dict(self) -> dict[str, Any]:
        """dict : The fields, as plain Python values."""
        return {
            "quantity": self.quantity,
            "output": self.output,
            "equation": self.equation,
            "step": self.step,
            "source": self.source,
            "difference": self.difference,
            "not_given": list(self.not_given),
        }

    def report(self) -> list[str]:
        """The divergence in words, a line or two for the report."""
        where = "" if self.step is None else f" at step {self.step}"
        where += "" if self.source is None else f", row {self.source}"
        named = (
            self.quantity if self.output == self.quantity else f"{self.quantity} ({self.output})"
        )
        lines = [
            f"First divergence: {named}{where}, off by {self.difference:.1e}: {self.equation}."
        ]
        if self.not_given:
            lines.append(
                "Everything given before it agrees; computed before it and not given: "
                f"{', '.join(self.not_given)}. The mistake is in {self.output} or in one of "
                "those: give them to tell which (docs/conformance.md, intermediate outputs)."
            )
        else:
            lines.append(
                f"Everything it is computed from was given and agrees: the mistake is in "
                f"{self.output} itself."
            )
        return lines


def upstream(name: str, defined: Mapping[str, Variable], given: Collection[str] = ()) -> list[str]:
    """Every variable ``name`` is computed from, directly or not, in production order.

    The search stops at the variables ``given``: what they are computed from reaches
    ``name`` only through them.

    Examples
    --------
    >>> from skf_ref.conformance._intermediates import variables
    >>> upstream("weights", variables(None))
    ['theta0', 'q', 'P_pred', 'S', 'K', 'P_filt', 'w']
    >>> upstream("w", variables(None), given=["P_pred", "K"])
    ['P_pred', 'S', 'K']
    """
    found: set[str] = set()
    todo = list(defined[name].inputs)
    while todo:
        here = todo.pop()
        if here in defined and here not in found:
            found.add(here)
            todo += [] if here in given else defined[here].inputs
    return [other for other in defined if other in found and other != name]


def first_divergence(
    given: Mapping[str, Any],
    expected: Mapping[str, Any],
    scales: Mapping[str, float],
    smoother: str | None,
    n_times: int,
    tolerance: float,
) -> Divergence | None:
    """The first variable given that leaves ``tolerance``, in the order of the equations.

    Parameters
    ----------
    given : mapping
        Their variables by name (outputs as compared: a transposed one transposed back),
        any of those :func:`~skf_ref.conformance._intermediates.variables` defines for the
        smoother; others are left out.
    expected : mapping
        The expected value of each.
    scales : mapping
        Each variable's own scale.
    smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}
    n_times : int
    tolerance : float

    Returns
    -------
    Divergence or None
        None when every variable given agrees at every step.
    """
    defined = variables(smoother)
    steps = {
        name: relative_steps(
            given[name],
            expected[name],
            scales[name],
            per_step=defined[name].stage not in ("once", "end"),
        )
        for name in given
        if name in defined
    }
    for name, step in production_order(smoother, n_times):
        if name not in steps:
            continue
        differences, rows = steps[name]
        index = 0 if step is None else step - 1
        if not differences[index] > tolerance:
            continue
        variable = defined[name]
        return Divergence(
            quantity=variable.quantity,
            output=name,
            equation=variable.equation,
            step=step,
            source=None if np.ndim(given[name]) == 0 else int(rows[index]) + 1,
            difference=float(differences[index]),
            not_given=tuple(n for n in upstream(name, defined, given) if n not in given),
        )
    return None
