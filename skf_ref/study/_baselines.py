"""MNE-Python's inverse methods on the study's heads: what the SKF is compared with.

MNE computes them; this module only hands MNE the study's head, simulated data and noise
covariance as MNE objects, and maps MNE's source estimates back onto the head's positions as
amplitudes (the norm over the three orientations, as for the SKF), so that every method is
scored by the same metrics (:func:`skf_ref.study._metrics.summarize`).

- :func:`mne_data`: an ``mne.EvokedArray`` of a simulation with MNE's average-reference
  projector, and the ``mne.Covariance`` its noise was drawn from;
- ``inverse_operator`` / :func:`apply_minimum_norm`: MNE's minimum norm, dSPM, sLORETA
  and eLORETA (``mne.minimum_norm``), free orientation, no depth weighting (the SKF has
  none), one operator for many data sets;
- :func:`amplitude_on_positions`: an MNE estimate's rows on the head's positions (sparse
  estimates, MxNE's, hold only their active positions).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    import mne
    from mne.minimum_norm import InverseOperator

    from ._head import HeadModel
    from ._scenario import Simulation

__all__ = [
    "MINIMUM_NORM_METHODS",
    "amplitude_on_positions",
    "apply_minimum_norm",
    "inverse_operator",
    "mne_data",
]

#: MNE's four minimum-norm methods (``mne.minimum_norm.apply_inverse``'s names).
MINIMUM_NORM_METHODS = ("MNE", "dSPM", "sLORETA", "eLORETA")


def mne_data(head: HeadModel, sim: Simulation) -> tuple[mne.EvokedArray, mne.Covariance]:
    """The simulation as MNE objects: the evoked and its noise covariance.

    Parameters
    ----------
    head : HeadModel
        The head the data were simulated on (its ``info``).
    sim : Simulation
        Data of ``head`` (:func:`skf_ref.study._scenario.simulate`).

    Returns
    -------
    evoked : mne.EvokedArray
        ``sim.Y`` (V) on the head's channels, with an average-reference projector.
    noise_cov : mne.Covariance
        ``sim.noise_cov``, the covariance the noise was drawn from.
    """
    import mne

    info = head.info.copy()
    evoked = mne.EvokedArray(sim.Y, info, tmin=float(sim.times[0]), verbose=False)
    if not evoked.info["projs"]:
        evoked.set_eeg_reference("average", projection=True, verbose=False)
    cov = mne.Covariance(
        np.asarray(sim.noise_cov), evoked.ch_names, bads=[], projs=[], nfree=1000, verbose=False
    )
    return evoked, cov


def inverse_operator(head: HeadModel, sim: Simulation) -> InverseOperator:
    """MNE's inverse operator for the head, free orientation, no depth weighting.

    Parameters
    ----------
    head : HeadModel
        The head (its forward model, ``head.fwd``).
    sim : Simulation
        Any simulation of ``head`` with the noise covariance to use.

    Returns
    -------
    mne.minimum_norm.InverseOperator
        For :func:`apply_minimum_norm`, any data of the head.
    """
    from mne.minimum_norm import make_inverse_operator

    evoked, cov = mne_data(head, sim)
    return make_inverse_operator(evoked.info, head.fwd, cov, loose=1.0, depth=None, verbose=False)


def apply_minimum_norm(
    head: HeadModel,
    sim: Simulation,
    inverse: InverseOperator,
    method: str = "sLORETA",
    lambda2: float = 1.0 / 9.0,
    prepared: bool = False,
) -> NDArray[np.float64]:
    """One of MNE's minimum-norm estimates of a simulation, as amplitudes on the positions.

    Parameters
    ----------
    head : HeadModel
        The head the data were simulated on.
    sim : Simulation
        The data to reconstruct.
    inverse : mne.minimum_norm.InverseOperator
        From ``inverse_operator``.
    method : {"MNE", "dSPM", "sLORETA", "eLORETA"}
        MNE's method.
    lambda2 : float
        MNE's regularization, 1 / SNR² (1/9: MNE's usual value for evoked data).
    prepared : bool
        Whether ``inverse`` was prepared for ``method`` and ``lambda2`` (and one average)
        by ``mne.minimum_norm.prepare_inverse_operator``: many data sets, one preparation.

    Returns
    -------
    ndarray, shape (n_positions, n_times)
        The norm over the three orientations at each position.
    """
    from mne.minimum_norm import apply_inverse

    from .._utils.checks import check_choice, check_real

    check_choice("method", method, MINIMUM_NORM_METHODS)
    regularization = check_real("lambda2", lambda2, positive=True)
    evoked = mne_data(head, sim)[0]
    stc = apply_inverse(evoked, inverse, regularization, method, prepared=prepared, verbose=False)
    return amplitude_on_positions(stc, head)


def amplitude_on_positions(stc: Any, head: Any) -> NDArray[np.float64]:
    """An MNE estimate's rows on the head's positions, zero where it has none.

    Parameters
    ----------
    stc : mne.VolSourceEstimate or mne.SourceEstimate
        With ``pick_ori=None``: one non-negative row per active position.
    head : HeadModel
        Whose ``fwd["src"]`` the estimate's vertices index.

    Returns
    -------
    ndarray, shape (n_positions, n_times)
        The absolute value of the estimate's row at each of its positions.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> src = [{"vertno": np.array([2, 5, 9])}, {"vertno": np.array([1, 4])}]
    >>> head = SimpleNamespace(fwd={"src": src}, positions=np.zeros((5, 3)))
    >>> stc = SimpleNamespace(vertices=[np.array([5]), np.array([1, 4])],
    ...                       data=np.array([[1.0], [-2.0], [3.0]]))
    >>> amplitude_on_positions(stc, head)[:, 0]
    array([0., 1., 0., 2., 3.])
    """
    src = head.fwd["src"]
    offsets = np.cumsum([0] + [len(s["vertno"]) for s in src])
    amplitude = np.zeros((len(head.positions), stc.data.shape[1]))
    start = 0
    for k, vertices in enumerate(stc.vertices):
        rows = offsets[k] + np.searchsorted(src[k]["vertno"], vertices)
        amplitude[rows] = np.abs(stc.data[start : start + len(vertices)])
        start += len(vertices)
    return amplitude
