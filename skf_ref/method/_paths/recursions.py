r"""The spectral path's rank-r recursions, and the steady state they settle into.

In the singular basis of the whitened lead field, ``L~ = U diag(s) V^T``
(``skf_ref.method._paths.spectral`` derives it), the covariances of the paper's model
(``A = a I``, ``Q = q I``, ``P_0 = theta0 I``) are ``r = rank(L)`` numbers a step,
``p_{t|t-1}``, and one scalar on the complement of span V, carried as ``u_t = q / c_t``.
This module holds those recursions, the filtered means and the smoother's backward passes.
The recursions broadcast over leading dimensions of ``theta0``, ``q`` and ``a``: with arrays of
K priors they run K filters at once (how :class:`~.singular_basis.SpectralBasis` evaluates a
grid of priors, and of transitions for the AR(1) prior's time constants).

Steady state
------------
Each component of ``p_{t|t-1}`` follows ``p -> f(p) = a^2 p / (s^2 p + 1) + q``. ``f`` is
increasing, so the sequence is monotone, and for ``q > 0`` (or ``|a| > 1``) it converges to
the positive root ``p_inf`` of ``s^2 p^2 + (1 - a^2 - q s^2) p - q = 0``. Once every
component is within ``STEADY_RTOL / 2`` of ``p_inf`` it stays there (monotone), so from that
step on, ``steady``, it changes by at most :data:`STEADY_RTOL` relative to the end of the
recording: :class:`Recursions` stops there and holds the value, and with it every quantity
that is a function of it: the gains, ``omega = s^2 p / (s^2 p + 1)`` (relative change at
most that of ``p``), ``p^{-1/2}``. The raw weights ``w_t = (V o V) omega_t`` are positive
combinations of ``omega``, so they too stay within :data:`STEADY_RTOL` of their held value,
entry by entry, and ``w^-alpha`` within ``alpha STEADY_RTOL``. The filtered means keep being
computed from the data at every step, with the held gains: a linear recurrence with
constant coefficients (:func:`recurrence`). The complement's ratio ``u_t`` (the smoother's
scalar gain ``beta_t``) falls like ``1/t`` when ``a = 1`` and is never held.

The tests compare held and full recursions on problems long enough to settle: the outputs
agree to 1e-12 relative (tests/test_steady.py).

Missing steps
-------------
At a step without a measurement (docs/model.md §2) the covariance is predicted and not
updated, ``p_{t|t} = p_{t|t-1}``, and the means follow ``xi_t = a xi_{t-1}``; such a step
adds nothing to the log-likelihood and has no weights (``omega`` is NaN there). A gap moves
``p`` away from ``p_inf``, and the observed steps after it converge again, monotonically: the
steady state is looked for only after the last missing step, and every step before it is
stored, ``8 r`` bytes a step per (n_times, r) array (``p_pred``, and ``p_filt``, ``omega``
and the smoother's gains when used). A recording without gaps is held as before.
"""

import functools
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Recursions", "backward", "fixed_point", "recurrence"]

_Array = NDArray[np.float64]

#: Relative change of ``p_{t|t-1}`` over the rest of the recording below which
#: :class:`Recursions` holds it (module docstring): 45 units of double rounding, 10 times
#: the recursion's own rounding noise near its fixed point, so the held value is reached.
STEADY_RTOL = 1e-14
#: Steps of the covariance recursion computed between two checks for the steady state.
_CHECK_STEPS = 32
#: A constant-coefficient recurrence at least this many steps long runs in
#: scipy.signal.lfilter (C, 22 ns a number) rather than a numpy step loop (two calls, about
#: 2.5 us, a step): the same arithmetic, the same bits.
LFILTER_STEPS = 4096


def fixed_point(s: _Array, a: Any, q: ArrayLike) -> _Array:
    """``p_inf``, the limit of ``p_{t|t-1}``: positive root of ``s^2 p^2 + b p - q = 0``.

    ``b = 1 - a^2 - q s^2``; each root formula is used where it does not cancel. NaN where
    there is no positive root (``q = 0`` with ``|a| <= 1``: ``p`` falls to 0).

    Parameters
    ----------
    s : ndarray, shape (r,)
    a : float or ndarray, shape (..., 1)
        Broadcast against ``q[..., None] * s``.
    q : float or ndarray, shape (...)

    Returns
    -------
    ndarray, shape (..., r)

    Examples
    --------
    >>> p = fixed_point(np.array([2.0]), 1.0, 0.5)
    >>> bool(np.isclose(p[0], p[0] / (4 * p[0] + 1) + 0.5))
    True
    """
    q = np.asarray(q, dtype=float)[..., None]
    with np.errstate(all="ignore"):
        b = 1 - a**2 - q * s**2
        root = np.sqrt(b**2 + 4 * s**2 * q)
        p = np.where(b >= 0, 2 * q / (b + root), (root - b) / (2 * s**2))
    return np.where(p > 0, p, np.nan)


class Recursions:
    """The data-free recursions of one model over ``n_times`` steps, held once settled.

    Parameters
    ----------
    s : ndarray, shape (r,)
        Singular values of the whitened lead field.
    a : float or ndarray, shape (...)
        ``A = a I``; an array (broadcast with ``q`` and ``theta0``) runs one transition per
        prior, for the filtered means and the log-likelihood (the smoothers take a float).
    q, theta0 : float or ndarray, shape (...)
        ``Q = q I`` and ``P_0 = theta0 I``; arrays (broadcast together) run several priors.
    n_times : int
    rtol : float, optional
        Default :data:`STEADY_RTOL`; a negative value never holds (the full recursion).
    missing : ndarray of bool, shape (n_times,), optional
        The steps without a measurement (docs/model.md §2): predicted, not updated.

    Attributes
    ----------
    steady : int
        First step of the steady state (``n_times`` if the recording ends before it). It
        comes after the last missing step: every step before it is stored.
    missing : ndarray of bool, shape (n_times,)
    p_pred : ndarray, shape (n_stored, ..., r)
        ``p_{t|t-1}`` for ``t < n_stored = min(steady + 1, n_times)``; the last row holds
        for every later step.

    Examples
    --------
    >>> rec = Recursions(np.array([3.0, 1.0]), 1.0, 0.1, 1.0, 1000)
    >>> rec.steady < 1000, rec.p_pred.shape == (rec.steady + 1, 2)
    (True, True)
    """

    def __init__(
        self,
        s: NDArray[np.float64],
        a: Any,
        q: ArrayLike,
        theta0: ArrayLike,
        n_times: int,
        rtol: float | None = None,
        missing: NDArray[np.bool_] | None = None,
    ) -> None:
        rtol = STEADY_RTOL if rtol is None else rtol
        q, theta0 = np.asarray(q, dtype=float), np.asarray(theta0, dtype=float)
        batch = np.broadcast_shapes(q.shape, theta0.shape, np.shape(a))
        self.s, self.n_times = s, n_times
        self.a: Any = a if np.ndim(a) == 0 else np.asarray(a, dtype=float)
        # a transition per prior broadcasts against s as q does; a scalar stays as given
        a = self._a = a if np.ndim(a) == 0 else np.asarray(a, dtype=float)[..., None]
        self.missing = np.zeros(n_times, bool) if missing is None else missing
        # the steady state can only hold after the last missing step (a gap restarts the
        # transient): the steps before it are kept one by one
        after_gaps = int(np.flatnonzero(self.missing)[-1]) + 1 if self.missing.any() else 0
        target = fixed_point(s, a, np.broadcast_to(q, batch))
        p_pred = np.empty((n_times, *batch, len(s)))
        q_ = q[..., None]  # broadcast against s
        p = np.broadcast_to(theta0[..., None], (*batch, len(s)))
        self.steady = n_times
        for start in range(0, n_times, _CHECK_STEPS):
            stop = min(start + _CHECK_STEPS, n_times)
            for t in range(start, stop):
                # P_{t|t-1} = a^2 P_{t-1|t-1} + q I                        §2.2 (4)
                p_pred[t] = a**2 * p + q_
                # P_{t|t} = P_{t|t-1} - K S K^T: on span V p / (s^2 p + 1)  §2.2 (5)
                # (at a missing step P_{t|t} = P_{t|t-1}: no update)   docs/model.md §2
                p = p_pred[t] if self.missing[t] else p_pred[t] / (s**2 * p_pred[t] + 1)
            first = max(start, after_gaps)
            settled = _settled(p_pred[first:stop], target, rtol) if first < stop else None
            if settled is not None:
                self.steady = first + settled
                break
        self.p_pred = p_pred[: min(self.steady + 1, n_times)].copy()
        self._priors = (q, theta0, batch)

    @functools.cached_property
    def u(self) -> _Array:
        """ndarray, shape (n_times, ...) : ``q / c_{t|t-1}`` on the complement of span V,
        every step; only the smoothers need it (computed on first use)."""
        q, theta0, batch = self._priors
        return _complement(self.a, q, theta0, batch, self.n_times)

    @property
    def held(self) -> bool:
        """bool : Whether the recording reaches the steady state."""
        return self.steady < self.n_times

    def expand(self, rows: _Array, times: slice) -> _Array:
        """Rows of a per-step array of ``p_pred``'s length at steps ``times`` (a slice)."""
        first, stop, _ = times.indices(self.n_times)
        index = np.minimum(np.arange(first, stop), len(rows) - 1)
        return rows[index]

    @property
    def n_observed(self) -> int:
        """int : The steps with a measurement."""
        return self.n_times - int(np.count_nonzero(self.missing))

    def _stored_missing(self) -> NDArray[np.bool_]:
        """The missing steps among the stored rows, shaped to broadcast against them."""
        gaps = self.missing[: len(self.p_pred)]
        return gaps.reshape((len(gaps),) + (1,) * (self.p_pred.ndim - 1))

    @property
    def p_filt(self) -> NDArray[np.float64]:
        """ndarray, shape (n_stored, ..., r) : ``p_{t|t}``, rows as ``p_pred``
        (``p_{t|t-1}`` at a missing step)."""
        updated = self.p_pred / (self.s**2 * self.p_pred + 1)
        return np.where(self._stored_missing(), self.p_pred, updated)

    @property
    def omega(self) -> NDArray[np.float64]:
        """ndarray, shape (n_stored, ..., r) : ``s^2 p / (s^2 p + 1)``, the raw weights'
        coefficients (``w = (V o V) omega``), rows as ``p_pred``; NaN at a missing step,
        which has no weights."""
        omega = self.s**2 * self.p_pred / (self.s**2 * self.p_pred + 1)
        return np.where(self._stored_missing(), np.nan, omega)

    def log_det_innovations(self) -> NDArray[np.float64]:
        """``sum_t log det S~_t`` (...) over the observed steps: ``s^2 p_{t|t-1} + 1`` on
        span U, 1 off it."""
        terms = np.sum(np.log(self.s**2 * self.p_pred + 1), axis=-1)
        observed = np.where(self._stored_missing()[..., 0], 0.0, terms)
        return np.sum(observed, axis=0) + (self.n_times - len(terms)) * terms[-1]

    @functools.cached_property
    def gains(self) -> tuple[_Array, _Array]:
        """The smoother's gains: ``gamma_t`` on span V, ``beta_t`` on its complement.

        Returns
        -------
        gamma : ndarray, shape (n_stored - 1 or n_stored, ..., r)
            ``a p_{t|t} / p_{t+1|t}`` for ``t = 0 .. T-2``; when held, one more row, the
            steady gain, that holds for every later step.
        beta : ndarray, shape (n_times - 1, ...)
            ``a c_{t|t} / c_{t+1|t} = a / (a^2 + u_t)``, from the ratio ``u = q / c`` so
            that it stays finite when ``c`` grows past the largest float (``|a| > 1``).
        """
        p_filt, p_pred = self.p_filt, self.p_pred
        gamma = self._a * p_filt[:-1] / p_pred[1:]
        if self.held:
            gamma = np.concatenate([gamma, self._a * p_filt[-1:] / p_pred[-1:]])
        return gamma, self.a / (self.a**2 + self.u[:-1])

    def smooth_state(self, xi: _Array) -> _Array:
        """``"rts-state"`` in the basis: ``xi^s_t = xi_t + gamma_t (xi^s_{t+1} - a xi_t)``.

        Parameters
        ----------
        xi : ndarray, shape (n_times, r)

        Returns
        -------
        ndarray, shape (n_times, r)
        """
        out = np.empty_like(xi)
        for times in _tiles(self.n_times - 1):
            out[times] = (1 - self.a * self._gamma(times)) * xi[times]
        out[-1] = xi[-1]
        return self._backward_gamma(out)

    def correction(self, zeta: _Array) -> _Array:
        """``delta`` of the paper's smoother (``skf_ref.method._paths.spectral``), in place.

        ``chi`` obeys the scalar recursion on ``zeta``; ``delta_T = 0``,
        ``delta_t = gamma_t delta_{t+1} + (gamma_t - beta_t)(chi_{t+1} - a zeta_t)``.

        Parameters
        ----------
        zeta : ndarray, shape (n_times, r)
            ``V^T z_{t|t}``; overwritten by ``delta``.

        Returns
        -------
        ndarray, shape (n_times, r)
            ``zeta`` itself.
        """
        _, beta = self.gains
        chi = backward(zeta, beta, self.a)  # = V^T h
        for times in _tiles(self.n_times - 1):
            following = chi[times.start + 1 : times.stop + 1]
            step = (self._gamma(times) - beta[times, None]) * (following - self.a * zeta[times])
            zeta[times] = step
        zeta[-1] = 0.0
        return self._backward_gamma(zeta)

    def _gamma(self, times: slice) -> _Array:
        """``gamma_t`` at steps ``times`` (within 0 .. T-2), the held row past the stored."""
        gamma, _ = self.gains
        first, stop, _ = times.indices(self.n_times - 1)
        return gamma[np.minimum(np.arange(first, stop), len(gamma) - 1)]

    def _backward_gamma(self, c: _Array) -> _Array:
        """``x_t = gamma_t x_{t+1} + c_t``, t = T-2 .. 0, from ``x_{T-1} = c_{T-1}``; in place."""
        gamma, _ = self.gains
        own, last = len(gamma) - self.held, len(c) - 1  # steps with their own gain; T-1
        if last > own:
            recurrence(gamma[-1], c[own:last], start=c[last], out=c[own:last], reverse=True)
        if own:
            recurrence(gamma[:own], c[:own], start=c[own], out=c[:own], reverse=True)
        return c

    def filter_means(self, eta: _Array) -> tuple[_Array, Any, Any]:
        """The filtered means in the basis and two sums over their innovations.

        Parameters
        ----------
        eta : ndarray, shape (n_times, r)
            The whitened data in the basis ``U``.

        Returns
        -------
        xi : ndarray, shape (n_times, ..., r)
            ``xi_t = V^T x_{t|t}``.
        quadratic : ndarray, shape (...)
            ``sum_t e~_t^T S~_t^{-1} e~_t`` over span U, the innovations' quadratic form.
        residual : ndarray, shape (...)
            ``sum_t ||U^T (y~_t - L~ x_{t|t})||^2``, the filtered residual's energy on span U:
            ``U^T y~_t - s xi_t = e~_t - s^2 p / (s^2 p + 1) e~_t = e~_t / (s^2 p + 1)``.
        """
        s, a, T = self.s, self._a, self.n_times
        denom = s**2 * self.p_pred + 1  # eigenvalues of S~ on span U
        eta = eta.reshape((T,) + (1,) * (self.p_pred.ndim - 2) + (len(s),))
        # x_{t|t} = a x + K~ (y~ - L~ a x) with K~ = V diag(p s / (s^2 p + 1)) U^T §2.2 (5)
        #         = (a / (s^2 p + 1)) x + (p s / (s^2 p + 1)) eta
        # and at a missing step x_{t|t} = a x: no gain                  docs/model.md §2
        gaps = self._stored_missing()
        decay = np.where(gaps, a, a / denom)
        gain = np.where(gaps, 0.0, s * self.p_pred / denom)
        n = len(denom) - self.held  # the steps with their own coefficients
        xi = np.empty(np.broadcast_shapes((T, *denom.shape[1:]), eta.shape))
        np.multiply(gain[:n], eta[:n], out=xi[:n])
        recurrence(decay[:n], xi[:n], out=xi[:n])
        if self.held:
            np.multiply(gain[-1], eta[n:], out=xi[n:])
            recurrence(decay[-1], xi[n:], start=xi[n - 1] if n else None, out=xi[n:])
        quadratic, residual = 0.0, 0.0
        observed = ~self.missing.reshape((T,) + (1,) * (xi.ndim - 1))
        for times in _tiles(T):
            previous = xi[times.start - 1 : times.stop - 1] if times.start else _shifted(xi, times)
            # U^T (y~_t - L~ x_{t|t-1}) at the observed steps: no innovation at a missing one
            innovation = (eta[times] - s * a * previous) * observed[times]
            d = self.expand(denom, times)
            quadratic = quadratic + np.sum(innovation**2 / d, axis=(0, -1))
            residual = residual + np.sum((innovation / d) ** 2, axis=(0, -1))
        return xi, quadratic, residual


def _settled(p_pred: _Array, target: _Array, rtol: float) -> int | None:
    """First row of ``p_pred`` within ``rtol / 2`` of ``target`` in every entry, or None."""
    with np.errstate(invalid="ignore"):
        close = np.abs(p_pred - target) <= rtol / 2 * target
    rows = np.nonzero(close.reshape(len(p_pred), -1).all(axis=1))[0]
    return int(rows[0]) if len(rows) else None


def _complement(a: Any, q: _Array, theta0: _Array, batch: tuple[int, ...], n_times: int) -> _Array:
    """``u_t = q / c_{t|t-1}`` (n_times, ...) with ``c' = a^2 c + q``: ``u' = u / (a^2 + u)``.

    ``c`` grows as ``a^(2t)`` when ``|a| > 1`` and would overflow on long runs; ``u`` stays
    in [0, 1]. Scalar priors run in Python floats, far faster than numpy scalars.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        first = q / (a**2 * theta0 + q)
    if not batch:
        values, v = [], float(first)
        for _ in range(n_times):
            values.append(v)
            v = v / (a**2 + v) if v else 0.0
        return np.array(values)
    u = np.empty((n_times, *batch))
    u[0] = np.nan_to_num(first)
    for t in range(1, n_times):
        u[t] = u[t - 1] / (a**2 + u[t - 1])
    return np.nan_to_num(u)


def _tiles(n_times: int, steps: int = 8192) -> list[slice]:
    return [slice(t, min(t + steps, n_times)) for t in range(0, n_times, steps)]


def _shifted(xi: _Array, times: slice) -> _Array:
    """``xi`` at steps ``times`` shifted one step back, with zeros before step 0."""
    previous = np.zeros((times.stop - times.start, *xi.shape[1:]))
    previous[1:] = xi[: times.stop - 1]
    return previous


def recurrence(
    decay: Any,
    c: _Array,
    start: Any = None,
    out: _Array | None = None,
    reverse: bool = False,
) -> _Array:
    """``x_t = decay_t x_{t-1} + c_t`` from ``x_{-1} = start`` (default 0), elementwise.

    With ``reverse`` the recursion runs from the end: ``x_t = decay_t x_{t+1} + c_t`` from
    ``x_N = start``.

    Parameters
    ----------
    decay : ndarray, shape (N, ...) or (...)
        One coefficient per step, or one for every step (then long runs use
        scipy.signal.lfilter, component by component: the same arithmetic).
    c : ndarray, shape (N, ...)
    start : ndarray, shape (...), optional
    out : ndarray, shape (N, ...), optional
        May be ``c`` itself.

    Returns
    -------
    ndarray, shape (N, ...)

    Examples
    --------
    >>> recurrence(0.5, np.ones((3, 1))).ravel().tolist()
    [1.0, 1.5, 1.75]
    >>> recurrence(np.full((3, 1), 0.5), np.ones((3, 1)), reverse=True).ravel().tolist()
    [1.75, 1.5, 1.0]
    """
    out = np.empty_like(c) if out is None else out
    same = out is c
    if reverse:
        decay = decay[::-1] if np.ndim(decay) == c.ndim else decay
        out, c = out[::-1], c[::-1]
    if not len(c):
        return out[::-1] if reverse else out
    constant = np.ndim(decay) < c.ndim
    if constant and len(c) >= LFILTER_STEPS:
        decay = np.broadcast_to(decay, c.shape[1:])
        start = np.zeros(c.shape[1:]) if start is None else np.broadcast_to(start, c.shape[1:])
        from scipy import signal  # here: importing it takes a second, most runs never need it

        for index in np.ndindex(c.shape[1:]):
            column = (slice(None), *index)
            # y_t = c_t + decay y_{t-1}: lfilter's direct form computes exactly this
            zi = [decay[index] * start[index]]
            out[column] = signal.lfilter([1.0], [1.0, -decay[index]], c[column], zi=zi)[0]
    else:
        if not same:
            out[...] = c
        if start is not None:
            out[0] += (decay if constant else decay[0]) * start
        for t in range(1, len(out)):
            out[t] += (decay if constant else decay[t]) * out[t - 1]
    return out[::-1] if reverse else out


#: The backward pass with one scalar gain per step runs CHUNK_STEPS steps as one matrix
#: product on arrays narrower than CHUNK_COLUMNS: a step costs a few microseconds of
#: interpreter whatever the width, a (b, b + 1) product 2 (b + 1) flops per number.
CHUNK_STEPS = 16
CHUNK_COLUMNS = 2048


def backward(z: _Array, gain: _Array, a: float, overwrite: bool = False) -> _Array:
    """``s_t = z_t + G_t (s_{t+1} - a z_t)``, ``s_T = z_T``; one scalar gain per step, (T-1,).

    With ``overwrite`` the result replaces ``z`` (step t reads only ``z_t`` and ``s_{t+1}``).
    On a (T, k) array narrower than :data:`CHUNK_COLUMNS` the steps are applied
    :data:`CHUNK_STEPS` at a time (``_chunk_matrices``): the same linear map, rounded
    differently. ``z`` may be any (T, k) view, e.g. the transpose of a C-ordered (k, T)
    block.

    Examples
    --------
    >>> z = np.arange(8.0).reshape(4, 2)
    >>> backward(z, np.full(3, 0.5), 1.0)
    array([[1.75, 2.75],
           [3.5 , 4.5 ],
           [5.  , 6.  ],
           [6.  , 7.  ]])
    """
    s = z if overwrite else z.copy()
    first = len(s) - 1  # steps 0 .. first-1 are computed; s_T = z_T
    if s.ndim == 2 and s.shape[1] < CHUNK_COLUMNS:
        b = CHUNK_STEPS
        first %= b
        matrices = _chunk_matrices(gain[first:], a, b)[::-1]
        for chunk, M in zip(range(len(s) - 1 - b, first - 1, -b), matrices, strict=True):
            s[chunk : chunk + b] = M @ s[chunk : chunk + b + 1]
    for t in range(first - 1, -1, -1):
        # the same, in place: s_t = (1 - a G_t) z_t + G_t s_{t+1}
        s[t] *= 1 - a * gain[t]
        s[t] += gain[t] * s[t + 1]
    return s


def _chunk_matrices(gain: _Array, a: float, b: int) -> _Array:
    """The backward pass over chunks of ``b`` steps as matrices, (len(gain) // b, b, b + 1).

    For the chunk of steps ``t0 .. t0+b-1``, ``s[t0:t0+b] = M @ v`` with ``v`` the rows
    ``z_{t0} .. z_{t0+b-1}, s_{t0+b}``: row i of M is ``(1 - a G_i) e_i + G_i M_{i+1}``
    (unrolling ``s_i = (1 - a G_i) z_i + G_i s_{i+1}``), with ``M_b = e_b``.
    """
    G = gain.reshape(-1, b)
    M = np.zeros((len(G), b + 1, b + 1))
    M[:, b, b] = 1.0
    for i in range(b - 1, -1, -1):
        np.multiply(G[:, i, None], M[:, i + 1], out=M[:, i])
        M[:, i, i] = 1 - a * G[:, i]
    return M[:, :b]
