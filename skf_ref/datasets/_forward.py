"""MNE forward solutions for recordings without one: a lead field from elsewhere, or a sphere.

- :func:`forward_from_leadfield`: a lead field computed by another program (a FEM by
  duneuro, Zeffiro or SimNIBS; a BEM by OpenMEEG or FieldTrip), with one position and one
  orientation per column, as a fixed-orientation ``mne.Forward``. MNE-Python has no public
  constructor of a forward from a matrix (mne-python issue 10016). MNE makes the object here:
  a discrete source space of the positions and orientations
  (``mne.setup_volume_source_space(pos=dict(rr=..., nn=...))``), a forward on it from a
  sphere as large as the head (``mne.make_forward_solution``), turned to fixed orientation
  along the given orientations (``mne.convert_forward_solution``); only then is its gain
  replaced by the given lead field, in every place MNE keeps it, and marked as fixed from the
  start, as a fixed-orientation forward read from a file is. Every key is then MNE's own, of
  the MNE version installed; ``mne.minimum_norm.make_inverse_operator``,
  ``mne.beamformer.make_lcmv``, ``mne.inverse_sparse`` and ``mne.apply_forward`` use the
  given lead field (tests/test_datasets.py checks each).
- :func:`sphere_forward`: a three-shell sphere fitted to the electrodes and a volume grid
  inside it, for a montage without an MRI: crude (no anatomy; tangential and radial as the
  sphere has them), and what MNE offers without a head model.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .._utils.checks import InputError, InputTypeError, check_array, check_real, describe
from .._utils.extras import optional

if TYPE_CHECKING:
    import mne

__all__ = ["forward_from_leadfield", "sphere_forward"]

#: Orientations must be unit vectors to this tolerance (float32 files included).
UNIT_TOLERANCE = 1e-5


def _check_geometry(leadfield, positions, orientations, n_channels):
    L = check_array("leadfield", leadfield, (n_channels, "n_sources"))
    n = L.shape[1]
    rr = check_array("positions", positions, (n, 3))
    nn = check_array("orientations", orientations, (n, 3))
    norms = np.linalg.norm(nn, axis=1)
    if np.any(np.abs(norms - 1) > UNIT_TOLERANCE):
        worst = int(np.argmax(np.abs(norms - 1)))
        raise InputError(
            f"orientations must be unit vectors, got a norm of {norms[worst]:.6g} in row {worst}"
        )
    return L, rr, nn / norms[:, None]


def forward_from_leadfield(
    info: mne.Info, leadfield: ArrayLike, positions: ArrayLike, orientations: ArrayLike
) -> mne.Forward:
    """A fixed-orientation ``mne.Forward`` from a lead field computed elsewhere.

    Parameters
    ----------
    info : mne.Info
        The channels of the lead field's rows, in that order, with their positions (a
        montage) in the frame of ``positions``: MNE's head frame, metres.
    leadfield : array_like, shape (n_channels, n_sources)
        The gain of each source (V per A m), in the reference of the data it will be
        applied to (an average reference is given to data and forward alike by MNE's and
        skf_ref's inverses).
    positions : array_like, shape (n_sources, 3)
        Each column's source position, metres, in the frame of the info's montage.
    orientations : array_like, shape (n_sources, 3)
        Each column's unit orientation.

    Returns
    -------
    mne.Forward
        Fixed orientation, ``sol["data"]`` the lead field (float64, as given), on a discrete
        source space of the positions; the head and MRI frames are the same (identity
        ``mri_head_t``).

    Examples
    --------
    >>> import mne
    >>> montage = mne.channels.make_standard_montage("biosemi32")
    >>> info = mne.create_info(montage.ch_names, 1000.0, "eeg").set_montage(montage)
    >>> rng = np.random.default_rng(0)
    >>> rr = rng.uniform(-0.03, 0.03, (10, 3)) + [0.0, 0.0, 0.04]
    >>> nn = np.tile([0.0, 0.0, 1.0], (10, 1))
    >>> L = rng.standard_normal((32, 10))
    >>> fwd = forward_from_leadfield(info, L, rr, nn)
    >>> fwd["sol"]["data"] is L, bool(np.array_equal(fwd["sol"]["data"], L))
    (False, True)
    >>> mne.forward.is_fixed_orient(fwd, orig=True)
    True
    """
    mne = optional("mne", "mne", "forward_from_leadfield")
    from mne.io.constants import FIFF

    if not isinstance(info, mne.Info):
        raise InputTypeError(f"info must be an mne.Info, got {describe(info)}")
    L, rr, nn = _check_geometry(leadfield, positions, orientations, len(info["ch_names"]))
    src = mne.setup_volume_source_space(pos=dict(rr=rr, nn=nn), verbose=False)
    # a sphere holding every source and electrode: MNE computes a forward on it, which
    # supplies the object; its gain is replaced below
    centre = rr.mean(axis=0)
    electrodes = np.array([ch["loc"][:3] for ch in info["chs"]])
    radius = 2 * max(np.linalg.norm(np.vstack([rr, electrodes]) - centre, axis=1).max(), 0.1)
    sphere = mne.make_sphere_model(centre, radius, info, verbose=False)
    fwd = mne.make_forward_solution(
        info, None, src, sphere, meg=False, eeg=True, mindist=0.0, verbose=False
    )
    if fwd["nsource"] != len(rr):  # every source is inside the sphere: a bug if not
        raise RuntimeError(f"MNE kept {fwd['nsource']} of the {len(rr)} sources")
    fwd = mne.convert_forward_solution(
        fwd, surf_ori=True, force_fixed=True, use_cps=False, verbose=False
    )
    gain = np.array(L, dtype=float)
    fwd["sol"]["data"] = gain
    fwd["sol"]["ncol"] = gain.shape[1]
    fwd["_orig_sol"] = gain.copy()
    fwd["_orig_source_ori"] = FIFF.FIFFV_MNE_FIXED_ORI  # as a fixed forward read from a file
    fwd["source_nn"] = nn.copy()
    return fwd


def sphere_forward(
    info: mne.Info, *, spacing_mm: float = 10.0, mindist_mm: float = 5.0
) -> tuple[mne.Forward, mne.bem.ConductorModel]:
    """A three-shell sphere fitted to the electrodes and a volume grid inside it.

    Parameters
    ----------
    info : mne.Info
        EEG channels with positions (a montage), MNE's head frame.
    spacing_mm : float
        The grid's spacing.
    mindist_mm : float
        Sources closer than this to the inner skull sphere are left out.

    Returns
    -------
    forward : mne.Forward
        Free orientation, on the grid.
    sphere : mne.bem.ConductorModel
        ``mne.make_sphere_model("auto", "auto", info)``: its centre ``sphere["r0"]`` and
        radius ``sphere.radius`` (m) are those of the sphere fitted to the electrodes.
    """
    mne = optional("mne", "mne", "sphere_forward")
    if not isinstance(info, mne.Info):
        raise InputTypeError(f"info must be an mne.Info, got {describe(info)}")
    spacing = check_real("spacing_mm", spacing_mm, positive=True)
    mindist = check_real("mindist_mm", mindist_mm, nonnegative=True)
    sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    src = mne.setup_volume_source_space(sphere=sphere, pos=spacing, mindist=mindist, verbose=False)
    fwd = mne.make_forward_solution(
        info, None, src, sphere, meg=False, eeg=True, mindist=mindist, verbose=False
    )
    return fwd, sphere
