"""The conformance cases: what each holds, how it is generated, and its expected outputs."""

from dataclasses import dataclass, field

import numpy as np

from ..method.outputs import OUTPUTS
from ..method.priors import priors_from_snr
from ..method.reconstruct import reconstruct
from ..method.result import readonly
from ..version import __version__

__all__ = [
    "CONFORMANCE_VERSION",
    "EXTRAS",
    "INPUTS",
    "OUTPUTS",
    "TOLERANCE",
    "Case",
    "as_value",
    "cases",
]

#: The version of the case set: raised whenever a case, its inputs or its seed change.
CONFORMANCE_VERSION = 1
#: Largest relative difference, ``max|theirs - expected| / max|expected|`` per output, that counts
#: as agreement. The package's own three paths agree to 1e-12 on these cases (the tests require
#: 1e-8), and an implementation in double precision with another order of operations should too:
#: the cases are small and well conditioned, so rounding stays far below 1e-10. Every mistake in
#: :mod:`skf_ref.conformance.mistakes` moves some output by 1e-3 or more (the tests require it).
#: 1e-6 leaves three orders of magnitude or more on each side; an implementation in single
#: precision (float32, eps 6e-8) should compare with 1e-4.
TOLERANCE = 1e-6
INPUTS = ("L", "Y", "noise_cov", "theta0", "q", "transition", "exponent", "smoother")
#: What some cases hold besides their inputs and outputs (see :mod:`skf_ref.conformance`).
EXTRAS = (
    "pm_snr_db",
    "ep_snr_db",
    "convention",
    "noise_std",
    "data_scale",
    "Y_unscaled",
    "L_unreferenced",
)

_SEED = 11  # the project's issue 11
_N_TIMES = 7  # never a case's n_sources, so that a transposed output shows in its shape


@dataclass(frozen=True, eq=False)
class Case:
    """One conformance case: the inputs, the expected outputs and what it exercises.

    Attributes
    ----------
    name : str
    description : str
    exercises : tuple of str
    inputs : dict
        The names of ``INPUTS``: arrays (read-only) of the shapes in
        :mod:`skf_ref.conformance`, scalars as ``float``, ``smoother`` None or text.
    expected : dict
        The names of ``OUTPUTS``, from the dense path: (n_sources, n_times) arrays and the
        log-likelihood as a float.
    extras : dict
        Whatever more the case holds (the names of ``EXTRAS`` it has).
    tolerance : float
        Largest relative difference that counts as agreement.
    """

    name: str
    description: str
    exercises: tuple
    inputs: dict
    expected: dict
    extras: dict = field(default_factory=dict)
    tolerance: float = TOLERANCE

    @property
    def shape(self):
        """tuple : (n_sources, n_times) of every array output."""
        return (self.inputs["L"].shape[1], self.inputs["Y"].shape[1])

    def reconstruct(self, method="dense", **changes):
        """Run :func:`skf_ref.reconstruct` on the inputs with one of its paths.

        Parameters
        ----------
        method : {"dense", "filterpy", "spectral", "auto"}
        **changes
            Inputs to replace (``smoother="rts-state"``, say).

        Returns
        -------
        Reconstruction
        """
        p = {**self.inputs, **changes}
        noise_cov = p["noise_cov"]
        if np.ndim(noise_cov) == 0:
            noise_cov = noise_cov * np.eye(p["L"].shape[0])
        return reconstruct(
            p["L"],
            p["Y"],
            noise_cov=noise_cov,
            theta0=p["theta0"],
            q=p["q"],
            transition=p["transition"],
            exponent=p["exponent"],
            smoother=p["smoother"],
            method=method,
        )

    def variables(self):
        """Everything the case's file holds, by name; ``smoother`` None as ``"none"``.

        Returns
        -------
        dict
        """
        about = {
            "case": self.name,
            "description": self.description,
            "exercises": "; ".join(self.exercises),
            "conformance_version": CONFORMANCE_VERSION,
            "tolerance": self.tolerance,
            "skf_ref_version": __version__,
        }
        inputs = {**self.inputs, "smoother": self.inputs["smoother"] or "none"}
        return {**about, **inputs, **self.extras, **self.expected}


# --- the cases -------------------------------------------------------------------------------

_SPECS = []


def _case(name, seed, description, *exercises):
    """Register a case builder: ``rng -> {input or extra name: value}``."""

    def register(builder):
        _SPECS.append((name, seed, description, exercises, builder))
        return builder

    return register


def _data(rng, L, noise, scale=1.0):
    """``L X + noise e`` with ``X`` a random walk (the model's own prior) times ``scale``."""
    X = scale * np.cumsum(rng.standard_normal((L.shape[1], _N_TIMES)), axis=1)
    return L @ X + noise @ rng.standard_normal((L.shape[0], _N_TIMES))


def _spd(rng, n, scale, floor):
    """A random symmetric positive definite matrix, eigenvalues above ``scale * floor``."""
    B = rng.standard_normal((n, n))
    return scale * (B @ B.T / n + floor * np.eye(n))


@_case("original_skf", 1, "The original SKF of Lahtinen et al. (2024).", "fixed orientation")
def _original_skf(rng):
    L = rng.standard_normal((6, 4))
    Y = _data(rng, L, 0.2 * np.eye(6))
    return dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.5, exponent=0.5, smoother=None)


@_case(
    "free_orientation",
    2,
    "Three positions of three columns each; every column is standardized on its own.",
    "free orientation (3 columns per position, MNE's order)",
)
def _free_orientation(rng):
    L = rng.standard_normal((6, 9))
    Y = _data(rng, L, 0.2 * np.eye(6))
    return dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.25, exponent=1.0, smoother=None)


@_case(
    "average_reference",
    3,
    "L and Y average referenced (rank n_channels - 1); L_unreferenced is L before it.",
    "average-referenced, rank-deficient lead field",
)
def _average_reference(rng):
    L_unreferenced = rng.standard_normal((6, 8)) + 1.0
    Y = _data(rng, L_unreferenced, 0.2 * np.eye(6))
    L, Y = L_unreferenced - L_unreferenced.mean(axis=0), Y - Y.mean(axis=0)
    inputs = dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.5, exponent=1.25)
    return inputs | dict(smoother="rts-standardized", L_unreferenced=L_unreferenced)


@_case("full_noise_cov", 4, "A full noise covariance R.")
def _full_noise_cov(rng):
    L = rng.standard_normal((6, 5))
    R = _spd(rng, 6, 0.02, 0.5)
    Y = _data(rng, L, np.linalg.cholesky(R))
    return dict(L=L, Y=Y, noise_cov=R, theta0=2.0, q=0.3, exponent=1.5, smoother="rts-state")


@_case("transition", 5, "A = 0.8 I instead of the random walk.")
def _transition(rng):
    L = rng.standard_normal((6, 5))
    Y = _data(rng, L, 0.2 * np.eye(6))
    inputs = dict(L=L, Y=Y, noise_cov=0.04, theta0=1.0, q=0.4, transition=0.8)
    return inputs | dict(exponent=1.25, smoother="rts-state")


@_case(
    "general_model",
    6,
    "Full matrices A, P_0 and Q: the general linear-Gaussian model (not the spectral path's).",
)
def _general_model(rng):
    L = rng.standard_normal((5, 4))
    R = _spd(rng, 5, 0.05, 0.5)
    Y = _data(rng, L, np.linalg.cholesky(R))
    A = 0.9 * np.eye(4) + 0.05 * rng.standard_normal((4, 4))
    theta0, q = _spd(rng, 4, 1.0, 0.5), _spd(rng, 4, 0.3, 0.2)
    inputs = dict(L=L, Y=Y, noise_cov=R, theta0=theta0, q=q, transition=A)
    return inputs | dict(exponent=1.0, smoother="rts-standardized")


def _priors(rng, convention, pm_snr_db, signal):
    """A lead field of order 1e2 and data of order 1e-6 (SI units), priors from the SNRs."""
    L = 100.0 * rng.standard_normal((6, 6))
    sigma = 1e-7
    Y = _data(rng, L, sigma * np.eye(6), scale=signal)
    extras = {}
    if convention == "toolbox":  # the toolbox divides the data by their maximum first
        scale = float(np.max(np.abs(Y)))
        extras = dict(data_scale=scale, Y_unscaled=Y)
        Y, sigma = Y / scale, sigma / scale
    theta0, q = priors_from_snr(L, sigma, pm_snr_db, 20.0, _N_TIMES, convention)
    snrs = dict(pm_snr_db=float(pm_snr_db), ep_snr_db=20.0, convention=convention)
    return dict(L=L, Y=Y, noise_cov=sigma**2, theta0=theta0, q=q, noise_std=sigma) | snrs | extras


@_case(
    "priors_gain",
    7,
    "The paper's setting with the unit-free amplitude (docs/model.md §4).",
    "priors from PM-SNR 0 dB, EP-SNR 20 dB, gain convention",
)
def _priors_gain(rng):
    return _priors(rng, "gain", 0.0, 1e-8) | dict(exponent=1.25, smoother="rts-standardized")


@_case(
    "priors_toolbox",
    8,
    "The paper's setting as the toolbox computes it (docs/model.md §4).",
    "priors from PM-SNR 0 dB, EP-SNR 20 dB, toolbox convention",
    "toolbox data scaling (Y / max|Y|, noise_std relative to it)",
)
def _priors_toolbox(rng):
    return _priors(rng, "toolbox", 0.0, 1e-8) | dict(exponent=1.25, smoother="rts-standardized")


@_case(
    "priors_toolbox_clamped",
    9,
    "PM-SNR 20 dB on data of about 10 dB SNR: the toolbox lowers it to SNR - 1 dB.",
    "toolbox convention with PM-SNR clamped to SNR - 1 dB",
    "toolbox data scaling (Y / max|Y|, noise_std relative to it)",
)
def _priors_toolbox_clamped(rng):
    return _priors(rng, "toolbox", 20.0, 2e-10) | dict(exponent=0.5, smoother=None)


def _exercises(inputs, own):
    """What a case exercises: its own tags, then those its inputs show."""
    alpha, smoother, A = inputs["exponent"], inputs["smoother"], inputs["transition"]
    noise = "full noise covariance" if np.ndim(inputs["noise_cov"]) else "scalar noise covariance"
    if np.ndim(A):
        transition = "transition matrix"
    else:
        transition = "random walk (transition 1)" if A == 1 else f"transition {A:g}"
    tags = [*own, noise, f"exponent {alpha:g}", smoother or "no smoothing", transition]
    if np.ndim(inputs["theta0"]) or np.ndim(inputs["q"]):
        tags.append("theta0 and q matrices")
    return tuple(tags)


def as_value(value):
    """``value`` as a float if it is a scalar, else as a read-only float array (a copy)."""
    return float(value) if np.ndim(value) == 0 else readonly(np.array(value, dtype=float))


def _build(name, seed, description, own, builder):
    values = {"transition": 1.0, **builder(np.random.default_rng((_SEED, seed)))}
    inputs = {key: values.pop(key) for key in INPUTS}
    inputs = {k: v if isinstance(v, str | None) else as_value(v) for k, v in inputs.items()}
    extras = {k: v if isinstance(v, str) else as_value(v) for k, v in values.items()}
    case = Case(name, description, _exercises(inputs, own), inputs, {}, extras)
    rec = case.reconstruct("dense")
    case.expected.update({key: as_value(getattr(rec, key)) for key in OUTPUTS})
    return case


_CASES = []


def cases():
    """The conformance cases, computed once per process.

    Returns
    -------
    list of Case

    Examples
    --------
    >>> [case.name for case in cases()][:3]
    ['original_skf', 'free_orientation', 'average_reference']
    >>> cases()[0].shape
    (4, 7)
    """
    if not _CASES:
        _CASES.extend(_build(*spec) for spec in _SPECS)
    return list(_CASES)
