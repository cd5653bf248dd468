"""The study's conditions: sensors, noise and the covariance the methods get (section 1).

:func:`condition` builds one (cached per process): MNE's forward on the sample subject's
cortex + thalamus, the covariance, MNE's rank-aware whitener, and a noise source that draws
white, Gaussian or real background noise at a design's rate.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .design import CONDITIONS, FLOOR_SHARE

RAW = "SSS/sample_audvis_trunc_raw_sss.fif"
COV = "MEG/sample/sample_audvis_trunc-cov.fif"
TRANS = "MEG/sample/sample_audvis_trunc-trans.fif"
#: The white EEG noise's standard deviation (V): any value, every result is in whitened units.
WHITE_STD = 1e-6


@dataclass(eq=False)
class Condition:
    """One condition: lead field, covariance, whitener and noise.

    Attributes
    ----------
    name : str
    head : HeadModel
        The EEG head of the condition's source space (MEG: the BioSemi head's positions).
    info, fwd, cov
        MNE's measurement info, forward (free orientation) and noise covariance.
    G : ndarray, shape (n_channels, n_columns)
        Sensor lead field (EEG average referenced).
    W : ndarray, shape (rank, n_channels)
        MNE's rank-aware whitener of ``cov``.
    """

    name: str
    head: object = field(repr=False)
    info: object = field(repr=False)
    fwd: object = field(repr=False)
    cov: object = field(repr=False)
    G: np.ndarray = field(repr=False)
    W: np.ndarray = field(repr=False)
    noise_kind: str = "white"
    colorer: np.ndarray | None = field(default=None, repr=False)
    rank_arg: object = None
    background: object = field(default=None, repr=False)
    gain_of: object = field(default=None, repr=False)

    @property
    def n_channels(self):
        """int"""
        return self.G.shape[0]

    @property
    def rank(self):
        """int : Rows of the whitener."""
        return self.W.shape[0]

    @functools.cached_property
    def Lw(self):
        """ndarray, shape (rank, n_columns) : The whitened lead field."""
        return self.W @ self.G

    def gains(self, points, orientations):
        """Sensor fields of exact dipoles at unit moment, shape (n_channels, n)."""
        return self.gain_of(np.asarray(points), np.asarray(orientations))

    @functools.lru_cache(maxsize=8)  # noqa: B019 (one condition per process)
    def _recording(self, sfreq):
        data = self.background(sfreq)
        return data, 1.0 / float(np.sqrt(np.mean((self.W @ data) ** 2)))

    def noise(self, rng, n_times, sfreq):
        """One noise draw in sensor units, shape (n_channels, n_times)."""
        if self.noise_kind == "white":
            z = rng.standard_normal((self.n_channels, n_times)) * WHITE_STD
            return z - z.mean(axis=0, keepdims=True)
        if self.noise_kind == "gaussian":
            return self.colorer @ rng.standard_normal((self.colorer.shape[1], n_times))
        data, scale = self._recording(float(sfreq))
        start = int(rng.integers(0, data.shape[1] - n_times + 1))
        sign = 1.0 if rng.random() < 0.5 else -1.0
        return sign * scale * data[:, start : start + n_times]


def _average_reference(n):
    return np.eye(n) - 1.0 / n


def _whitener(cov, info, rank=None):
    import mne

    W, _, colorer = mne.cov.compute_whitener(
        cov, info, rank=rank, pca=True, return_colorer=True, verbose=False
    )
    return np.asarray(W), np.asarray(colorer)


def _covariance(C, names):
    import mne

    C = 0.5 * (C + C.T)
    return mne.Covariance(C, list(names), bads=[], projs=[], nfree=1000, verbose=False)


@functools.lru_cache(maxsize=1)
def _raw(root):
    import mne

    return mne.io.read_raw_fif(Path(root) / RAW, preload=True, verbose=False)


def _eeg_background(root, names, sfreq):
    raw = _raw(root).copy().pick(list(names))
    if not raw.info["projs"]:
        raw.set_eeg_reference("average", projection=True, verbose=False)
    raw.apply_proj(verbose=False)
    if abs(raw.info["sfreq"] - sfreq) > 1e-9:
        raw.resample(sfreq, verbose=False)
    return raw.get_data()


def _interpolation(source_info, target_info):
    """MNE's spherical-spline map from one set of electrodes to another, (n_target, n_source)."""
    import mne

    info = mne.create_info(source_info.ch_names, 1000.0, "eeg")
    info.set_montage(source_info.get_montage(), verbose=False)
    unit = mne.io.RawArray(np.eye(len(info.ch_names)), info, verbose=False)
    mapped = unit.interpolate_to(target_info.get_montage(), method="spline")
    order = [mapped.ch_names.index(name) for name in target_info.ch_names]
    return mapped.get_data()[order]


@functools.lru_cache(maxsize=2)
def _eeg_head(montage, root, quick):
    from skf_ref.study._head import make_head

    if quick:
        return make_head("sphere", "anatomical", montage="biosemi64")
    return make_head("bem", "anatomical", montage=montage, testing_data=root)


def _meg_forward(head, root):
    """MNE's MEG forward on the head's source space (cached beside its EEG forward)."""
    import mne

    from skf_ref.study._head import cache_dir

    bads = mne.read_cov(Path(root) / COV, verbose=False)["bads"]
    raw_info = _raw(root).info
    info = mne.pick_info(raw_info, mne.pick_types(raw_info, meg=True, exclude=bads))
    trans = mne.read_trans(Path(root) / TRANS, verbose=False)
    path = cache_dir() / f"v3-meg-anatomical-{len(info.ch_names)}-fwd.fif"
    if not path.exists():
        fwd = mne.make_forward_solution(
            info, trans, head.src, head.conductor, meg=True, eeg=False, verbose=False
        )
        mne.write_forward_solution(path, fwd, overwrite=True, verbose=False)
    fwd = mne.read_forward_solution(path, verbose=False)
    fwd = mne.convert_forward_solution(fwd, surf_ori=False, force_fixed=False, verbose=False)
    if not np.allclose(fwd["source_rr"], head.positions):
        raise RuntimeError("the MEG forward's positions are not the head's")
    return info, trans, fwd


def _meg_gains(head, info, trans):
    import mne

    def gains(points, orientations):
        rr = np.c_[points, np.ones(len(points))] @ trans["trans"].T
        if trans["from"] != mne.io.constants.FIFF.FIFFV_COORD_HEAD:
            rr = np.c_[points, np.ones(len(points))] @ np.linalg.inv(trans["trans"]).T
        src = mne.setup_volume_source_space(
            pos=dict(rr=rr[:, :3], nn=np.tile([0.0, 0.0, 1.0], (len(points), 1))),
            bem=head.conductor,
            mindist=0.0,
            verbose=False,
        )
        fwd = mne.make_forward_solution(
            info, trans, src, head.conductor, meg=True, eeg=False, verbose=False
        )
        fwd = mne.convert_forward_solution(fwd, surf_ori=False, force_fixed=False, verbose=False)
        free = np.asarray(fwd["sol"]["data"]).reshape(len(info.ch_names), len(points), 3)
        return np.einsum("cnk,nk->cn", free, orientations)

    return gains


@functools.lru_cache(maxsize=1)
def condition(name, root=None, quick=False):
    """Build condition ``name`` (``design.CONDITIONS``) from MNE's testing data at ``root``."""
    import mne

    sensors, noise = CONDITIONS[name]
    if sensors == "meg":
        head = _eeg_head("biosemi64", root, quick)
        info, trans, fwd = _meg_forward(head, root)
        file_cov = mne.read_cov(Path(root) / COV, verbose=False)
        cov = mne.pick_channels_cov(file_cov, info.ch_names, ordered=True, verbose=False)
        with info._unlock():
            info["projs"] = list(cov["projs"])
        # the recording is Maxwell-filtered: MNE's rank from its info (69), not the
        # covariance's (302, which MNE's data-driven estimate flags as exceeding it)
        W, colorer = _whitener(cov, info, rank="info")
        G = np.asarray(fwd["sol"]["data"])
        return Condition(
            name, head, info, fwd, cov, G, W, "gaussian", colorer, "info", None,
            _meg_gains(head, info, trans),
        )  # fmt: skip
    head = _eeg_head(sensors, root, quick)
    n = len(head.info.ch_names)
    P = _average_reference(n)
    background = None
    if noise == "white":
        C = WHITE_STD**2 * P
    elif sensors == "sample":
        C = np.asarray(head.noise_cov)
        names = head.info.ch_names

        def background(sfreq):
            return P @ _eeg_background(root, names, sfreq)
    else:
        subject = _eeg_head("sample", root, quick)
        M = _interpolation(subject.info, head.info)
        mapped = M @ np.asarray(subject.noise_cov) @ M.T
        floor = FLOOR_SHARE * np.trace(mapped) / n
        C = P @ (mapped + floor * np.eye(n)) @ P

        def background(sfreq):
            data = M @ _eeg_background(root, subject.info.ch_names, sfreq)
            share = FLOOR_SHARE * np.mean(np.var(data, axis=1))
            rng = np.random.default_rng([43050, int(sfreq)])
            return P @ (data + np.sqrt(share) * rng.standard_normal(data.shape))

    cov = _covariance(C, head.info.ch_names)
    W, colorer = _whitener(cov, head.info)
    return Condition(
        name, head, head.info, head.fwd, cov, np.asarray(head.leadfield), W,
        noise, colorer, None, background, head.dipole_gain,
    )  # fmt: skip
