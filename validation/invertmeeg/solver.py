"""The SKF as an invertmeeg solver: :class:`SolverSKF` and :func:`register`.

Imported only where invertmeeg (PyPI ``invertmeeg``, GPL-3) is installed; nothing of it is
copied here. :class:`SolverSKF` subclasses ``invert.solvers.base.BaseSolver``:
``make_inverse_operator(forward, mne_obj, alpha=..., noise_cov=...)`` keeps the forward and
the noise covariance, and ``apply_inverse_operator(evoked)`` runs
:func:`skf_ref.apply_skf` with the package's defaults (exponent 0.5,
``"rts-smoothed-weights"``, ``standardize="position"``, which for a fixed-orientation
forward is the per-column form, PM-SNR 0 dB and the AR(1) prior with its time constant chosen
by the data's marginal likelihood at the evoked's sampling rate; docs/choosing.md). invertmeeg's
``alpha`` (its regularization grid) is not used: the SKF's regularization is its priors.

The solver is data dependent (``require_recompute = True``): invertmeeg's benchmark makes it
once per sample, with that sample's noise covariance, as it does its other data-dependent
solvers (beamformers, Champagne).

:func:`register` adds the solver to invertmeeg's registry under the id ``"skf"`` (alias
``"SKF"``), so ``BenchmarkRunner(solvers=[..., "skf"])`` runs it. invertmeeg has no public
call for this: its registry is a module-level tuple of specs with two indexes built from it,
which :func:`register` rebuilds with the SKF's spec added, by invertmeeg's own index builder.
"""

from __future__ import annotations

from typing import Any

import mne
from invert import solver_registry
from invert.solvers.base import BaseSolver, SolverMeta

import skf_ref

SOLVER_ID = "skf"
#: The priors each application chose (``skf_ref.TuneResult``), in order: the benchmark makes
#: its solvers itself, so the runner reads what the data chose from here.
CHOICES: list[Any] = []


class SolverSKF(BaseSolver):
    """The standardized Kalman filter (skf_ref) behind invertmeeg's solver interface.

    Parameters
    ----------
    name : str
        The solver's display name.
    pm_snr_db, ep_snr_db, time_constant_ms, exponent, smoother, standardize
        :func:`skf_ref.apply_skf`'s; None: the package's defaults.
    **kwargs
        ``BaseSolver``'s (``verbose`` and the regularization options its other solvers
        use; the SKF uses none of them).
    """

    meta = SolverMeta(
        acronym="SKF",
        full_name="Standardized Kalman Filter",
        category="Kalman",
        description=(
            "Kalman filter over the source time courses with a random-walk or AR(1) "
            "evolution prior, each step's estimate standardized as sLORETA's (skf_ref)."
        ),
        references=[
            "Lahtinen, J., Ronni, P., Subramaniyam, N. P., Koulouri, A., Wolters, C., & "
            "Pursiainen, S. (2024). Standardized Kalman filtering for dynamical source "
            "localization of concurrent subcortical and cortical brain activity. Clinical "
            "Neurophysiology, 168, 15-24. doi:10.1016/j.clinph.2024.09.021",
        ],
    )

    def __init__(
        self,
        name: str = "Standardized Kalman Filter",
        pm_snr_db: Any = None,
        ep_snr_db: Any = None,
        time_constant_ms: Any = None,
        exponent: float = 0.5,
        smoother: str | None = "rts-smoothed-weights",
        standardize: str | None = None,
        **kwargs: Any,
    ) -> None:
        self.name = name
        self.skf_options = dict(
            pm_snr_db=pm_snr_db,
            ep_snr_db=ep_snr_db,
            time_constant_ms=time_constant_ms,
            exponent=exponent,
            smoother=smoother,
            standardize=standardize,
        )
        super().__init__(**kwargs)
        self.require_recompute = True
        self.require_data = True
        self.noise_cov: mne.Covariance | None = None
        self.reconstruction: skf_ref.Reconstruction | None = None

    def make_inverse_operator(  # type: ignore[override]
        self,
        forward: mne.Forward,
        *args: Any,
        alpha: Any = "auto",
        noise_cov: mne.Covariance | None = None,
        **kwargs: Any,
    ) -> SolverSKF:
        """Keep the forward and the noise covariance of one trial (required).

        ``alpha`` is accepted for invertmeeg's interface and not used. The operator itself
        (channels, reference, whitening, priors) is made for each evoked by
        :func:`skf_ref.apply_skf`, which chooses the time constant from that evoked.
        """
        if noise_cov is None:
            raise ValueError(
                "SolverSKF needs noise_cov (the covariance of one trial): the SKF whitens "
                "with it and sets its priors on the whitened lead field"
            )
        self.forward = forward
        self.noise_cov = noise_cov
        self.alpha = alpha
        self.made_inverse_operator = True
        return self

    def apply_inverse_operator(self, mne_obj: Any) -> Any:
        """The SKF's source estimate of an evoked (or of the average of epochs)."""
        if not self.made_inverse_operator:
            raise RuntimeError("call make_inverse_operator first")
        if isinstance(mne_obj, mne.BaseEpochs):
            mne_obj = mne_obj.average()
        if not isinstance(mne_obj, mne.Evoked):
            raise TypeError(f"SolverSKF applies to an mne.Evoked or mne.Epochs, got {mne_obj!r}")
        given = ("exponent", "smoother")  # None is a smoother: none
        options = {k: v for k, v in self.skf_options.items() if v is not None or k in given}
        stc, self.reconstruction = skf_ref.apply_skf(
            mne_obj,
            self.forward,
            self.noise_cov,
            return_reconstruction=True,
            verbose=bool(self.verbose),
            **options,
        )
        CHOICES.append(self.reconstruction.tuning)
        return stc


def register() -> solver_registry.SolverSpec:
    """Add :class:`SolverSKF` to invertmeeg's registry as ``"skf"`` (once; returns its spec)."""
    key = solver_registry.normalize_solver_name(SOLVER_ID)
    if key in solver_registry._SPECS_BY_ID:
        return solver_registry._SPECS_BY_ID[key]
    spec = solver_registry.SolverSpec(
        solver_id=SOLVER_ID,
        module_path=__name__,
        class_name=SolverSKF.__name__,
        aliases=("standardized-kalman-filter",),
        display_name="SKF",
    )
    specs = (*solver_registry._SOLVER_SPECS, spec)
    by_id, aliases = solver_registry._build_solver_indexes(specs)
    solver_registry._SOLVER_SPECS = specs
    solver_registry._SPECS_BY_ID = by_id
    solver_registry._ALIAS_TO_ID = aliases
    return spec
