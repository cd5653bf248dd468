"""Reconstructions as MNE source estimates: the way back to MNE-Python's tools.

The class follows the source space (surface, volume or discrete, mixed) and what is shown:

- ``"amplitude"``: the per-position amplitude (the norm of a position's three components for
  free orientation, ``|z|`` for fixed): ``SourceEstimate`` / ``VolSourceEstimate`` /
  ``MixedSourceEstimate``;
- ``"vector"``: free orientation's three components in MNE's x, y, z (head coordinates):
  ``VectorSourceEstimate`` / ``VolVectorSourceEstimate`` / ``MixedVectorSourceEstimate``;
- ``"z"``: the signed standardized estimate of a fixed-orientation model, one value per
  position, in the scalar class.
"""

import numpy as np

from .._utils.checks import InputError, check_choice, check_real
from .._utils.extras import optional

__all__ = ["KINDS", "make_stc"]

#: What a source estimate can show.
KINDS = ("amplitude", "vector", "z")

_CLASSES = {
    ("surface", False): "SourceEstimate",
    ("surface", True): "VectorSourceEstimate",
    ("volume", False): "VolSourceEstimate",
    ("volume", True): "VolVectorSourceEstimate",
    ("mixed", False): "MixedSourceEstimate",
    ("mixed", True): "MixedVectorSourceEstimate",
}


def make_stc(reconstruction, src, tmin, tstep, subject=None, kind="amplitude"):
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
    kind : {"amplitude", "vector", "z"}
        See the module docstring.

    Returns
    -------
    mne.SourceEstimate or mne.VolSourceEstimate or mne.MixedSourceEstimate or vector kin
        Data (n_positions, n_times), or (n_positions, 3, n_times) for ``"vector"``.
    """
    mne = optional("mne", "mne", "make_stc")

    check_choice("kind", kind, KINDS)
    if not isinstance(src, mne.SourceSpaces):
        raise InputError(f"src must be an mne.SourceSpaces, got {type(src).__name__}")
    tmin, tstep = check_real("tmin", tmin), check_real("tstep", tstep, positive=True)
    vertices = [np.asarray(s["vertno"]) for s in src]
    n_positions = sum(len(v) for v in vertices)
    components, remainder = divmod(reconstruction.n_sources, n_positions)
    if remainder or components not in (1, 3):
        raise InputError(
            f"the reconstruction has {reconstruction.n_sources} sources; the source space "
            f"has {n_positions} positions, so it needs {n_positions} (fixed orientation) "
            f"or {3 * n_positions} (free orientation)"
        )
    if kind == "amplitude":
        data = reconstruction.amplitude(components)
    elif components == 3 and kind == "vector":
        data = reconstruction.z.reshape(n_positions, 3, -1)
    elif components == 1 and kind == "z":
        data = reconstruction.z
    else:
        orientation = "free" if components == 3 else "fixed"
        raise InputError(
            f"kind={kind!r} needs {'free' if kind == 'vector' else 'fixed'} orientation; "
            f"this reconstruction has {orientation} orientation: use kind='amplitude'"
            + (" or 'vector'" if components == 3 else " or 'z'")
        )
    src_kind = "volume" if src.kind == "discrete" else src.kind
    stc_class = getattr(mne, _CLASSES[src_kind, kind == "vector"])
    subject = subject if subject is not None else src[0].get("subject_his_id")
    return stc_class(np.array(data), vertices=vertices, tmin=tmin, tstep=tstep, subject=subject)
