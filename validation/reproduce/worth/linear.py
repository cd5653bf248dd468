"""Linear methods as exact responses: what each one outputs for a unit source and for noise.

With fixed priors, the SKF (every smoother and standardization) and MNE's minimum-norm
methods are linear in the data. A source of field ``g`` carrying waveform ``s`` gives data
``g s^T``; a method's output at sample t is then ``R_s(t) g`` with ``R_s(t)`` the method's
response to each channel alone carrying ``s`` (n_columns x n_channels). :class:`Response`
holds those responses at the two peak samples for every column, at every sample for the
columns near the thalamus (time courses), and the outputs of a pool of noise draws at the
same places. Every estimate of the study is then a sum of these: exact, without running the
method on each of thousands of data sets. Data are in whitened units (noise standard
deviation 1, white): a data set's signal is its field times its waveform over sigma.

- :func:`skf_response`: the SKF, by applying it to each channel alone (n_channels runs);
- :func:`static_response`: a kernel ``K`` (MNE's, :func:`mne_kernel`), optionally on data
  filtered in time by a window ``h`` (the temporal control, :func:`skf_window`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from skf_ref._utils.atomic_files import atomic_path

__all__ = [
    "Response",
    "matched_lambda2",
    "mne_kernel",
    "noise_parts",
    "signal_parts",
    "skf_response",
    "skf_window",
    "static_response",
]


@dataclass(frozen=True, eq=False)
class Response:
    """A linear method's responses in one design.

    Attributes
    ----------
    at : dict
        (waveform name, sample) -> ndarray (n_columns, n_channels).
    near : dict
        Waveform name -> ndarray (n_times, n_near_columns, n_channels).
    noise_at : dict
        Sample -> ndarray (n_columns, n_draws): the outputs of the pool's draws.
    noise_near : ndarray, shape (n_times, n_near_columns, n_draws)
    """

    at: dict = field(repr=False)
    near: dict = field(repr=False)
    noise_at: dict = field(repr=False)
    noise_near: np.ndarray = field(repr=False)


def signal_parts(outputs, waveforms, samples, near_columns, n_channels):
    """``at`` and ``near`` of a :class:`Response`: ``outputs`` applied to each channel alone.

    Parameters
    ----------
    outputs : callable
        Data (n_channels, n_times) -> the method's output (n_columns, n_times).
    waveforms : dict
        Name -> ndarray (n_times,).
    samples : sequence of int
    near_columns : ndarray of int
    n_channels : int
    """
    at, near = {}, {}
    for name, wave in waveforms.items():
        near[name] = np.empty((len(wave), len(near_columns), n_channels))
        for c in range(n_channels):
            Y = np.zeros((n_channels, len(wave)))
            Y[c] = wave
            z = outputs(Y)
            for t in samples:
                at.setdefault((name, t), np.empty((z.shape[0], n_channels)))[:, c] = z[:, t]
            near[name][:, :, c] = z[near_columns].T
    return at, near


def noise_parts(outputs, pool, samples, near_columns):
    """``noise_at`` and ``noise_near`` of a :class:`Response`: the pool's draws applied."""
    n_draws, _, n_times = pool.shape
    noise_at = {}
    noise_near = np.empty((n_times, len(near_columns), n_draws))
    for k in range(n_draws):
        z = outputs(pool[k])
        for t in samples:
            noise_at.setdefault(t, np.empty((z.shape[0], n_draws)))[:, k] = z[:, t]
        noise_near[:, :, k] = z[near_columns].T
    return noise_at, noise_near


def skf_response(prepared, setting, waveforms, samples, near_columns, pool, signal=None):
    """The SKF's responses (``prepared``: :class:`.skf.Prepared` for this design's length).

    Parameters
    ----------
    prepared : Prepared
    setting : SKFSetting
    waveforms : dict
        Name -> ndarray (n_times,).
    samples : sequence of int
    near_columns : ndarray of int
    pool : ndarray, shape (n_draws, n_channels, n_times)
    signal : (dict, dict), optional
        ``at`` and ``near`` already computed (they do not depend on the noise pool).

    Returns
    -------
    Response
    """

    def outputs(Y):
        return prepared.z(Y, setting)

    if signal is None:
        signal = signal_parts(outputs, waveforms, samples, near_columns, pool.shape[1])
    return Response(*signal, *noise_parts(outputs, pool, samples, near_columns))


def static_response(K, waveforms, samples, near_columns, pool, window=None):
    """The responses of a static kernel, on data filtered in time by ``window``.

    Parameters
    ----------
    K : ndarray, shape (n_columns, n_channels)
    waveforms, samples, near_columns, pool
        As for :func:`skf_response`.
    window : ndarray, shape (n_times, n_times), optional
        ``ybar_t = sum_tau window[t, tau] y_tau``; None: the data as they are.
    """
    n_draws, n_channels, n_times = pool.shape
    h = np.eye(n_times) if window is None else np.asarray(window)
    filtered = {name: h @ wave for name, wave in waveforms.items()}  # (n_times,)
    at = {(name, t): wave[t] * K for name, wave in filtered.items() for t in samples}
    near_K = K[near_columns]
    near = {name: wave[:, None, None] * near_K[None] for name, wave in filtered.items()}
    noise = np.einsum("tu,kcu->tck", h, pool)  # (n_times, n_channels, n_draws)
    noise_at = {t: K @ noise[t] for t in samples}
    noise_near = np.einsum("nc,tck->tnk", near_K, noise)
    return Response(at, near, noise_at, noise_near)


def skf_window(prepared, direction, smooths):
    """The SKF's effective window: its state estimate's impulse response along a direction.

    ``h(t, tau) = u^T L x_t`` for data ``u e_tau^T`` (an impulse at sample tau along the
    unit direction u), normalized over tau to sum 1.

    Parameters
    ----------
    prepared : Prepared
    direction : ndarray, shape (n_channels,)
        u: the leading direction of the thalamic fields.
    smooths : bool
        The RTS-smoothed state (a smoothed setting) or the filtered means.

    Returns
    -------
    ndarray, shape (n_times, n_times)
    """
    u = np.asarray(direction, dtype=float)
    u = u / np.linalg.norm(u)
    n_times = prepared.n_times
    response = np.empty((n_times, n_times))
    for tau in range(n_times):
        Y = np.zeros((len(u), n_times))
        Y[:, tau] = u
        response[:, tau] = u @ (prepared.L @ prepared.state(Y, smooths))
    total = response.sum(axis=1, keepdims=True)
    if not (total > 0).all():
        raise RuntimeError("the SKF's window has a non-positive total at some sample")
    return response / total


def matched_lambda2(pm_snr_db, n_channels, rank):
    """MNE's lambda2 equal to the SKF's prior at PM-SNR: ``10^(-PM/10) rank / n_channels``.

    MNE scales the whitened gain to a squared norm equal to the whitener's rank; the SKF's
    gain convention sets the prior so that ``theta0 ||L~||_F^2 = 10^(PM/10) n_channels``.

    Examples
    --------
    >>> matched_lambda2(0.0, 64, 63)
    0.984375
    """
    return 10.0 ** (-pm_snr_db / 10.0) * rank / n_channels


_INVERSE = {}


def _unit_inverse(head):
    """The head's inverse operator for white unit noise, and the identity as an evoked."""
    from types import SimpleNamespace

    from skf_ref.study.baselines import inverse_operator, mne_data

    key = id(head)
    if key not in _INVERSE:
        n = head.n_channels
        unit = SimpleNamespace(Y=np.eye(n), times=np.arange(n) / 1000.0, noise_cov=np.eye(n))
        inverse = inverse_operator(head, unit)
        # each prepare_inverse_operator copies the operator whole: without the volume
        # grids' per-voxel neighbour lists (which no kernel reads) that takes 0.03 s, not 0.2
        inverse["src"] = inverse["src"].copy()
        for space in inverse["src"]:
            space.pop("neighbor_vert", None)
        _INVERSE.clear()
        _INVERSE[key] = (head, inverse, mne_data(head, unit)[0])
    return _INVERSE[key][1:]


def mne_kernel(head, method, lambda2, cache=None):
    """MNE's kernel of a minimum-norm method on whitened data, (n_columns, n_channels).

    The inverse operator of the head (free orientation, no depth weighting, noise covariance
    the identity, the average reference), prepared for ``method`` and ``lambda2``, applied by
    ``apply_inverse`` to each channel alone (``pick_ori="vector"``): the components of every
    position, in MNE's order. ``cache``: a folder where kernels are kept between processes.
    """
    from mne.minimum_norm import apply_inverse, prepare_inverse_operator

    path = None
    if cache is not None:
        path = Path(cache) / f"kernel-{method}-{lambda2:.12g}.npy"
        if path.exists():
            return np.load(path)
    inverse, evoked = _unit_inverse(head)
    inverse = prepare_inverse_operator(inverse, 1, lambda2, method, verbose=False)
    stc = apply_inverse(
        evoked, inverse, lambda2, method, pick_ori="vector", prepared=True, verbose=False
    )
    kernel = np.asarray(stc.data).reshape(-1, head.n_channels)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            np.save(tmp, kernel)
    return kernel
