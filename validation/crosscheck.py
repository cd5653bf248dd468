"""Cross-check the computational paths of ``skf_ref.reconstruct`` against the dense oracle.

Run from the repository root::

    python -m validation.crosscheck                 # every path in PATHS
    python -m validation.crosscheck --paths filterpy

Each path in :data:`PATHS` reconstructs a grid of seeded random problems, and its result is
compared with that of the reference path :data:`REFERENCE` (``skf_ref/method/_paths/dense.py``, the
readable statement of the algorithm). The grid crosses

- orientation: fixed (one column per position) and free (three, MNE's order);
- lead field reference: none (full rank) and average (channel mean removed, rank
  ``n_channels - 1``);
- exponent alpha in {0.5, 1, 1.25, 1.5};
- smoother in {None, "rts-standardized", "rts-state"};
- noise given as ``noise_std`` (``R = sigma**2 I``) and as a full random SPD ``noise_cov``;

with a random walk (``A = I``) and isotropic priors from :func:`skf_ref.priors_from_snr`. On
top of it, one general linear-Gaussian model (non-identity transition, full SPD ``theta0``
and ``q``) is run with each smoother. Scales are realistic: lead field entries of order 1e2,
noise of order 1e-6, so a relative comparison is not flattered by numbers of order one.

For each quantity the metric is the largest relative difference ``max|a - b| / max|b|``
(``b`` the reference); for the log-likelihood ``|a - b| / |b|``. The script prints a markdown
table, one row per problem and path, and exits with status 1 if any difference exceeds
:data:`TOLERANCE` or if no comparison was made at all (every row skipped: a run that compared
nothing has shown nothing, so it cannot pass).

A path that covers only part of the model class is compared only on the problems
:func:`qualifies` admits for it; the others are listed as skipped.
"""

import argparse
import itertools
import sys
import time
from dataclasses import dataclass

import numpy as np

from skf_ref import priors_from_snr, reconstruct
from skf_ref.method._settings import PATHS as ALL_PATHS

__all__ = [
    "TOLERANCE",
    "REFERENCE",
    "PATHS",
    "QUANTITIES",
    "Problem",
    "make_problems",
    "qualifies",
    "relative_difference",
    "crosscheck",
    "worst",
    "passed",
    "format_table",
    "main",
]

# The paths differ only in rounding: filterpy inverts S explicitly and updates P in Joseph
# form, the dense oracle solves with a Cholesky factor and updates P in the short form. On
# these problems (S and P conditioned to well under 1e6) rounding stays far below 1e-10,
# while an algebraic slip (a transpose, an index off by one step, the wrong covariance in
# the weights) shows up at 1e-3 or more. 1e-8 separates the two with room on both sides.
TOLERANCE = 1e-8

#: The path every other path is compared with.
REFERENCE = "dense"
#: The paths compared with the reference; extend this tuple to check a new path.
PATHS = ("filterpy", "spectral")
#: Compared quantities: fields of :class:`skf_ref.Reconstruction`.
QUANTITIES = ("z", "x", "z_filtered", "x_filtered", "weights", "log_likelihood")

SEED = 2025
N_CHANNELS = 12
N_POSITIONS = 10
N_TIMES = 9
LEAD_FIELD_SCALE = 1e2  # magnitude of lead field entries (data units per source unit)
NOISE_STD = 1e-6  # noise standard deviation in data units
PM_SNR_DB = 0.0
EP_SNR_DB = 20.0

ORIENTATIONS = {"fixed": 1, "free": 3}  # columns per position
REFERENCES = ("none", "average")
EXPONENTS = (0.5, 1.0, 1.25, 1.5)
SMOOTHERS = (None, "rts-standardized", "rts-state")
NOISE_MODELS = ("noise_std", "noise_cov")


@dataclass(frozen=True, eq=False)
class Problem:
    """One seeded model and data set, reconstructed by every path.

    Attributes
    ----------
    name : str
        Short label for the table.
    labels : dict
        The grid coordinates: ``orientation``, ``reference``, ``noise``, ``exponent``,
        ``smoother``, ``transition`` (``"identity"`` or ``"general"``).
    L : ndarray, shape (n_channels, n_sources)
    Y : ndarray, shape (n_channels, n_times)
    kwargs : dict
        Keyword arguments of :func:`skf_ref.reconstruct` other than ``L``, ``Y`` and
        ``path``.
    """

    name: str
    labels: dict
    L: np.ndarray
    Y: np.ndarray
    kwargs: dict


def _lead_field(rng, components, reference):
    L = LEAD_FIELD_SCALE * rng.standard_normal((N_CHANNELS, N_POSITIONS * components))
    if reference == "average":
        # Average reference: remove the channel mean of every column; rank n_channels - 1.
        L = L - L.mean(axis=0)
    return L


def _random_spd(rng, n, scale):
    """``scale * (B B^T / n + I / 2)``: a full SPD matrix of mean eigenvalue ~ 1.5 scale."""
    B = rng.standard_normal((n, n))
    return scale * (B @ B.T / n + 0.5 * np.eye(n))


def _simulate(rng, L, R, A, Q, P0, reference):
    """Data drawn from the model itself: ``x_t = A x_{t-1} + q_t``, ``y_t = L x_t + r_t``."""
    n = L.shape[1]
    x = np.linalg.cholesky(P0) @ rng.standard_normal(n)
    Q_chol, R_chol = np.linalg.cholesky(Q), np.linalg.cholesky(R)
    Y = np.empty((N_CHANNELS, N_TIMES))
    for t in range(N_TIMES):
        x = A @ x + Q_chol @ rng.standard_normal(n)
        Y[:, t] = L @ x + R_chol @ rng.standard_normal(N_CHANNELS)
    if reference == "average":
        Y = Y - Y.mean(axis=0)
    return Y


def _grid_problem(index, orientation, reference, exponent, smoother, noise):
    rng = np.random.default_rng([SEED, index])
    L = _lead_field(rng, ORIENTATIONS[orientation], reference)
    n = L.shape[1]
    if noise == "noise_std":
        R, noise_kwargs = NOISE_STD**2 * np.eye(N_CHANNELS), {"noise_std": NOISE_STD}
    else:
        R = _random_spd(rng, N_CHANNELS, NOISE_STD**2)
        noise_kwargs = {"noise_cov": R}
    sigma = float(np.sqrt(np.mean(np.diag(R))))
    theta0, q = priors_from_snr(L, sigma, PM_SNR_DB, EP_SNR_DB, N_TIMES)
    Y = _simulate(rng, L, R, np.eye(n), q * np.eye(n), theta0 * np.eye(n), reference)
    labels = {
        "orientation": orientation,
        "reference": reference,
        "noise": noise,
        "exponent": exponent,
        "smoother": smoother,
        "transition": "identity",
    }
    name = f"{orientation} {reference}-ref {noise} a={exponent:g} {smoother or 'unsmoothed'}"
    kwargs = dict(noise_kwargs, theta0=theta0, q=q, exponent=exponent, smoother=smoother)
    return Problem(name, labels, L, Y, kwargs)


def _general_problem(index, smoother):
    """Free orientation, average reference, full SPD R, P_0, Q and a non-identity A."""
    rng = np.random.default_rng([SEED, index])
    L = _lead_field(rng, ORIENTATIONS["free"], "average")
    n = L.shape[1]
    R = _random_spd(rng, N_CHANNELS, NOISE_STD**2)
    theta0, q = priors_from_snr(L, NOISE_STD, PM_SNR_DB, EP_SNR_DB, N_TIMES)
    P0, Q = _random_spd(rng, n, theta0), _random_spd(rng, n, q)
    # A contraction with a rotating part: spectral norm at most 0.8 + 0.15 < 1.
    G = rng.standard_normal((n, n))
    A = 0.8 * np.eye(n) + 0.15 * G / np.linalg.norm(G, 2)
    Y = _simulate(rng, L, R, A, Q, P0, "average")
    labels = {
        "orientation": "free",
        "reference": "average",
        "noise": "noise_cov",
        "exponent": 1.25,
        "smoother": smoother,
        "transition": "general",
    }
    kwargs = {
        "noise_cov": R,
        "theta0": P0,
        "q": Q,
        "exponent": 1.25,
        "smoother": smoother,
        "transition": A,
    }
    name = f"general A, P0, Q, R a=1.25 {smoother or 'unsmoothed'}"
    return Problem(name, labels, L, Y, kwargs)


def make_problems():
    """The seeded problems of the cross-check.

    Returns
    -------
    list of Problem
        The full grid (orientation x reference x exponent x smoother x noise model, 96
        problems), then the general linear-Gaussian model once per smoother (3 problems).
    """
    grid = itertools.product(ORIENTATIONS, REFERENCES, EXPONENTS, SMOOTHERS, NOISE_MODELS)
    problems = [_grid_problem(i, *point) for i, point in enumerate(grid)]
    start = len(problems)
    problems += [_general_problem(start + i, s) for i, s in enumerate(SMOOTHERS)]
    return problems


# Paths that handle only part of the model class, with the keyword arguments of reconstruct
# that must be scalars (isotropic: A = a I, P_0 = theta0 I, Q = q I) for them.
_SCALAR_ONLY = {"spectral": ("transition", "theta0", "q")}


def qualifies(path, problem):
    """Whether ``path`` handles ``problem``'s model, so that comparing it is meaningful.

    The hook for paths that cover only part of the model class: :func:`crosscheck` reports
    a comparison as skipped instead of running it when this returns ``False``. The
    ``"spectral"`` path needs a scalar ``transition``, ``theta0`` and ``q``; every other
    path handles every model.

    Parameters
    ----------
    path : str
        A ``path`` of :func:`skf_ref.reconstruct`.
    problem : Problem

    Returns
    -------
    bool
    """
    scalars = _SCALAR_ONLY.get(path, ())
    return all(np.ndim(problem.kwargs.get(name, 1.0)) == 0 for name in scalars)


def relative_difference(a, b):
    """Largest relative difference of ``a`` from the reference ``b``.

    Parameters
    ----------
    a, b : array_like or float
        Same shape; ``b`` is the reference.

    Returns
    -------
    float
        ``max|a - b| / max|b|``, or ``max|a - b|`` when ``b`` is all zero. NaN if either
        holds a NaN.

    Examples
    --------
    >>> relative_difference([1.0, -3.0], [1.0, -4.0])
    0.25
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    difference = np.max(np.abs(a - b))
    scale = np.max(np.abs(b))
    return float(difference / scale if scale > 0 else difference)


def _compare(problem, path, reference):
    row = {"problem": problem.name, "path": path, **problem.labels}
    if not qualifies(path, problem):
        return dict(row, skipped=True, **{q: float("nan") for q in QUANTITIES})
    result = reconstruct(problem.L, problem.Y, path=path, **problem.kwargs)
    differences = {
        q: relative_difference(getattr(result, q), getattr(reference, q)) for q in QUANTITIES
    }
    return dict(row, skipped=False, **differences)


def crosscheck(paths=PATHS, problems=None):
    """Compare every path with the reference on every problem.

    Parameters
    ----------
    paths : sequence of str
        Methods of :func:`skf_ref.reconstruct` to compare with :data:`REFERENCE`.
    problems : list of Problem, optional
        Default :func:`make_problems`.

    Returns
    -------
    list of dict
        One row per problem and path (problem-major): ``problem`` (name), ``path``, the
        grid labels of :class:`Problem`, ``skipped`` (bool) and, for each name in
        :data:`QUANTITIES`, its relative difference from the reference (NaN if skipped).
    """
    problems = make_problems() if problems is None else problems
    rows = []
    for problem in problems:
        reference = reconstruct(problem.L, problem.Y, path=REFERENCE, **problem.kwargs)
        rows += [_compare(problem, path, reference) for path in paths]
    return rows


def worst(rows):
    """Largest difference over the compared (not skipped) rows.

    NaN if any is NaN, and NaN if no row was compared (there is no largest difference).
    """
    values = [row[q] for row in rows if not row["skipped"] for q in QUANTITIES]
    if not values:
        return float("nan")
    return float(np.nan if np.any(np.isnan(values)) else np.max(values))


def passed(rows):
    """Whether at least one row was compared and every difference is within tolerance.

    Parameters
    ----------
    rows : list of dict
        As returned by :func:`crosscheck`.

    Returns
    -------
    bool
        ``False`` when every row was skipped: zero comparisons is a failure, not a pass.
    """
    compared = any(not row["skipped"] for row in rows)
    return compared and worst(rows) <= TOLERANCE


def format_table(rows):
    """The rows of :func:`crosscheck` as a markdown table with a summary line.

    Parameters
    ----------
    rows : list of dict

    Returns
    -------
    str
    """
    header = ["problem", "path", *QUANTITIES]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        if row["skipped"]:
            cells = ["skipped"] * len(QUANTITIES)
        else:
            cells = [f"{row[q]:.1e}" for q in QUANTITIES]
        lines.append("| " + " | ".join([row["problem"], row["path"], *cells]) + " |")
    compared = sum(not row["skipped"] for row in rows)
    value = worst(rows)
    verdict = "PASS" if passed(rows) else "FAIL"
    lines.append("")
    if compared == 0:
        lines.append(
            f"no comparison was made ({len(rows)} problem x path rows, every one skipped): "
            f"{verdict}"
        )
        return "\n".join(lines)
    lines.append(
        f"max relative difference over {compared} compared and {len(rows) - compared} "
        f"skipped problem x path rows: {value:.2e} (tolerance {TOLERANCE:.0e}): {verdict}"
    )
    return "\n".join(lines)


def main(argv=None):
    """Command-line entry point: print the table, return the exit status.

    Parameters
    ----------
    argv : list of str, optional
        Arguments after the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        0 if at least one comparison was made and every difference is within
        :data:`TOLERANCE`, else 1.
    """
    choices = [m for m in ALL_PATHS if m not in ("auto", REFERENCE)]
    parser = argparse.ArgumentParser(
        prog="python -m validation.crosscheck",
        description=f"Compare skf_ref.reconstruct paths with path={REFERENCE!r}.",
    )
    parser.add_argument(
        "--paths", nargs="+", choices=choices, default=list(PATHS), help="paths to compare"
    )
    args = parser.parse_args(argv)
    start = time.perf_counter()
    rows = crosscheck(args.paths)
    print(format_table(rows))
    print(f"({time.perf_counter() - start:.1f} s)")
    return 0 if passed(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
