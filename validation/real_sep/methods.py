"""Each family of :mod:`validation.real_sep.settings` on a recording: amplitudes on its positions.

MNE-Python computes its own methods here (``mne.minimum_norm``, ``mne.beamformer``,
``mne.inverse_sparse``); skf_ref the SKF (:func:`skf_ref.apply_skf`). Every method returns the
amplitude at each position of the forward (absolute value for a fixed orientation, norm over
the three for a free one), zero where a sparse estimate has no source.

**nave.** MNE's minimum-norm methods and :func:`skf_ref.apply_skf` (since 0.4.0) divide the
noise covariance by ``evoked.nave``: they get the recording's evoked and covariance as they
are. LCMV and MxNE do not; they get :func:`of_average`: the average's own covariance and an
evoked whose ``nave`` is 1, the same whitening.
"""

import inspect
import time

import numpy as np
from scipy.optimize import brentq

import skf_ref
from skf_ref.datasets import baseline_noise_cov

#: lambda2 is searched in 10**[-8, 4]; outside, the bound is kept and flagged.
LOG10_LAMBDA2 = (-8.0, 4.0)
#: MxNE's depth weighting: MNE's default.
MXNE_DEPTH = 0.8


def of_average(recording):
    """The evoked with ``nave`` 1 and the covariance of the average (module docstring)."""
    evoked = recording.evoked.copy()
    evoked.nave = 1
    cov = recording.noise_cov.copy()
    cov["data"] = recording.noise_cov["data"] / recording.evoked.nave
    return evoked, cov


def _fixed(recording):
    return recording.orientations is not None


def amplitude_on_positions(stc, recording):
    """The estimate's rows on the forward's positions (zero where it has none)."""
    vertno = recording.forward["src"][0]["vertno"]
    amplitude = np.zeros((len(vertno), stc.data.shape[1]))
    amplitude[np.searchsorted(vertno, stc.vertices[0])] = np.abs(stc.data)
    return amplitude


def discrepancy_lambda2(evoked, inverse, tmin=0.0):
    """lambda2 at which the minimum norm's whitened residual is the noise's expected energy.

    Over the samples after ``tmin``: ``sum_t ||W (y_t - G x_t)||^2 = rank * n_samples``, in
    the basis of MNE's prepared operator (its whitener, projector, singular values ``s`` and
    eigenfields ``U``): the residual's coefficient along ``U_k`` is ``lambda2 / (s_k^2 +
    lambda2)`` times the data's. Returns ``(lambda2, solved)``; unsolved, the nearer bound.
    """
    from mne.minimum_norm import prepare_inverse_operator

    inv = prepare_inverse_operator(inverse, evoked.nave, 1.0, "MNE", verbose=False)
    names = inv["noise_cov"]["names"]
    rows = [evoked.ch_names.index(name) for name in names]
    data = evoked.data[np.ix_(rows, np.flatnonzero(evoked.times > tmin))]
    whitened = inv["whitener"] @ inv["proj"] @ data
    coefficients = inv["eigen_fields"]["data"] @ whitened
    energy = (coefficients**2).sum(axis=1)
    outside = float((whitened**2).sum() - energy.sum())
    s2 = inv["sing"] ** 2
    target = np.linalg.matrix_rank(inv["whitener"]) * data.shape[1]

    def excess(log10_lambda2):
        lam = 10.0**log10_lambda2
        return float(((lam / (s2 + lam)) ** 2 * energy).sum() + outside - target)

    low, high = LOG10_LAMBDA2
    if excess(low) > 0:
        return 10.0**low, False
    if excess(high) < 0:
        return 10.0**high, False
    return 10.0 ** brentq(excess, low, high, xtol=1e-6), True


#: The SKF's prior parameters among a setting's parameters: the rest go to apply_skf as given.
PRIOR_KEYS = ("pm_snr_db", "ep_snr_db", "time_constant_ms")


def _skf_note(priors, chosen):
    """What the SKF's priors were: PM-SNR and EP-SNR (walk) or time constant (AR(1))."""
    if chosen is not None:
        pm, ep, tau = chosen.pm_snr_db, chosen.ep_snr_db, chosen.time_constant_ms
    else:
        pm, ep, tau = (priors.get(k) for k in PRIOR_KEYS)
    note = f"PM {pm:.1f} / EP {ep:.1f} dB" if tau is None else f"PM {pm:.1f} dB / tau {tau:.3g} ms"
    bounds = ", ".join(
        f"{k} at its {v} bound" for k, v in (chosen.at_bound if chosen else {}).items()
    )
    return note + (f" ({bounds})" if bounds else "")


def _skf(recording, params):
    evoked, cov = recording.evoked, recording.noise_cov
    priors = {k: params[k] for k in PRIOR_KEYS if k in params}
    setting = {k: v for k, v in params.items() if k not in (*PRIOR_KEYS, "priors")}
    stc, rec = skf_ref.apply_skf(
        evoked,
        recording.forward,
        cov,
        **priors,
        **setting,
        return_reconstruction=True,
        verbose=False,
    )
    return amplitude_on_positions(stc, recording), _skf_note(priors, rec.tuning)


_INVERSES = {}  # one inverse operator per recording (its name), made once


def _inverse(recording):
    from mne.minimum_norm import make_inverse_operator

    if recording.name not in _INVERSES:
        _INVERSES[recording.name] = make_inverse_operator(
            recording.evoked.info,
            recording.forward,
            recording.noise_cov,
            loose=0.0 if _fixed(recording) else 1.0,
            depth=None,
            verbose=False,
        )
    return _INVERSES[recording.name]


def _minimum_norm(recording, params):
    from mne.minimum_norm import apply_inverse

    inverse = _inverse(recording)
    lambda2, note = params["lambda2"], ""
    if lambda2 == "discrepancy":
        lambda2, solved = discrepancy_lambda2(recording.evoked, inverse)
        note = "" if solved else " (no root: the bound)"
    stc = apply_inverse(recording.evoked, inverse, lambda2, params["method"], verbose=False)
    return amplitude_on_positions(stc, recording), f"lambda2 {lambda2:.3g}{note}"


def _lcmv(recording, params):
    import mne

    evoked, cov = of_average(recording)
    data_cov = baseline_noise_cov(evoked, 0.0, float(evoked.times[-1]), reg=0.0)
    filters = mne.beamformer.make_lcmv(
        evoked.info,
        recording.forward,
        data_cov,
        reg=params["reg"],
        noise_cov=cov,
        verbose=False,
    )
    stc = mne.beamformer.apply_lcmv(evoked, filters, verbose=False)
    return amplitude_on_positions(stc, recording), f"reg {params['reg']:g}"


def _mxne(recording, params):
    from mne.inverse_sparse import mixed_norm

    evoked, cov = of_average(recording)
    seed = {"rng": 0} if "rng" in inspect.signature(mixed_norm).parameters else {}
    stc = mixed_norm(
        evoked,
        recording.forward,
        cov,
        alpha=params["alpha"],
        loose=0.0 if _fixed(recording) else 1.0,
        depth=MXNE_DEPTH,
        verbose=False,
        **seed,
    )
    active = len(stc.vertices[0])
    return amplitude_on_positions(stc, recording), f"alpha {params['alpha']}, {active} sources"


FAMILIES = {"skf": _skf, "minimum_norm": _minimum_norm, "lcmv": _lcmv, "mxne": _mxne}


def run(recording, family, params):
    """One setting on one recording.

    Returns
    -------
    amplitude : ndarray, shape (n_positions, n_times)
    note : str
        What was chosen (priors, lambda2, active sources).
    seconds : float
        Wall time; ``cpu`` the process's CPU time over it.
    cpu : float
    """
    wall, cpu = time.perf_counter(), time.process_time()
    amplitude, note = FAMILIES[family](recording, params)
    return amplitude, note, time.perf_counter() - wall, time.process_time() - cpu
