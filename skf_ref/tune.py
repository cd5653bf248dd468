"""Priors chosen by the data: PM-SNR and EP-SNR by marginal likelihood (docs/model.md §4).

The Kalman filter gives the marginal likelihood of the data, ``log p(Y | theta0, q)``, as
the sum of its innovations' log densities. In the singular basis of the whitened lead field
it needs only the rank-r recursions (:class:`skf_ref.singular.SpectralBasis`): one SVD,
then a few hundred microseconds per prior pair at the paper's scale, with no n-dimensional
array at all, so a whole grid of priors costs little more than one reconstruction.
"""

from dataclasses import dataclass

import numpy as np

from .checks import InputError, check_choice, check_db, check_int, check_real, describe
from .model import StateSpaceModel
from .priors import (
    CONVENTIONS,
    evolution_variance,
    lead_field_amplitude,
    prior_variance,
    priors_from_snr,
)
from .singular import SpectralBasis, whitener

__all__ = ["AUTO_RANGE_DB", "TuneResult", "choose_priors", "tune"]

#: The SNRs searched for ``"auto"`` (dB): the span of the paper's finer map.
AUTO_RANGE_DB = (-20.0, 40.0)


@dataclass(frozen=True, eq=False)
class TuneResult:
    """The priors of largest marginal likelihood, and the likelihood over the grid.

    Attributes
    ----------
    pm_snr_db, ep_snr_db : float
        The chosen SNRs (dB).
    theta0, q : float
        The priors they give (docs/model.md §4), in the units of ``L`` and ``Y`` (for the
        "toolbox" convention, of ``Y / max|Y|``).
    log_likelihood : float
        Its value there: ``reconstruct(...).log_likelihood`` at ``theta0``, ``q``.
    landscape : pandas.DataFrame
        The coarse grid: columns ``pm_snr_db``, ``ep_snr_db``, ``theta0``, ``q``,
        ``log_likelihood``.
    convention : str
        The amplitude convention of the SNRs.
    """

    pm_snr_db: float
    ep_snr_db: float
    theta0: float
    q: float
    log_likelihood: float
    landscape: object
    convention: str

    def __repr__(self):
        return (
            f"<TuneResult | PM-SNR {self.pm_snr_db:.2f} dB, EP-SNR {self.ep_snr_db:.2f} dB, "
            f"log-likelihood {self.log_likelihood:.6g}>"
        )


def _search_range(name, value):
    """A fixed SNR (one number), a search range (lo, hi), lo < hi, or "auto"."""
    if isinstance(value, str) and value == "auto":
        return AUTO_RANGE_DB
    if np.ndim(value) == 0:
        return (check_db(name, value),) * 2
    if isinstance(value, str) or len(value) != 2:
        raise InputError(f"{name} must be a number or a range (lo, hi), got {describe(value)}")
    low, high = (check_db(f"{name}[{i}]", v) for i, v in enumerate(value))
    if not low < high:
        raise InputError(
            f"{name} must be a range (lo, hi) with lo < hi, got ({low:g}, {high:g}); give one "
            "number to fix it"
        )
    return low, high


def tune(
    L,
    Y,
    *,
    noise_std=None,
    noise_cov=None,
    pm_snr_db=AUTO_RANGE_DB,
    ep_snr_db=AUTO_RANGE_DB,
    transition=1.0,
    convention="gain",
    grid=13,
):
    """PM-SNR and EP-SNR that maximize the marginal likelihood of the data.

    A coarse grid of ``grid`` values per searched SNR, then a bounded refinement
    (``scipy.optimize.minimize``, L-BFGS-B, from the best cell). The likelihood judges the
    model ``y = L x + r`` with its priors; it cannot choose the standardization exponent or
    the smoother: they change the estimate shown, not the model, and leave the likelihood
    unchanged.

    Parameters
    ----------
    L : array_like, shape (n_channels, n_sources)
    Y : array_like, shape (n_channels, n_times)
    noise_std : float, optional
    noise_cov : array_like, shape (n_channels, n_channels), optional
        Give exactly one, as for :func:`skf_ref.reconstruct`.
    pm_snr_db, ep_snr_db : (float, float) or float or "auto"
        The range searched, in dB; a single number fixes that SNR; ``"auto"`` is the
        default range, :data:`AUTO_RANGE_DB`.
    transition : float
        ``A = transition I``.
    convention : {"gain", "toolbox"}
        "gain" (default): SNRs of the whitened lead field, unit free. "toolbox": as the
        toolbox (docs/model.md §4): needs ``noise_std``; the data are divided by ``max|Y|``
        and ``theta0``, ``q`` and the likelihood are those of ``Y / max|Y|``.
    grid : int
        Values per searched SNR on the coarse grid, >= 2.

    Returns
    -------
    TuneResult

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> L = rng.standard_normal((8, 20))
    >>> X = np.cumsum(0.3 * rng.standard_normal((20, 50)), axis=1)
    >>> result = tune(L, L @ X + 0.5 * rng.standard_normal((8, 50)), noise_std=0.5, grid=7)
    >>> result.landscape.shape
    (49, 5)
    >>> bool(result.log_likelihood >= result.landscape["log_likelihood"].max())
    True
    """
    check_choice("convention", convention, CONVENTIONS)
    grid = check_int("grid", grid, minimum=2)
    ranges = [_search_range("pm_snr_db", pm_snr_db), _search_range("ep_snr_db", ep_snr_db)]
    if np.ndim(transition) != 0:
        raise InputError(f"transition must be a scalar for tune, got {describe(transition)}")
    model = StateSpaceModel.create(
        L, noise_std=noise_std, noise_cov=noise_cov, theta0=1.0, q=1.0, transition=transition
    )
    Y = model.check_data(Y)
    if convention == "toolbox":
        if noise_std is None:
            raise InputError("convention='toolbox' needs noise_std (relative to max|Y|)")
        scale = np.max(np.abs(Y))
        relative_std = check_real("noise_std", noise_std) / scale
        model = StateSpaceModel.create(
            model.L, noise_std=relative_std, theta0=1.0, q=1.0, transition=transition
        )
        Y = Y / scale
    basis = SpectralBasis(model.L, model.R)
    priors = _priors(model, basis, convention, Y.shape[1])
    a = float(model.transition)

    def log_likelihoods(points):
        theta0, q = priors(points)
        return basis.log_likelihood(Y, theta0, q, a)

    axes = [np.linspace(low, high, grid) if low < high else [low] for low, high in ranges]
    cells = np.array(np.meshgrid(*axes, indexing="ij")).reshape(2, -1).T
    values = log_likelihoods(cells)
    best = _refine(log_likelihoods, cells[np.argmax(values)], ranges)
    best_value = float(log_likelihoods(best[None])[0])
    if best_value < values.max():  # the refinement did not improve on the grid
        best, best_value = cells[np.argmax(values)], float(values.max())
    return _result(cells, values, priors, best, best_value, convention)


def _priors(model, basis, convention, n_steps):
    """(PM, EP) dB pairs (K, 2) -> theta0 (K,), q (K,), vectorized over the pairs."""
    if convention == "gain":
        # the whitened lead field with noise std 1: the same as priors_from_snr(L, sigma)
        amplitude = lead_field_amplitude(basis.whiten(model.L), "gain")
        sigma = 1.0
    else:
        amplitude = lead_field_amplitude(model.L, "toolbox")
        sigma = float(np.sqrt(model.R[0, 0]))
        snr_db = -20 * np.log10(sigma)
    unit_theta0 = prior_variance(0.0, sigma, amplitude, model.n_sources)
    unit_q = evolution_variance(0.0, 1.0, n_steps)

    def priors(points):
        pm, ep = np.asarray(points, dtype=float).T
        if convention == "toolbox":
            pm = np.minimum(pm, snr_db - 1.0)  # the toolbox's clamp
        theta0 = unit_theta0 * 10 ** (pm / 10)
        return theta0, unit_q * 10 ** (ep / 10) * theta0

    return priors


def _refine(log_likelihoods, start, ranges, step_db=1e-3):
    """L-BFGS-B on -log p over the searched SNRs, gradients by one batched evaluation."""
    from scipy.optimize import minimize

    free = [i for i, (low, high) in enumerate(ranges) if low < high]
    if not free:
        return np.asarray(start, dtype=float)

    def objective(x):
        point = np.asarray(start, dtype=float).copy()
        point[free] = x
        shifted = np.repeat(point[None], 1 + len(free), axis=0)
        for k, i in enumerate(free):
            shifted[1 + k, i] += step_db
        values = -log_likelihoods(shifted)
        return values[0], (values[1:] - values[0]) / step_db

    bounds = [ranges[i] for i in free]
    solution = minimize(objective, start[free], jac=True, method="L-BFGS-B", bounds=bounds)
    best = np.asarray(start, dtype=float).copy()
    best[free] = solution.x
    return best


def _result(cells, values, priors, best, best_value, convention):
    import pandas as pd

    theta0, q = priors(cells)
    landscape = pd.DataFrame(
        dict(
            pm_snr_db=cells[:, 0],
            ep_snr_db=cells[:, 1],
            theta0=theta0,
            q=q,
            log_likelihood=values,
        )
    )
    (best_theta0,), (best_q,) = priors(best[None])
    return TuneResult(
        pm_snr_db=float(best[0]),
        ep_snr_db=float(best[1]),
        theta0=float(best_theta0),
        q=float(best_q),
        log_likelihood=best_value,
        landscape=landscape,
        convention=convention,
    )


def choose_priors(
    L, Y, *, noise_std=None, noise_cov=None, pm_snr_db, ep_snr_db, convention="gain"
):
    """``theta0, q`` from two SNRs, either of which may be ``"auto"``, and how they were chosen.

    The SNRs are those of the whitened lead field (docs/model.md §4): with ``noise_std``,
    exactly :func:`skf_ref.priors_from_snr`.

    Parameters
    ----------
    L : array_like, shape (n_channels, n_sources)
    Y : array_like, shape (n_channels, n_times)
    noise_std : float, optional
    noise_cov : array_like, shape (n_channels, n_channels), optional
        Give exactly one.
    pm_snr_db, ep_snr_db : float or "auto"
    convention : {"gain", "toolbox"}
        "toolbox" needs ``noise_std``.

    Returns
    -------
    theta0, q : float
    tuning : TuneResult or None
        None when both SNRs were given.
    """
    if "auto" in (pm_snr_db, ep_snr_db):
        result = tune(
            L,
            Y,
            noise_std=noise_std,
            noise_cov=noise_cov,
            pm_snr_db=pm_snr_db,
            ep_snr_db=ep_snr_db,
            convention=convention,
        )
        return result.theta0, result.q, result
    n_times = np.shape(Y)[-1]
    if noise_cov is None:
        return *priors_from_snr(L, noise_std, pm_snr_db, ep_snr_db, n_times, convention), None
    if convention != "gain":
        raise InputError(f"convention={convention!r} needs noise_std, not noise_cov")
    model = StateSpaceModel.create(L, noise_cov=noise_cov, theta0=1.0, q=1.0)
    whitened = whitener(model.R)[0](model.L)
    return *priors_from_snr(whitened, 1.0, pm_snr_db, ep_snr_db, n_times), None
