"""Reconstructions as MNE source estimates: the way back to MNE-Python's tools.

The class follows the source space (surface, volume or discrete, mixed) and ``pick_ori``, as
MNE's ``apply_inverse`` names it:

- ``None``: for free orientation, the per-position amplitude (the norm of a position's three
  components); for fixed orientation, the signed standardized estimate ``z``, one value per
  position: ``SourceEstimate`` / ``VolSourceEstimate`` / ``MixedSourceEstimate``;
- ``"vector"``: free orientation's three components in MNE's x, y, z (head coordinates):
  ``VectorSourceEstimate`` / ``VolVectorSourceEstimate`` / ``MixedVectorSourceEstimate``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._utils.checks import InputError, check_choice, check_real
from .._utils.extras import optional

__all__ = ["PICK_ORIS", "STC_CLASSES", "StcLayout", "make_stc", "stc_layout"]

#: What a source estimate can show, in MNE's words (``pick_ori`` of ``apply_inverse``).
PICK_ORIS = (None, "vector")

_CLASSES = {
    ("surface", False): "SourceEstimate",
    ("surface", True): "VectorSourceEstimate",
    ("volume", False): "VolSourceEstimate",
    ("volume", True): "VolVectorSourceEstimate",
    ("mixed", False): "MixedSourceEstimate",
    ("mixed", True): "MixedVectorSourceEstimate",
}
#: The names of MNE's source estimate classes a reconstruction can become.
STC_CLASSES = tuple(_CLASSES.values())


def make_stc(
    reconstruction: Any,
    src: Any,
    tmin: float,
    tstep: float,
    subject: str | None = None,
    pick_ori: str | None = None,
    *,
    layout: StcLayout | None = None,
) -> Any:
    """An MNE source estimate of a reconstruction on the source space it was computed on.

    Parameters
    ----------
    reconstruction : skf_ref.Reconstruction
        With ``n_sources`` = the number of source-space positions (fixed orientation) or
        three times it (free orientation, MNE's column order).
    src : mne.SourceSpaces
        The forward model's source space (``forward["src"]``).
    tmin : float
        Time of the first sample, seconds.
    tstep : float
        Time between samples, seconds (``1 / sfreq``).
    subject : str, optional
        Default: the source space's subject.
    pick_ori : {None, "vector"}
        See the module docstring.
    layout : StcLayout, optional
        ``stc_layout``'s answer for ``src`` and ``pick_ori``, when many estimates
        share it (a prepared operator keeps it).

    Returns
    -------
    mne.SourceEstimate or mne.VolSourceEstimate or mne.MixedSourceEstimate or vector kin
        Data (n_positions, n_times), or (n_positions, 3, n_times) for ``"vector"``.
    """
    mne = optional("mne", "mne", "make_stc")

    tmin, tstep = check_real("tmin", tmin), check_real("tstep", tstep, positive=True)
    if layout is None:
        layout = stc_layout(reconstruction.n_sources, src, pick_ori)
    n_positions = len(layout.vertices_flat)
    if pick_ori == "vector":
        data = reconstruction.z.reshape(n_positions, 3, -1)
    elif layout.components == 3:
        data = reconstruction.amplitude(3)
    else:
        data = reconstruction.z
    subject = subject if subject is not None else layout.subject
    stc_class = getattr(mne, layout.class_name)
    data = np.require(data, float, ["W"])  # z is read-only: a copy; an amplitude is new
    return stc_class(data, vertices=layout.vertices, tmin=tmin, tstep=tstep, subject=subject)


@dataclass(frozen=True)
class StcLayout:
    """What a source estimate of a reconstruction on a source space looks like.

    Attributes
    ----------
    vertices : list of ndarray
        Per source space, as MNE's source estimates hold them.
    components : int
        Reconstruction rows per position: 3 (free orientation) or 1 (fixed).
    class_name : str
        The MNE class (``"VolSourceEstimate"``, ...).
    subject : str or None
        The source space's subject.
    """

    vertices: list[np.ndarray]
    components: int
    class_name: str
    subject: str | None

    @property
    def vertices_flat(self) -> np.ndarray:
        """ndarray : Every position's vertex number, source spaces one after the other."""
        return np.concatenate(self.vertices)


def stc_layout(n_sources: int, src: Any, pick_ori: str | None = None) -> StcLayout:
    """The layout of a source estimate of ``n_sources`` rows on ``src``, or a clear error.

    Parameters
    ----------
    n_sources : int
        Rows of the reconstruction.
    src : mne.SourceSpaces
    pick_ori : {None, "vector"}

    Returns
    -------
    StcLayout
    """
    mne = optional("mne", "mne", "make_stc")

    check_choice("pick_ori", pick_ori, PICK_ORIS)
    if not isinstance(src, mne.SourceSpaces):
        raise InputError(f"src must be an mne.SourceSpaces, got {type(src).__name__}")
    vertices = [np.asarray(s["vertno"]) for s in src]
    n_positions = sum(len(v) for v in vertices)
    components, remainder = divmod(n_sources, n_positions)
    if remainder or components not in (1, 3):
        raise InputError(
            f"the reconstruction has {n_sources} sources; the source space "
            f"has {n_positions} positions, so it needs {n_positions} (fixed orientation) "
            f"or {3 * n_positions} (free orientation)"
        )
    if pick_ori == "vector" and components == 1:
        raise InputError(
            "pick_ori='vector' needs free orientation (three columns per position); this "
            "reconstruction has fixed orientation: use pick_ori=None"
        )
    src_kind = "volume" if src.kind == "discrete" else src.kind
    class_name = _CLASSES[src_kind, pick_ori == "vector"]
    return StcLayout(vertices, components, class_name, src[0].get("subject_his_id"))
