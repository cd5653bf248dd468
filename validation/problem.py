"""The benchmarks' problem: one size's head model, data and priors, and what each row records.

:mod:`validation.bench` (every path) and :mod:`validation.floor` (the smoothed z against its
floor) both time :func:`skf_runner` on a :func:`make_problem`, and record the BLAS each
timing ran with (:func:`blas_columns`); they import it from here, neither from the other.
"""

from collections.abc import Callable
from typing import Any

import numpy as np

from skf_ref._utils.provenance import blas_threads

__all__ = ["MONTAGES", "blas_columns", "make_problem", "skf_runner"]

#: The BioSemi montage of each channel count.
MONTAGES = {32: "biosemi32", 64: "biosemi64", 128: "biosemi128", 256: "biosemi256"}


def make_problem(n_columns: int, n_channels: int, n_times: int, seed: int = 0) -> dict[str, Any]:
    """Head model, data and SNR priors for one benchmark size.

    Parameters
    ----------
    n_columns : int
        Lead-field columns, three per position (free orientation).
    n_channels : int
        One of the BioSemi montage sizes (32, 64, 128, 256).
    n_times : int
        Time steps of the data.
    seed : int
        Seed of the dipole's column and the noise.

    Returns
    -------
    dict
        ``head`` (:class:`skf_ref.study._scenario.HeadModel`), ``Y`` (n_channels, n_times),
        ``noise_std``, ``theta0``, ``q``.
    """
    from skf_ref import priors_from_snr
    from skf_ref.study._scenario import make_head_model

    if n_channels not in MONTAGES:
        raise ValueError(f"n_channels must be one of {sorted(MONTAGES)}, got {n_channels}")
    head = make_head_model(n_positions=n_columns // 3, montage=MONTAGES[n_channels])
    rng = np.random.default_rng(seed)
    L = head.leadfield
    column = int(rng.integers(L.shape[1]))
    waveform = 10e-9 * np.sin(2 * np.pi * np.arange(n_times) / 40)
    clean = np.outer(L[:, column], waveform)
    noise_std = 0.1 * np.max(np.abs(clean))
    Y = clean + noise_std * rng.standard_normal(clean.shape)
    theta0, q = priors_from_snr(L, noise_std, pm_snr_db=0, ep_snr_db=20, n_steps=n_times)
    return dict(head=head, Y=Y, noise_std=noise_std, theta0=theta0, q=q)


def skf_runner(problem: dict[str, Any], path: str) -> Callable[[], np.ndarray]:
    """``reconstruct(...).z`` of ``problem``, smoothed ("rts-standardized", exponent 1.25).

    Parameters
    ----------
    problem : dict
        As :func:`make_problem` returns.
    path : {"dense", "filterpy", "spectral"}
        The path (``reconstruct``'s ``path``).

    Returns
    -------
    callable
        Takes no argument; returns ``z``, shape (n_columns, n_times).
    """
    from skf_ref import reconstruct

    L = problem["head"].leadfield

    def run() -> np.ndarray:
        rec = reconstruct(
            L,
            problem["Y"],
            noise_std=problem["noise_std"],
            theta0=problem["theta0"],
            q=problem["q"],
            exponent=1.25,
            smoother="rts-standardized",
            path=path,
        )
        return rec.z  # the spectral path computes outputs on access

    return run


def blas_columns(blas_limit: int | None = None) -> dict[str, Any]:
    """What the BLAS libraries run on now, as the columns every benchmark row records.

    Parameters
    ----------
    blas_limit : int, optional
        The ``--blas-threads`` limit the benchmark runs under (None: not limited).

    Returns
    -------
    dict
        ``blas``: each library with its version and threads, e.g.
        ``"openblas 0.3.30 (2 threads)"``, ``"; "``-separated (``"none"`` if none is
        loaded); ``blas_threads``: the largest thread count of any of them (1 if none);
        ``blas_limit``: ``blas_limit``, or ``"none"``.
    """
    blas = blas_threads()
    described = [
        f"{b['library']} {b['version']} ({b['threads']} thread{'s' * (b['threads'] != 1)})"
        for b in blas
    ]
    return dict(
        blas="; ".join(described) or "none",
        blas_threads=max((b["threads"] for b in blas), default=1),
        blas_limit="none" if blas_limit is None else blas_limit,
    )
