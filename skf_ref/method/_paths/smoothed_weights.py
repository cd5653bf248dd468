r"""The smoothed state's own variance in the singular basis: ``"rts-smoothed-weights"``.

docs/model.md §3 ("A smoother standardized by its own variance") derives it. With
``A = a I``, ``Q = q I``, ``P_0 = theta0 I`` the prior covariance of ``x_t`` is
``sigma_t I`` (``sigma_0 = theta0``, ``sigma_t = a^2 sigma_{t-1} + q``), nothing off
span ``V`` is ever updated or smoothed, and

    Sigma_t^{-1/2} (Sigma_t - P^s_t) Sigma_t^{-1/2} = V Diag(omega^s_t) V^T,
    omega^s_t = (sigma_t - p^s_t) / sigma_t,
    Sigma_t^{-1/2} x^s_t = V xi^s_t / sigma_t^(1/2),

the filter's forms (``(V o V) omega`` for the column weights, ``V_i Diag(omega) V_i^T``
for a position's block) with another ``omega`` and another whitening. ``sigma_t - p^s_t``
is a difference of nearly equal numbers for components the sensors see weakly; it is
computed as a sum of nonnegative terms, ``omega^s_t = epsilon_t + h_t / sigma_t`` with

    g_t = p_{t|t-1} - p_{t|t} = omega_t p_{t|t-1}          (0 at a missing step)
    epsilon_0 = 0,  epsilon_{t+1} = a beta_t (epsilon_t + g_t / sigma_t)
    h_{T-1} = g_{T-1},  h_t = g_t + gamma_t^2 h_{t+1}

(``epsilon_t = (sigma_t - p_{t|t-1}) / sigma_t``, ``h_t = p_{t|t-1} - p^s_t``;
``a beta_t = a^2 sigma_t / sigma_{t+1}`` and ``gamma_t`` are the smoother's gains of
:class:`~.recursions.Recursions`). ``1 / sigma_t`` is carried rather than ``sigma_t``, so
that nothing overflows when ``|a| > 1``. With ``a = 1`` ``sigma_t`` grows at every step:
these weights never settle, and every step has its own.

With ``|a| < 1`` (the AR(1) prior) they settle inside a long recording: the filter's
recursion from the start, the smoother's from the end. Where every component stays within
``STEADY_RTOL / 2`` of its value in the middle of the recording (the steady state's rule,
``skf_ref.method._paths.recursions``), :func:`interior` holds that value, and
:class:`HeldInterior` standardizes those steps by one product, ``z_t = (F V) u_t``, as the
filter's steady state does; only the steps at either end have weights (or blocks, and
their powers) of their own.
"""

from typing import Any

import numpy as np
from numpy.typing import NDArray

from .recursions import STEADY_RTOL, Recursions, recurrence

__all__ = ["HeldInterior", "interior", "inverse_prior_variance", "smoothed_weights"]

#: Held steps below which the weights are not worth holding (one chunk of positions' steps).
MIN_HELD = 128

_Array = NDArray[np.float64]


def inverse_prior_variance(a: float, q: float, theta0: float, n_times: int) -> _Array:
    """``1 / sigma_t`` of the steps t = 1 .. T (rows 0 .. T-1), the prior variance of ``x_t``.

    ``sigma_1 = a^2 theta0 + q`` and ``1 / sigma_{t+1} = (1 / sigma_t) / (a^2 + q / sigma_t)``:
    no overflow, an underflow to 0 at worst.

    Examples
    --------
    >>> inverse_prior_variance(1.0, 0.5, 1.0, 3).tolist()
    [0.6666666666666666, 0.5, 0.4]
    """
    out = np.empty(n_times)
    inverse = 1.0 / (a**2 * theta0 + q)
    for t in range(n_times):
        out[t] = inverse
        inverse = inverse / (a**2 + q * inverse)
    return out


def smoothed_weights(recursions: Recursions, q: float, theta0: float) -> tuple[_Array, _Array]:
    """``omega^s_t`` of every step and ``1 / sigma_t`` (module docstring).

    Parameters
    ----------
    recursions : Recursions
        The covariance recursion of the run (scalar priors), missing steps included.
    q, theta0 : float
        ``Q = q I``, ``P_0 = theta0 I``.

    Returns
    -------
    omega : ndarray, shape (n_times, r)
        The raw smoothed weights are ``(V o V) omega_t``; a position's block is
        ``V_i Diag(omega_t) V_i^T``.
    inverse_sigma : ndarray, shape (n_times,)
        ``1 / sigma_t``: ``Sigma_t^{-1/2} x^s_t = V xi^s_t inverse_sigma_t^(1/2)``.
    """
    T, a = recursions.n_times, recursions.a
    every = slice(0, T)
    p = recursions.expand(recursions.p_pred, every)
    omega = recursions.expand(recursions.omega, every)  # NaN at a missing step
    # g_t = p_{t|t-1} - p_{t|t} = s^2 p^2 / (s^2 p + 1): no update at a missing step
    g = np.where(recursions.missing[:, None], 0.0, np.nan_to_num(omega) * p)
    inverse_sigma = inverse_prior_variance(a, q, theta0, T)
    gamma, beta = recursions.gains
    epsilon = np.zeros_like(p)
    if T > 1:
        # epsilon_{t+1} = a beta_t (epsilon_t + g_t / sigma_t), epsilon_0 = 0
        decay = np.broadcast_to((a * beta)[:, None], (T - 1, p.shape[1]))
        recurrence(decay, decay * g[:-1] * inverse_sigma[:-1, None], out=epsilon[1:])
    # h_t = g_t + gamma_t^2 h_{t+1}, h_{T-1} = g_{T-1}
    h = g.copy()
    if T > 1:
        steps = np.minimum(np.arange(T - 1), len(gamma) - 1)  # the held gain past the stored
        recurrence(gamma[steps] ** 2, g[:-1], start=g[-1], out=h[:-1], reverse=True)
    return epsilon + h * inverse_sigma[:, None], inverse_sigma


def interior(omega: _Array) -> tuple[int, int] | None:
    """The steps ``first:stop`` (around the middle of the recording) where every component of
    ``omega`` (n_times, r) stays within ``STEADY_RTOL / 2`` of its value at the middle step,
    or None (fewer than :data:`MIN_HELD` such steps, or a missing step in the middle).

    Examples
    --------
    >>> omega = np.ones((400, 2)); omega[:50] = 2.0; omega[-10:] = 3.0
    >>> interior(omega)
    (50, 390)
    """
    middle = len(omega) // 2
    target = omega[middle]
    with np.errstate(invalid="ignore"):
        close = (np.abs(omega - target) <= STEADY_RTOL / 2 * target).all(axis=1)
    if not close[middle]:
        return None
    first = middle - int(np.argmin(close[middle::-1])) + 1 if not close[: middle + 1].all() else 0
    after = close[middle:]
    stop = middle + int(np.argmin(after)) if not after.all() else len(omega)
    return (first, stop) if stop - first >= MIN_HELD else None


class HeldInterior:
    """A standardization by weights held on the steps ``first:stop`` (:func:`interior`),
    their own at the steps before and after: three standardizations of the kind given
    (``Standardization`` or ``BlockStandardization``), each over its own steps, the middle
    one held from its first step on.

    Parameters
    ----------
    kind : type
        ``Standardization`` or ``BlockStandardization``.
    V : ndarray, shape (n_sources, r)
    omega : ndarray, shape (n_times, r)
        Every step's weights (``omega^s``).
    held : (int, int)
        ``first, stop``: the steps held at ``omega`` of the middle step (within
        ``STEADY_RTOL / 2`` of which every one of them is).
    exponent : float
    """

    def __init__(
        self, kind: Any, V: _Array, omega: _Array, held: tuple[int, int], exponent: float
    ) -> None:
        first, stop = held
        T = len(omega)
        self.align, self.exponent, self.n_times = kind.align, exponent, T
        self.held_steps = held
        parts = []  # (first step, standardization of its steps)
        if first > 0:  # every step its own
            parts.append((0, kind(V, omega[:first], first, first, exponent)))
        middle = T // 2
        parts.append((first, kind(V, omega[middle : middle + 1], 0, stop - first, exponent)))
        if stop < T:
            parts.append((stop, kind(V, omega[stop:], T - stop, T - stop, exponent)))
        self.parts = parts

    @property
    def applications(self) -> int:
        """int : Data sets this standardization served (each part's count)."""
        return self.parts[0][1].applications

    @applications.setter
    def applications(self, value: int) -> None:
        for _, part in self.parts:
            part.applications = value

    @property
    def kept(self) -> bool:
        """bool : Whether the weights of the steps not held are kept."""
        return any(part.kept for _, part in self.parts)

    def prepare(self) -> None:
        """Each part's shared work, in the calling thread."""
        for _, part in self.parts:
            part.prepare()

    def standardized(self, u: _Array, rows: slice, times: slice, out: _Array) -> _Array:
        """``z_t`` of ``rows`` at ``times`` into ``out`` (n_rows, n_steps), each part on its
        own steps, for whitened coordinates ``u`` (n_times, r)."""
        for start, part in self.parts:
            stop = start + part.n_times
            first, last = max(times.start, start), min(times.stop, stop)
            if first < last:
                where = out[:, first - times.start : last - times.start]
                part.standardized(u[start:stop], rows, slice(first - start, last - start), where)
        return out
