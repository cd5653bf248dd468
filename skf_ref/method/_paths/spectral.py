r"""The exact fast path: the SKF and both smoothers in the singular basis of the lead field.

It applies to the paper's model: ``A = a I``, ``Q = q I``, ``P_0 = theta0 I`` and a constant SPD
noise covariance ``R``. Nothing is approximated beyond holding the covariances once they have
settled to 1e-14 (the steady state, below); the result equals
``skf_ref.method._paths.dense`` to rounding (1e-12 relative on the tests' problems). Cost:
one thin SVD, O(r) work per step, and a few (n, r) x (r, T) products, with
``r = rank(L) <= n_channels``; in the steady state one product a step. Memory O(n r + n T);
no (n, n) matrix is formed. The whitening and SVD (:class:`SpectralBasis`) live in
``skf_ref.method._paths.singular_basis``, the rank-r recursions in
``skf_ref.method._paths.recursions``; this module prepares them once per model
(:class:`SpectralModel`) and ``skf_ref.method._paths.spectral_rows`` forms the
n-dimensional outputs from them.

Why it equals the dense recursion, equation by equation (docs/model.md §2-3)
----------------------------------------------------------------------------
**Whitening.** With ``R = C C^T`` (Cholesky), ``L~ = C^{-1} L``, ``y~ = C^{-1} y`` and noise
covariance I give the same means and covariances: ``S~ = C^{-1} S C^{-T}`` and
``K~ = K C``, so ``K S K^T = K~ S~ K~^T`` and the weights §2.2 (7) are unchanged. The
log-likelihood changes by the Jacobian: ``log N(e; 0, S) = log N(e~; 0, S~) - log|det C|``.

**Basis.** Let ``L~ = U diag(s) V^T`` (thin SVD, ``V`` (n, r) with orthonormal columns,
``V_perp`` its orthogonal complement, never formed). Claim: every covariance has the form
``P = V diag(p) V^T + c (I - V V^T)``, with a vector ``p`` (r,) and one scalar ``c``.
``P_0 = theta0 I`` has it (``p = theta0``, ``c = theta0``). If ``P_{t-1|t-1}`` has it:

- predict §2.2 (4): ``a^2 P + q I`` has it with ``p_pred = a^2 p + q``, ``c_pred = a^2 c + q``;
- update §2.2 (5): ``S~ = U diag(s^2 p_pred) U^T + I``, so in the basis ``U`` (completed to R^m)
  ``S~`` is diagonal with entries ``s^2 p_pred + 1`` on ``U`` and 1 elsewhere, and
  ``K~ = P L~^T S~^{-1} = V diag(g) U^T`` with ``g = p_pred s / (s^2 p_pred + 1)``;
  ``P_{t|t} = P_pred - K~ S~ K~^T`` has ``p = p_pred / (s^2 p_pred + 1)``, ``c = c_pred``
  (the lead field does not see ``V_perp``: no update there).

**Means.** ``x_0 = 0`` and ``K~`` maps into ``span V``, so ``x_t = V xi_t`` with
``xi_t = a xi_{t-1} + g (eta_t - s a xi_{t-1})``, ``eta_t = U^T y~_t``.

**Log-likelihood.** The innovation ``e~ = y~ - U (s a xi)`` has ``U^T e~ = eta - s a xi``
and, on the complement of ``U``, the part of ``y~`` that no source explains, ``rho_t``:
``log N(e~; 0, S~) = -(m log 2 pi + sum log(s^2 p_pred + 1)
+ sum (U^T e~)^2 / (s^2 p_pred + 1) + ||rho_t||^2) / 2``.

**Weights, §2.2 (7).** ``w = diag(P^{1/2} L~^T S~^{-1} L~ P^{1/2})`` (docs/model.md §2) and
``L~ P^{1/2} = U diag(s sqrt(p_pred)) V^T``, so
``w = (V o V) omega`` with ``omega = s^2 p_pred / (s^2 p_pred + 1)`` (``o``: elementwise).
**Output, §2.2 (6).** ``P_pred^{-1/2} x = V diag(p_pred^{-1/2}) xi``.

**Smoother gains, §2.3 (4).** ``G_t = P_{t|t} a P_{t+1|t}^{-1} = V diag(gamma_t) V^T
+ beta_t (I - V V^T)`` with ``gamma_t = a p_{t|t} / p_{t+1|t}`` and the scalar
``beta_t = a c_{t|t} / c_{t+1|t} = a / (a^2 + q / c_{t|t})``, computed from the ratio
``q / c`` so that it stays finite when ``c`` grows past the largest float (``|a| > 1``).

- ``"rts-state"``: ``x^s`` stays in ``span V``:
  ``xi^s_t = xi_t + gamma_t (xi^s_{t+1} - a xi_t)``, then §2.2 (6) as above.
- ``"rts-standardized"``: ``z`` is not in ``span V``. Write ``G_t = beta_t I +
  V diag(gamma_t - beta_t) V^T``. The scalar part gives, on whole vectors,
  ``h_t = z_t + beta_t (h_{t+1} - a z_t)``, ``h_T = z_T`` (O(n) per step, no product with
  a matrix). The rest ``d_t = s_t - h_t`` satisfies ``d_T = 0`` and
  ``d_t = beta_t d_{t+1} + V diag(gamma_t - beta_t) V^T (s_{t+1} - a z_t)``, so it lies in
  ``span V``: ``d_t = V delta_t``. With ``zeta = V^T z``, ``chi = V^T h`` (which obeys the
  scalar recursion on ``zeta``) and ``V^T s_{t+1} = chi_{t+1} + delta_{t+1}``:
  ``delta_T = 0``, ``delta_t = gamma_t delta_{t+1} + (gamma_t - beta_t)(chi_{t+1} - a zeta_t)``.
  So ``s = h + V delta``: one product ``V^T z``, one product ``V delta``, O(r T) recursions.

**Steady state.** The covariance recursion settles (``skf_ref.method._paths.recursions``):
from step ``steady`` on, ``p`` and with it ``omega`` and ``W_t^(alpha) = D`` are held, to a
relative ``STEADY_RTOL`` (1e-14). Then ``z_t = (D V) u_t`` with ``u_t = p^{-1/2} xi_t``: one
product, no power. In the paper's smoother, ``h`` obeys a scalar recursion, so for
``t >= steady``, where every ``z_t`` lies in span ``D V``, ``h_t = D V eta_t`` with ``eta``
the same recursion on ``u`` (rank r): ``s_t = D V eta_t + V delta_t``, one product of width
2r, and ``zeta_t = (V^T D V) u_t``. Only the steps before ``steady`` need ``z`` of every row
first (``skf_ref.method._paths.spectral_rows``). The scalar ``beta_t`` never settles when
``a = 1`` (``c`` grows like ``t q``); it only enters these rank-r recursions.

**Standardization per position, and the smoothed state over its own variance.** Both
keep the forms above (docs/model.md §2-3): a position's block of ``Psi_t`` is
``V_i Diag(omega_t) V_i^T`` (``skf_ref.method._paths.block_weights``; ``D V`` becomes
``F V``, ``F`` the held blocks' powers, in the steady state and in the paper's smoother),
and ``"rts-smoothed-weights"`` standardizes ``V xi^s_t / sigma_t^(1/2)`` by ``(V o V)
omega^s_t`` or its blocks, with ``omega^s`` of every step from the RTS covariance recursion
on span ``V`` (``skf_ref.method._paths.smoothed_weights``).

The r x T recursions are kept time-major, (T, r). An output held in memory is time-major
too, (T, n), handed out as its (n, T) transpose: the smoother's scalar recursion then runs
along whole contiguous rows. Streamed blocks of rows are computed source-major, (k, T), as
they are written.
"""

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..._utils.checks import InputError
from .._model import StateSpaceModel
from .._result import Reconstruction
from .._settings import Settings, check_gaps, check_settings
from .._standardization import check_positions_seen, overflow_cause
from .block_weights import BlockStandardization
from .recursions import Recursions
from .singular_basis import SpectralBasis, log_likelihood
from .smoothed_weights import HeldInterior, interior, smoothed_weights
from .spectral_rows import SpectralRows
from .weights import Standardization

_Weights = Standardization | BlockStandardization | HeldInterior

__all__ = ["SpectralModel", "run"]


class SpectralModel:
    """The data-independent part of the spectral path, prepared once, applied many times.

    Whitening, the SVD and the whole covariance recursion depend on the model and the number
    of steps only, and so do the standardization weights of each exponent, so runs that
    share them (several data sets, seeds of a simulation, exponents and smoothers) pay for
    them once.

    For speed when applying one model to many data sets: keep the model, ask the result
    only for the outputs needed (each is computed on first access; ``z`` is one product
    and, before the steady state, one multiplication by the weights), and keep the
    exponent: from the second data set on, the weights of the steps before the steady state
    are kept per exponent (up to 256 MiB of them). ``smoother=None``
    and ``"rts-state"`` cost the same; ``"rts-standardized"`` adds, before the steady
    state, two products (the projection ``V^T z`` and the correction ``V delta``) and a
    backward pass, and after it a second product of width r.

    Parameters
    ----------
    model : StateSpaceModel
        With ``transition``, ``q`` and ``theta0`` scalars or scalar multiples of the
        identity (:meth:`StateSpaceModel.isotropic_problem` is None).
    n_times : int
    basis : SpectralBasis, optional
        The whitening and SVD of ``model.L`` and ``model.R``, if already computed.

    Examples
    --------
    >>> from skf_ref.method import StateSpaceModel
    >>> rng = np.random.default_rng(0)
    >>> model = StateSpaceModel.create(rng.standard_normal((6, 9)), noise_std=1.0,
    ...                                theta0=1.0, q=0.1)
    >>> prepared = SpectralModel(model, n_times=5)
    >>> a = prepared.apply(rng.standard_normal((6, 5)), exponent=0.5, smoother=None)
    >>> b = prepared.apply(rng.standard_normal((6, 5)), exponent=1.25, smoother="rts-state")
    >>> a.z.shape, b.z.shape, prepared.rank
    ((9, 5), (9, 5), 6)
    """

    def __init__(
        self, model: StateSpaceModel, n_times: int, basis: SpectralBasis | None = None
    ) -> None:
        problem = model.isotropic_problem()
        if problem:
            raise InputError(
                f"the spectral path needs A = a I, Q = q I, P_0 = theta0 I: {problem}"
            )
        a = model.scalar("transition")
        assert a is not None  # isotropic
        self.model, self.a, self.n_times = model, a, n_times
        self.n_channels, self.n_sources = model.L.shape
        self.basis = SpectralBasis(model.L, model.R) if basis is None else basis
        self.U, self.s, self.V = self.basis.U, self.basis.s, self.basis.V
        self.recursions = self._recursions(None)
        self._standardizations: dict[tuple[Any, ...], _Weights] = {}
        self._seen: set[int] = set()  # the blocks checked by check_positions_seen
        self._gaps: tuple[bytes, Recursions, dict[tuple[Any, ...], _Weights]] | None = None

    def _recursions(self, missing: NDArray[np.bool_] | None) -> Recursions:
        """The covariance recursion over ``n_times`` steps with these missing steps,
        refused before any output if it leaves double precision."""
        q, theta0 = self.model.scalar("q"), self.model.scalar("theta0")
        assert q is not None and theta0 is not None  # isotropic (checked by __init__)
        recursions = Recursions(self.s, self.a, q, theta0, self.n_times, missing=missing)
        log_det_S = recursions.log_det_innovations()
        if not (np.isfinite(recursions.p_pred).all() and np.isfinite(log_det_S)):
            raise InputError(
                f"the predicted covariance overflows: theta0={theta0:g}, q={q:g} and "
                f"transition={self.a:g} are out of range at this lead field's scale (largest "
                f"whitened singular value {self.s[0]:.3g}); rescale L, the noise or the priors"
            )
        smallest = np.nanmin(recursions.omega)
        if not smallest > 0:
            raise InputError(overflow_cause(smallest, 0.0))
        return recursions

    @property
    def steady(self) -> int:
        """The first step of the steady state (int), without missing steps.

        ``n_times`` if the recording ends before it (``skf_ref.method._paths.recursions``).
        """
        return self.recursions.steady

    @property
    def rank(self) -> int:
        """Numerical rank of the whitened lead field (int)."""
        return len(self.s)

    def standardization(
        self,
        exponent: float,
        missing: NDArray[np.bool_] | None = None,
        block: int = 1,
        smoothed: bool = False,
    ) -> _Weights:
        """The weights ``W_t^(alpha)`` of every source and step at ``exponent``, kept.

        Parameters
        ----------
        exponent : float
        missing : ndarray of bool, shape (n_times,), optional
            The missing steps of the data (default none). The weights of the last pattern
            of missing steps are kept beside those of data without any.
        block : {1, 3}
            Columns standardized together: 1 (each column on its own) or 3 (a position
            of free orientation, docs/model.md §2).
        smoothed : bool
            The weights of the smoothed state by its own variance
            (``"rts-smoothed-weights"``, docs/model.md §3) in place of the filter's.

        Returns
        -------
        Standardization or BlockStandardization
        """
        recursions, kept = self._prepared(missing)
        key = (float(exponent), block, smoothed)
        if key not in kept:
            omega, steady = recursions.omega, recursions.steady
            kind = BlockStandardization if block == 3 else Standardization
            if smoothed:  # held inside the recording if they settle there, else every step
                omega, steady = self._smoothed_weights(missing)[0], self.n_times
                held = interior(omega)
                if held is not None:
                    kept[key] = HeldInterior(kind, self.V, omega, held, float(exponent))
                    return kept[key]
            kept[key] = kind(self.V, omega, steady, self.n_times, float(exponent))
        return kept[key]

    def _smoothed_weights(self, missing: NDArray[np.bool_] | None) -> tuple[Any, Any]:
        """``omega^s`` (n_times, r) and ``1 / sigma_t`` (n_times,) of the smoothed state's
        own variance (``skf_ref.method._paths.smoothed_weights``), kept."""
        recursions, kept = self._prepared(missing)
        if "smoothed" not in kept:
            q, theta0 = self.model.scalar("q"), self.model.scalar("theta0")
            assert q is not None and theta0 is not None  # isotropic
            kept["smoothed"] = smoothed_weights(recursions, q, theta0)
        return kept["smoothed"]

    def _prepared(self, missing: NDArray[np.bool_] | None) -> tuple[Recursions, dict[Any, Any]]:
        """The recursion and the kept standardizations of data with these missing steps."""
        if missing is None or not missing.any():
            return self.recursions, self._standardizations
        key = np.packbits(missing).tobytes()
        if self._gaps is None or self._gaps[0] != key:
            self._gaps = (key, self._recursions(missing), {})
        return self._gaps[1], self._gaps[2]

    def apply(
        self,
        Y: ArrayLike,
        exponent: float,
        smoother: str | None,
        memory_limit: float | None = None,
        standardize: str = "column",
        n_orient: int | None = None,
    ) -> Reconstruction:
        """Filter and smooth data ``Y``, equal to the dense path on the model.

        Equal to ``skf_ref.method._paths.dense.run`` to rounding.

        Parameters
        ----------
        Y : array_like, shape (n_channels, n_times)
            A column of NaN is a missing step (docs/model.md §2).
        exponent : float
        smoother : {None, "rts-standardized", "rts-state", "rts-smoothed-weights"}
            ``"rts-standardized"`` is refused over missing steps.
        memory_limit : float, optional
            Bytes an (n, T) output asked for in memory may take (default half the memory
            available then); streamed outputs need only a few blocks.
        standardize : {"column", "position"}
        n_orient : {1, 3}, optional
            Columns per source position; ``"position"`` needs it (docs/model.md §2).

        Returns
        -------
        Reconstruction
            Its arrays are computed on first access.
        """
        m, T = self.n_channels, self.n_times
        data = self.model.check_data(Y)
        if data.shape != (m, T):
            raise InputError(f"Y must have shape ({m}, {T}), got {data.shape}")
        missing = np.isnan(data[0])  # check_data refused columns NaN in part
        settings = check_settings(
            exponent, smoother, "spectral", standardize, n_orient, self.n_sources
        )
        check_gaps(settings.smoother, missing)
        return self._checked_apply(data, settings, memory_limit)

    def _checked_apply(
        self, Y: NDArray[np.float64], settings: Settings, memory_limit: float | None = None
    ) -> Reconstruction:
        """:meth:`apply` on data and settings already checked (the public routes' kernel).

        Parameters
        ----------
        Y : ndarray, shape (n_channels, n_times)
            Checked (``StateSpaceModel.check_data``); a column of NaN is a missing step.
        settings : Settings
            Checked, with :func:`skf_ref.method._settings.check_gaps` against ``Y``.
        memory_limit : float, optional

        Returns
        -------
        Reconstruction
        """
        data, m, T = Y, self.n_channels, self.n_times
        exponent, smoother = settings.exponent, settings.smoother
        missing = np.isnan(data[0])
        block = settings.block
        if block not in self._seen:  # every position's block regular (docs/model.md §2)
            check_positions_seen(self.model.L, self.model.R, block)
            self._seen.add(block)
        recursions, _ = self._prepared(missing)
        eta, rho_sq = self.basis.project(data)  # U^T y~ (T, r) and the data outside span U
        xi, quadratic, _ = recursions.filter_means(eta)
        del eta
        total = log_likelihood(
            quadratic,
            recursions.log_det_innovations(),
            rho_sq,
            self.basis.log_det_C,
            m,
            recursions.n_observed,
        )
        smoothed = None
        if smoother == "rts-smoothed-weights":
            weights = self.standardization(exponent, missing, block, smoothed=True)
            smoothed = (weights, self._smoothed_weights(missing)[1])
        filtered = self.standardization(exponent, missing, block)
        assert not isinstance(filtered, HeldInterior)  # the filter's: held from steady on
        rows = SpectralRows(
            self.V,
            self.a,
            recursions,
            filtered,
            xi,
            smoother,
            memory_limit=memory_limit,
            smoothed=smoothed,
        )
        return Reconstruction(
            log_likelihood=float(total),
            n_sources=self.n_sources,
            n_times=T,
            exponent=exponent,
            smoother=smoother,
            path="spectral",
            theta0=self.model.theta0,
            q=self.model.q,
            transition=self.model.transition,
            standardize=settings.standardize,
            n_orient=settings.n_orient,
            missing=missing,
            lazy=rows,
        )


def run(
    model: StateSpaceModel,
    Y: NDArray[np.float64],
    settings: Settings,
    memory_limit: float | None = None,
) -> Reconstruction:
    """Filter and optionally smooth in the singular basis; equal to
    ``skf_ref.method._paths.dense.run``.

    Parameters
    ----------
    model : StateSpaceModel
        Isotropic: see :class:`SpectralModel`.
    Y : ndarray, shape (n_channels, n_times)
    settings : Settings
        Checked by the caller.
    memory_limit : float, optional
        See :meth:`SpectralModel.apply`.

    Returns
    -------
    Reconstruction
        Its arrays are computed on first access.
    """
    return SpectralModel(model, Y.shape[1])._checked_apply(Y, settings, memory_limit)
