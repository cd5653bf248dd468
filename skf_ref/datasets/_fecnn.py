"""The feCNN recordings: three median-nerve SEP averages, one with its own FEM lead field.

From the repository of "EEG Source Analysis with a Convolutional Neural Network and Finite
Element Analysis" (Delatolas, Antonakakis, Wolters, Zervakis, EMBC 2023; MIT licence),
found or downloaded by :func:`skf_ref.datasets.data_path`:

- **The averages** (:func:`load_fecnn_evoked`): FieldTrip timelock averages of subjects
  A0206, A1974 and A1999, right median nerve, 1200 Hz, -100 ... 199 ms, band-pass 20-250 Hz
  (two-pass Butterworth), notch 50/100/150 Hz, average reference, read with MNE's
  ``mne.read_evoked_fieldtrip`` (whose time axis starts at 0 and whose sampling frequency is
  the inverse of the rounded interval: both are set here from the structure's ``time``).
  ``nave`` is read from the structure's history: the trials of the trial definition
  (``trl``) less those ``ft_rejectvisual`` rejected (none: 1198 for each subject). The
  preprocessing script sets a baseline window of -100 ... -20 ms without
  ``cfg.demean = 'yes'``, which FieldTrip then ignores; the averaging step demeans each
  trial over the whole epoch (the averages' mean over -100 ... 199 ms is 0 to rounding,
  over -100 ... -20 ms it is not). The window -100 ... -20 ms is still the right one for the noise
  (:func:`skf_ref.datasets.baseline_noise_cov`): it ends before the zero-phase filter
  spreads the stimulus artifact backwards.
- **The frame.** A0206's MNE objects live in the frame of its lead field, the FEM's MRI
  frame of ``electrodes.elc`` and ``cd_matrix`` (x from the left to the right ear, y from
  back to front, z up: MNE's head-frame convention), in metres, declared as MNE's head frame
  with an identity head-MRI transform: the evoked's montage is ``electrodes.elc``, the
  forward's sources are ``cd_matrix``'s. The FieldTrip ``elec`` (cm, the CTF frame: x to the
  nose, y to the left ear) describes the same electrodes: a rigid transform maps it onto
  ``electrodes.elc`` within a few mm (a test holds this), and it is not used for A0206.
  A1974 and A1999 have no lead field: their montage is their FieldTrip ``elec``, turned from
  CTF's axes to MNE's (x right = -y, y front = x), cm to m.
- **The forward** (:func:`load_fecnn_forward`): duneuro's FEM lead field of A0206,
  ``leadfield_downsampled_5k.npy`` (5046 sources x 73 electrodes, average referenced), with
  ``cd_matrix`` (position in mm and a unit orientation per row: 5046 positions, each with one
  Cartesian axis), as a fixed-orientation ``mne.Forward``
  (:func:`skf_ref.datasets.forward_from_leadfield`). Its electrodes are ``electrodes.elc``,
  in the data's channel order (a test holds this).
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import numpy as np

from .._utils.checks import InputError, check_choice
from .._utils.extras import optional
from ._forward import forward_from_leadfield
from ._paths import fecnn_file

if TYPE_CHECKING:
    import mne

__all__ = [
    "FECNN_SUBJECTS",
    "FILTER",
    "SFREQ",
    "load_fecnn_evoked",
    "load_fecnn_forward",
    "read_elc",
]

#: The subjects, and whether each has a lead field.
FECNN_SUBJECTS = {"A0206": True, "A1974": False, "A1999": False}
#: The band-pass of the preprocessing, Hz (matlab/real_data_preproc.m).
FILTER = (20.0, 250.0)
#: The sampling frequency of the averages, Hz.
SFREQ = 1200.0
_EVOKED = "real_data/{}/EEG_avg.mat"
_LEADFIELD = "duneuropy/DataOut/leadfield_downsampled_5k.npy"
_DIPOLES = "duneuropy/Data/dipoles_downsampled_5k.mat"
_ELECTRODES = "duneuropy/Data/electrodes.elc"
_MM, _CM = 1e-3, 1e-2


def read_elc(path: str | os.PathLike) -> tuple[list[str], np.ndarray]:
    """Labels and positions of an ASA electrode file (``.elc``), as duneuro writes it.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    labels : list of str
    positions : ndarray, shape (n_electrodes, 3)
        In the file's unit (``UnitPosition``).
    """
    lines = [line.strip() for line in open(path, encoding="ascii").read().splitlines()]
    n = int(next(line for line in lines if line.startswith("NumberPositions")).split("=")[1])
    start = lines.index("Positions") + 1
    positions = np.array([[float(v) for v in line.split()] for line in lines[start : start + n]])
    labels = lines[lines.index("Labels") + 1].split()
    if len(labels) != n or positions.shape != (n, 3):
        raise InputError(f"{path}: {n} positions announced, {len(labels)} labels read")
    return labels, positions


def _nave(cfg: Any) -> int:
    """Trials averaged: those defined (``trl``) less those ``ft_rejectvisual`` rejected."""
    defined, rejected = None, 0
    while isinstance(cfg, dict):
        if "trl" in cfg and np.ndim(cfg["trl"]) == 2:
            defined = len(cfg["trl"])
        artifacts = cfg.get("artfctdef", {})
        for kind in artifacts.values() if isinstance(artifacts, dict) else ():
            rejected += len(np.atleast_2d(kind.get("artifact", [])).reshape(-1, 2))
        cfg = cfg.get("previous")
    if defined is None:
        raise InputError("the FieldTrip structure's history has no trial definition (trl)")
    return defined - rejected


def _ctf_to_mne(positions_cm: np.ndarray) -> np.ndarray:
    """CTF's axes (x nose, y left ear, z up), cm, to MNE's (x right, y nose, z up), m."""
    x, y, z = positions_cm.T
    return np.column_stack([-y, x, z]) * _CM


def _info(labels, positions, sfreq, subject):
    """EEG channels with their positions (m, MNE's head frame) and the preprocessing."""
    mne = optional("mne", "mne", "load_fecnn_evoked")
    montage = mne.channels.make_dig_montage(
        dict(zip(labels, positions, strict=True)), coord_frame="head"
    )
    info = mne.create_info(list(labels), sfreq, "eeg")
    info.set_montage(montage)
    info["description"] = (
        f"feCNN {subject}: right median nerve SEP, band-pass {FILTER[0]:g}-{FILTER[1]:g} Hz"
    )
    return info


def _a0206_electrodes(path):
    """A0206's electrodes in its lead field's frame: labels, positions (m)."""
    labels, positions = read_elc(fecnn_file(_ELECTRODES, path))
    return labels, positions * _MM


def _positions(subject, structure, path):
    """The data's channels and their positions (m, MNE's head frame): module docstring."""
    labels = list(structure["label"])
    if FECNN_SUBJECTS[subject]:
        elc_labels, positions = _a0206_electrodes(path)
        if elc_labels != labels:
            raise InputError(f"{subject}: the data's channels are not electrodes.elc's")
        return labels, positions
    elec = structure["elec"]
    index = [list(elec["label"]).index(label) for label in labels]
    return labels, _ctf_to_mne(np.asarray(elec["chanpos"])[index])


def load_fecnn_evoked(
    subject: str = "A0206", path: str | os.PathLike | None = None
) -> mne.EvokedArray:
    """One subject's average, as an ``mne.EvokedArray`` with its electrodes.

    Parameters
    ----------
    subject : {"A0206", "A1974", "A1999"}
    path : path-like, optional
        The data folder (:func:`skf_ref.datasets.data_path`: found if not given).

    Returns
    -------
    mne.EvokedArray
        Volts, times from the structure (-0.1 ... 0.199 s), ``nave`` from its history,
        ``comment`` the subject, an average-reference projector (the data are average
        referenced already; the projector tells MNE so). Positions in metres, MNE's head
        frame: A0206's in its lead field's frame (module docstring).
    """
    mne = optional("mne", "mne", "load_fecnn_evoked")
    pymatreader = optional("pymatreader", "mne", "load_fecnn_evoked")
    check_choice("subject", subject, tuple(FECNN_SUBJECTS))
    file = fecnn_file(_EVOKED.format(subject), path)
    structure = pymatreader.read_mat(str(file), variable_names=["EEG_avg"])["EEG_avg"]
    if not np.allclose(np.diff(structure["time"]), 1 / SFREQ, rtol=1e-6):
        raise InputError(f"{file}: not sampled at {SFREQ:g} Hz")
    labels, positions = _positions(subject, structure, path)
    info = _info(labels, positions, SFREQ, subject)
    read = mne.read_evoked_fieldtrip(file, info, comment=subject, data_name="EEG_avg")
    if read.ch_names != info.ch_names:
        raise InputError(f"{file}: MNE's reader kept {len(read.ch_names)} channels")
    # MNE's reader starts the times at 0 and takes 1 / (rounded sampling interval) as the
    # frequency: both from the structure here
    evoked = mne.EvokedArray(
        read.data,
        info,
        tmin=float(structure["time"][0]),
        nave=_nave(structure["cfg"]),
        comment=subject,
        verbose=False,
    )
    evoked.set_eeg_reference("average", projection=True, verbose=False)
    return evoked


def load_fecnn_forward(path: str | os.PathLike | None = None) -> mne.Forward:
    """A0206's FEM lead field as a fixed-orientation ``mne.Forward``.

    Parameters
    ----------
    path : path-like, optional
        The data folder (:func:`skf_ref.datasets.data_path`).

    Returns
    -------
    mne.Forward
        73 EEG channels (``electrodes.elc``, the data's order), 5046 sources at
        ``cd_matrix``'s positions (mm to m) with its orientations; ``sol["data"]`` is the
        lead field transposed to (73, 5046), float64, as duneuro computed it.
    """
    optional("mne", "mne", "load_fecnn_forward")
    from scipy.io import loadmat

    labels, electrodes = _a0206_electrodes(path)
    dipoles = loadmat(fecnn_file(_DIPOLES, path))["cd_matrix"]
    leadfield = np.load(fecnn_file(_LEADFIELD, path)).T  # (5046, 73) on file
    info = _info(labels, electrodes, SFREQ, "A0206")
    return forward_from_leadfield(info, leadfield, dipoles[:, :3] * _MM, dipoles[:, 3:])
