"""A forward model invertmeeg's benchmark can run on here, built from MNE's testing dataset.

invertmeeg's own helper (``invert.forward.create_forward_model``) builds fsaverage's cortex
(ico3, fixed orientation) and fetches fsaverage from the network when it is not on disk; the
machines this was written on have no network and no fsaverage. MNE's testing dataset has the
"sample" subject's three-layer BEM, its head-MRI transform, its ``aseg.mgz`` and a recording
with its 60 digitized EEG electrodes, but no cortical surfaces (``lh.white``). So the forward
here is:

- **sources**: the voxels of the cortex labels of ``aseg.mgz`` (Left/Right-Cerebral-Cortex)
  on a :data:`SPACING_MM` grid, one volume source space (1262 positions at 7 mm, about the
  1284 of invertmeeg's published leaderboard);
- **orientation**: fixed, radial from the centroid of the positions. invertmeeg's simulator
  and metrics take one column per position (its lead field's columns are its dipoles), so
  the forward must be fixed; a volume has no cortical normal, and MNE converts only surface
  or discrete source spaces to fixed orientation, so the free forward's three columns are
  combined here with that unit vector, the orientation EEG sees best;
- **positions**: the metrics' distances are between the source space's positions (MRI
  coordinates, metres; invertmeeg reads MNI coordinates from FreeSurfer surfaces, which are
  not here): :mod:`validation.invertmeeg` reports MLE and EMD in mm;
- **sensors**: the recording's 60 EEG electrodes (``SSS/sample_audvis_trunc_raw_sss.fif``)
  with an average-reference projector (MNE's convention for EEG inverse modelling; the
  benchmark's own solvers read it from the info too), sampling rate :data:`SFREQ` (the
  benchmark's time courses are generated in samples; 1000 Hz is the rate of invertmeeg's
  ``get_info``), and the three-layer BEM (``sample-1280-1280-1280-bem.fif``).

Nothing is downloaded: the folder is the one ``mne.datasets.testing.data_path()`` returns.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

RAW = "SSS/sample_audvis_trunc_raw_sss.fif"
TRANS = "MEG/sample/sample_audvis_trunc-trans.fif"
BEM = "subjects/sample/bem/sample-1280-1280-1280-bem.fif"
LABELS = ("Left-Cerebral-Cortex", "Right-Cerebral-Cortex")
#: Grid spacing of the cortex positions (mm).
SPACING_MM = 7.0
#: Sources closer than this to the inner skull are left out (mm, MNE's default).
MINDIST_MM = 5.0
#: Sampling rate given to the benchmark's evokeds (Hz).
SFREQ = 1000.0


def eeg_info(testing_data, sfreq=SFREQ):
    """The recording's EEG channels, with an average-reference projector, at ``sfreq``."""
    import mne

    info = mne.io.read_info(Path(testing_data) / RAW, verbose=False)
    info = mne.pick_info(info, mne.pick_types(info, meg=False, eeg=True, exclude=[]))
    with info._unlock():
        info["projs"] = []
        info["bads"] = []
        info["sfreq"] = float(sfreq)
        info["lowpass"] = min(info["lowpass"], sfreq / 2)
    raw = mne.io.RawArray(np.zeros((len(info["ch_names"]), 1)), info, verbose=False)
    raw.set_eeg_reference(projection=True, verbose=False)
    return raw.info


def fixed_orientation(fwd, normals):
    """A fixed-orientation copy of a free-orientation forward, each position along ``normals``.

    The free forward's columns come in threes per position (x, y, z, head coordinates);
    each position's column is their combination with its unit normal, as MNE's
    ``convert_forward_solution(force_fixed=True)`` does with a surface's normals.
    """
    from mne.io.constants import FIFF

    if fwd["source_ori"] != FIFF.FIFFV_MNE_FREE_ORI:
        raise ValueError("the forward must have free orientation")
    normals = np.asarray(normals, dtype=float)
    n_src = int(fwd["nsource"])
    if normals.shape != (n_src, 3):
        raise ValueError(f"normals must be ({n_src}, 3), got {normals.shape}")
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    gain = np.asarray(fwd["sol"]["data"], dtype=float)
    fixed = np.einsum("csk,sk->cs", gain.reshape(gain.shape[0], n_src, 3), normals)
    out = fwd.copy()
    out["sol"] = dict(out["sol"], data=fixed, ncol=n_src)
    out["_orig_sol"] = fixed.copy()
    out["sol_grad"] = None
    out["source_ori"] = FIFF.FIFFV_MNE_FIXED_ORI
    out["_orig_source_ori"] = FIFF.FIFFV_MNE_FIXED_ORI
    out["source_nn"] = normals
    out["nchan"] = fixed.shape[0]
    return out


def radial_normals(fwd):
    """Unit vectors from the centroid of the forward's positions to each position."""
    rr = np.asarray(fwd["source_rr"], dtype=float)
    out = rr - rr.mean(axis=0)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def benchmark_forward(testing_data, spacing_mm=SPACING_MM, sfreq=SFREQ):
    """The sample subject's cortex, fixed radial orientation, 60 EEG electrodes, BEM.

    Returns ``(forward, info)``: the fixed-orientation ``mne.Forward`` and the
    ``mne.Info`` (EEG with its average-reference projector) the benchmark's evokeds take.
    """
    import mne

    root = Path(testing_data)
    info = eeg_info(root, sfreq)
    bem = mne.make_bem_solution(root / BEM, verbose=False)
    src = mne.setup_volume_source_space(
        "sample",
        pos=float(spacing_mm),
        mri="aseg.mgz",
        volume_label=list(LABELS),
        single_volume=True,
        subjects_dir=root / "subjects",
        bem=bem,
        mindist=MINDIST_MM,
        add_interpolator=False,
        verbose=False,
    )
    fwd = mne.make_forward_solution(
        info, trans=root / TRANS, src=src, bem=bem, eeg=True, meg=False, verbose=False
    )
    fwd = fixed_orientation(fwd, radial_normals(fwd))
    # invertmeeg's positions (invert.util.util.pos_from_forward) are MNI coordinates read
    # from the subject's FreeSurfer surfaces, which the testing dataset lacks; without a
    # subject it falls back to the source space's own positions (MRI coordinates, metres)
    # instead of failing on the missing SUBJECTS_DIR. Distances are the same.
    for space in fwd["src"]:
        space["subject_his_id"] = None
    return fwd, info
