"""The real recordings' loaders: files, shapes, channel order, units, frames, and MNE objects
that MNE's inverse methods and skf_ref accept.

The feCNN files are read from the data folder (``$SKF_REF_DATA``, or ``shared/real-data``
beside the checkout); tests that need them skip where it is absent. Nothing is downloaded:
the download is tested with pooch replaced by a copy from that folder or by a stub.
"""

import hashlib
import warnings

import numpy as np
import pytest
from rounding import assert_same_to_rounding

import skf_ref
from skf_ref import InputError, InputTypeError
from skf_ref.datasets import _fecnn as fecnn
from skf_ref.datasets import _paths as paths
from skf_ref.datasets import _sep256 as sep256

mne = pytest.importorskip("mne")

#: The A0206 N20 is "at about 24 ms" (the README of the source's data): the GFP peak nearest.
N20_A0206_S = 0.024
#: The 256-channel GFP peaks (P14, N20, P25), s, and how far a peak may be from each: half a
#: millisecond, one sample at 2048 Hz either way of spharapy's own 13/19/30 ms marks.
SEP256_PEAKS_S, SEP256_PEAK_TOL_S = (0.0135, 0.0193, 0.0296), 0.0005
#: The FieldTrip ``elec`` and ``electrodes.elc`` are the same electrodes, digitized and then
#: placed on the FEM's scalp (integer mm): a rigid transform maps one onto the other within
#: this median and maximum (mm).
RIGID_MEDIAN_MM, RIGID_MAX_MM = 3.0, 10.0


@pytest.fixture(scope="module")
def folder():
    try:
        return skf_ref.datasets.data_path()
    except FileNotFoundError:
        pytest.skip(
            "the feCNN recordings were not found: name their folder in $SKF_REF_DATA, or "
            "put them in shared/real-data beside the checkout"
        )


@pytest.fixture(scope="module")
def averages(folder):
    return {subject: fecnn.load_fecnn_evoked(subject, folder) for subject in fecnn.FECNN_SUBJECTS}


@pytest.fixture(scope="module")
def a0206(averages):
    return averages["A0206"]


@pytest.fixture(scope="module")
def forward(folder):
    return fecnn.load_fecnn_forward(folder)


def _gfp_peak_near(evoked, time):
    """The time of the local maximum of the global field power nearest ``time``."""
    from scipy.signal import find_peaks

    gfp = evoked.data.std(axis=0)
    peaks = find_peaks(gfp)[0]
    return evoked.times[peaks[np.argmin(np.abs(evoked.times[peaks] - time))]]


def _rigid_residual(a, b):
    """Distances left after the rigid transform (Kabsch) that maps ``a`` onto ``b`` best."""
    a0, b0 = a - a.mean(0), b - b.mean(0)
    u, _, vt = np.linalg.svd(a0.T @ b0)
    d = np.sign(np.linalg.det(u @ vt))
    rotation = u @ np.diag([1, 1, d]) @ vt
    return np.linalg.norm(a0 @ rotation - b0, axis=1)


# --- the files ----------------------------------------------------------------------------


def test_every_file_has_its_pinned_checksum(folder):
    for name, digest in paths.FECNN_FILES.items():
        data = (folder / "fecnn" / name).read_bytes()
        assert hashlib.sha256(data).hexdigest() == digest, name
        assert paths.fecnn_file(name, folder).is_file()


def test_a_changed_file_is_refused(folder, tmp_path):
    copy = tmp_path / "fecnn"
    for name in paths.FECNN_FILES:
        (copy / name).parent.mkdir(parents=True, exist_ok=True)
        (copy / name).write_bytes((folder / "fecnn" / name).read_bytes())
    with open(copy / "duneuropy/Data/electrodes.elc", "a") as file:
        file.write(" ")
    with pytest.raises(InputError, match="electrodes.elc has sha256 .*a different or damaged"):
        fecnn.load_fecnn_forward(tmp_path)
    with pytest.raises(InputError, match="name must be one of"):
        paths.fecnn_file("README.md", tmp_path)


def test_a_folder_given_or_named_must_hold_the_files(tmp_path, monkeypatch):
    with pytest.raises(InputError, match="path must be a folder holding fecnn/.*lacks fecnn/"):
        skf_ref.datasets.data_path(tmp_path)
    with pytest.raises(InputTypeError, match="path must be a folder path, got 3"):
        skf_ref.datasets.data_path(3)
    monkeypatch.setenv(paths.DATA_ENV, str(tmp_path))
    with pytest.raises(InputError, match=r"\$SKF_REF_DATA must be a folder holding fecnn/"):
        skf_ref.datasets.data_path()


def test_nothing_found_says_how_to_get_the_files(tmp_path, monkeypatch):
    monkeypatch.delenv(paths.DATA_ENV, raising=False)
    monkeypatch.setattr(paths, "_checkout_folders", lambda: [tmp_path / "none"])
    monkeypatch.setattr(paths, "_cache_folder", lambda: tmp_path / "cache")
    with pytest.raises(FileNotFoundError, match=r"data_path\(download=True\)"):
        skf_ref.datasets.data_path()


def test_a_download_fetches_every_pinned_file_from_the_pinned_commit(tmp_path, monkeypatch):
    pooch = pytest.importorskip("pooch")
    created = {}

    class Fetcher:
        def fetch(self, name):
            file = created["path"] / name
            file.parent.mkdir(parents=True, exist_ok=True)
            file.write_text(name)  # a stand-in: the real pooch checks the sha256
            return str(file)

    def create(path, base_url, registry):
        created.update(path=path, base_url=base_url, registry=registry)
        return Fetcher()

    monkeypatch.delenv(paths.DATA_ENV, raising=False)
    monkeypatch.setattr(paths, "_checkout_folders", lambda: [])
    monkeypatch.setattr(paths, "_cache_folder", lambda: tmp_path / "cache")
    monkeypatch.setattr(pooch, "create", create)
    found = skf_ref.datasets.data_path(download=True)
    assert found == tmp_path / "cache"
    assert created["base_url"] == (
        "https://raw.githubusercontent.com/thanosDelatolas/feCNN/"
        "3a78825f549ac88cad3e5f64cf58b52eace5379f/"
    )
    assert created["registry"] == {n: f"sha256:{d}" for n, d in paths.FECNN_FILES.items()}
    assert all((found / "fecnn" / name).is_file() for name in paths.FECNN_FILES)
    # filled once, the cache is found without downloading again
    monkeypatch.setattr(pooch, "create", None)
    assert skf_ref.datasets.data_path() == found


# --- the averages -------------------------------------------------------------------------


@pytest.mark.parametrize(("subject", "n_channels"), [("A0206", 73), ("A1974", 71), ("A1999", 73)])
def test_averages_shapes_times_units_and_nave(averages, subject, n_channels):
    evoked = averages[subject]
    assert evoked.data.shape == (n_channels, 360)
    assert evoked.info["sfreq"] == 1200.0 and evoked.comment == subject
    np.testing.assert_allclose(evoked.times[[0, -1]], [-0.1, 0.199 + 1 / 6000], atol=1e-9)
    assert evoked.nave == 1198  # 1198 trials defined, none rejected (the cfg's history)
    assert 1e-7 < np.abs(evoked.data).max() < 1e-4  # volts: microvolts, not volts or uV
    np.testing.assert_allclose(evoked.data.sum(axis=0), 0, atol=1e-18)  # average reference
    positions = np.array([ch["loc"][:3] for ch in evoked.info["chs"]])
    assert 0.05 < np.ptp(positions, axis=0).max() < 0.3  # metres: a head, not mm or cm
    assert evoked.info["chs"][0]["coord_frame"] == mne.io.constants.FIFF.FIFFV_COORD_HEAD


@pytest.mark.parametrize("subject", ["A0206", "A1974", "A1999"])
def test_the_montage_has_mne_s_axes(averages, subject):
    evoked = averages[subject]
    at = {ch["ch_name"]: ch["loc"][:3] for ch in evoked.info["chs"]}
    assert at["C3"][0] < at["Cz"][0] < at["C4"][0]  # x to the right
    assert at["Pz"][1] < at["Cz"][1] < at["Fz"][1]  # y to the front
    assert at["Cz"][2] > at["T7"][2]  # z up


@pytest.mark.parametrize("subject", ["A0206", "A1974", "A1999"])
def test_the_n20_is_negative_at_cp3_and_positive_at_fz(averages, subject):
    # a sanity check of the loader (times, units, sign, channel labels), not of any method:
    # right median nerve, the N20/P20 field of a tangential dipole in left area 3b
    evoked = averages[subject]
    window = (evoked.times > 0.015) & (evoked.times < 0.030)
    cp3, fz = (evoked.ch_names.index(name) for name in ("CP3", "Fz"))
    at = np.flatnonzero(window)[np.argmin(evoked.data[cp3, window])]
    assert 0.020 < evoked.times[at] < 0.027
    assert evoked.data[cp3, at] < -1e-6 and evoked.data[fz, at] > 0.3e-6


def test_the_averages_are_demeaned_over_the_whole_epoch_not_the_baseline(a0206):
    # FieldTrip ignored the script's baseline window (no cfg.demean): the loader's docstring
    whole, baseline = a0206.data.mean(axis=1), a0206.data[:, a0206.times <= -0.02].mean(axis=1)
    assert np.abs(whole).max() < 1e-15 < 1e-9 < np.abs(baseline).max()


def test_a0206_n20_at_about_24_ms(a0206):
    time = _gfp_peak_near(a0206, N20_A0206_S)
    assert abs(time - N20_A0206_S) < 0.003
    at = np.argmin(np.abs(a0206.times - time))
    cp3, fz = (a0206.ch_names.index(name) for name in ("CP3", "Fz"))
    assert a0206.data[cp3, at] < 0 < a0206.data[fz, at]


# --- A0206's forward: channels, frame, and MNE's and skf_ref's inverses ---------------------


def test_forward_channels_are_the_data_s_and_the_lead_field_s(folder, a0206, forward):
    labels, elc = fecnn.read_elc(folder / "fecnn/duneuropy/Data/electrodes.elc")
    assert labels == a0206.ch_names == forward["sol"]["row_names"] == forward["info"].ch_names
    leadfield = np.load(folder / "fecnn/duneuropy/DataOut/leadfield_downsampled_5k.npy")
    assert forward["sol"]["data"].shape == (73, 5046) and forward["sol"]["data"].dtype == float
    np.testing.assert_array_equal(forward["sol"]["data"], leadfield.T)
    np.testing.assert_allclose(leadfield.sum(axis=1), 0, atol=1e-12)  # average referenced


def test_evoked_electrodes_and_sources_are_in_the_lead_field_s_frame(folder, a0206, forward):
    from scipy.io import loadmat

    _, elc = fecnn.read_elc(folder / "fecnn/duneuropy/Data/electrodes.elc")
    dipoles = loadmat(folder / "fecnn/duneuropy/Data/dipoles_downsampled_5k.mat")["cd_matrix"]
    locations = np.array([ch["loc"][:3] for ch in a0206.info["chs"]])
    np.testing.assert_allclose(locations, elc / 1000, rtol=1e-12)
    forward_locations = np.array([ch["loc"][:3] for ch in forward["info"]["chs"]])
    np.testing.assert_array_equal(forward_locations, locations)
    np.testing.assert_allclose(forward["source_rr"], dipoles[:, :3] / 1000)
    np.testing.assert_allclose(forward["source_nn"], dipoles[:, 3:])
    assert np.array_equal(forward["mri_head_t"]["trans"], np.eye(4))
    # every source under the cap, in metres
    lowest, highest = locations.min(axis=0), locations.max(axis=0)
    assert np.all(forward["source_rr"][:, :2] > lowest[:2])
    assert np.all(forward["source_rr"][:, :2] < highest[:2])
    assert np.all(forward["source_rr"][:, 2] < highest[2] - 0.01)


def test_fieldtrip_elec_is_the_same_electrodes_rigidly_moved(folder, a0206):
    import pymatreader

    mat = folder / "fecnn/real_data/A0206/EEG_avg.mat"
    elec = pymatreader.read_mat(str(mat), variable_names=["EEG_avg"])["EEG_avg"]["elec"]
    assert elec["unit"] == "cm"
    index = [list(elec["label"]).index(name) for name in a0206.ch_names]
    fieldtrip_mm = np.asarray(elec["chanpos"])[index] * 10
    elc_mm = np.array([ch["loc"][:3] for ch in a0206.info["chs"]]) * 1000
    residual = _rigid_residual(fieldtrip_mm, elc_mm)
    assert np.median(residual) < RIGID_MEDIAN_MM and residual.max() < RIGID_MAX_MM


def test_the_forward_stays_fixed_and_float64_through_mne_s_conversions(forward):
    # a forward made fixed stays so: MNE never rotates it back through a sphere's free gain
    for surf_ori, force_fixed in ((True, True), (False, False), (True, False)):
        converted = mne.convert_forward_solution(
            forward, surf_ori=surf_ori, force_fixed=force_fixed, verbose=False
        )
        assert mne.forward.is_fixed_orient(converted)
        assert converted["sol"]["data"].dtype == float
        np.testing.assert_array_equal(converted["sol"]["data"], forward["sol"]["data"])
    picked = mne.pick_channels_forward(forward, ["C3", "Cz", "CP3"], ordered=True)
    assert picked["sol"]["data"].shape == (3, 5046)


def test_mne_s_forward_model_is_the_lead_field(a0206, forward):
    rng = np.random.default_rng(0)
    amplitudes = rng.standard_normal((5046, 2)) * 1e-9
    stc = mne.VolSourceEstimate(amplitudes, [forward["src"][0]["vertno"]], 0.0, 0.001)
    simulated = mne.apply_forward(forward, stc, a0206.info, verbose=False)
    np.testing.assert_allclose(simulated.data, forward["sol"]["data"] @ amplitudes, rtol=1e-12)


@pytest.mark.slow  # over 10 s: CI runs it with the slow tests
def test_mne_s_inverses_and_the_skf_accept_the_forward(a0206, forward):
    from mne.minimum_norm import apply_inverse, make_inverse_operator

    cov = skf_ref.datasets.baseline_noise_cov(a0206, None, -0.02)
    # no depth weighting: MNE refuses it on a forward that was never free
    inverse = make_inverse_operator(a0206.info, forward, cov, loose=0.0, depth=None, verbose=False)
    for method in ("MNE", "dSPM", "sLORETA"):
        stc = apply_inverse(a0206, inverse, 1 / 9, method, verbose=False)
        assert stc.data.shape == (5046, 360) and np.all(np.isfinite(stc.data)), method
    # the SKF takes the average and the covariance as MNE's methods do (it divides by nave)
    stc = skf_ref.apply_skf(a0206, forward, cov, ep_snr_db=0.0, verbose=False)
    assert stc.data.shape == (5046, 360) and np.all(np.isfinite(stc.data))
    _same_as_of_the_average(stc, a0206, forward, cov)


@pytest.mark.slow
def test_eloreta_and_lcmv_accept_the_forward(a0206, forward):
    from mne.minimum_norm import apply_inverse, make_inverse_operator

    cov = skf_ref.datasets.baseline_noise_cov(a0206, None, -0.02)
    inverse = make_inverse_operator(a0206.info, forward, cov, loose=0.0, depth=None, verbose=False)
    stc = apply_inverse(a0206, inverse, 1 / 9, "eLORETA", verbose=False)
    assert np.all(np.isfinite(stc.data))
    # the data covariance of the average after the stimulus (LCMV's), as the analysis makes it
    data_cov = skf_ref.datasets.baseline_noise_cov(a0206, 0.0, a0206.times[-1], reg=0.0)
    filters = mne.beamformer.make_lcmv(
        a0206.info, forward, data_cov, noise_cov=cov, reg=0.05, verbose=False
    )
    assert np.all(np.isfinite(mne.beamformer.apply_lcmv(a0206, filters).data))


def _same_as_of_the_average(stc, evoked, forward, cov):
    """``stc`` equals the SKF of the same average given as one trial (nave 1) with the
    covariance of the average (``cov / nave``): the whitening the report's LCMV and MxNE
    get (validation/real_sep/methods.py)."""
    single = evoked.copy()
    single.nave = 1
    of_average = cov.copy()
    of_average["data"] = cov["data"] / evoked.nave
    other = skf_ref.apply_skf(single, forward, of_average, ep_snr_db=0.0, verbose=False)
    np.testing.assert_allclose(stc.data, other.data, rtol=1e-9, atol=1e-12 * abs(stc.data).max())


# --- the noise covariance of an average ------------------------------------------------------


@pytest.mark.slow  # over 10 s: CI runs it with the slow tests
def test_the_covariance_is_nave_times_the_baseline_s_and_nave_cancels(a0206, forward):
    from mne.minimum_norm import apply_inverse, make_inverse_operator

    plain = skf_ref.datasets.baseline_noise_cov(a0206, -0.1, -0.02, reg=0.0)
    window = a0206.times <= -0.02 + 1e-9
    samples = a0206.data[:, window]
    np.testing.assert_allclose(plain["data"], 1198 * samples @ samples.T / window.sum())
    assert plain["nfree"] == window.sum() == 97
    estimates = []
    for nave in (1198, 1):
        evoked = a0206.copy()
        evoked.nave = nave
        cov = skf_ref.datasets.baseline_noise_cov(evoked, None, -0.02)
        inverse = make_inverse_operator(
            evoked.info, forward, cov, loose=0.0, depth=None, verbose=False
        )
        estimates.append(apply_inverse(evoked, inverse, 1 / 9, "dSPM", verbose=False).data)
    # nave cancels in the algebra; MNE's SVD and products round each way (an entry near
    # zero differs relatively by more): rounding relative to the estimate's scale
    assert_same_to_rounding(estimates[0], estimates[1], rtol=1e-9)


def test_the_regularized_covariance_has_the_info_s_rank(a0206):
    plain = skf_ref.datasets.baseline_noise_cov(a0206, None, -0.02, reg=0.0)
    regularized = skf_ref.datasets.baseline_noise_cov(a0206, None, -0.02)
    ranks = [
        mne.compute_rank(c, info=a0206.info, verbose=False)["eeg"] for c in (plain, regularized)
    ]
    assert ranks[0] < 72 == ranks[1]  # 97 band-limited samples; 73 channels less the reference


def test_covariance_errors_name_the_parameter():
    info = mne.create_info(["a", "b"], 100.0, "eeg")
    evoked = mne.EvokedArray(np.zeros((2, 10)), info, tmin=0.0, verbose=False)
    with pytest.raises(InputError, match="tmin, tmax must hold at least 2 samples"):
        skf_ref.datasets.baseline_noise_cov(evoked, tmax=-0.5)
    with pytest.raises(InputTypeError, match="evoked must be an mne.Evoked"):
        skf_ref.datasets.baseline_noise_cov(np.zeros((2, 10)))
    with pytest.raises(InputError, match="reg must be"):
        skf_ref.datasets.baseline_noise_cov(evoked, reg=-1)


# --- a forward from any lead field ---------------------------------------------------------


def _small_problem(n=12, seed=0):
    montage = mne.channels.make_standard_montage("biosemi32")
    info = mne.create_info(montage.ch_names, 1000.0, "eeg").set_montage(montage)
    rng = np.random.default_rng(seed)
    rr = rng.uniform(-0.03, 0.03, (n, 3)) + [0.0, 0.0, 0.04]
    nn = rng.standard_normal((n, 3))
    nn /= np.linalg.norm(nn, axis=1, keepdims=True)
    return info, rng.standard_normal((32, n)), rr, nn


def test_forward_from_leadfield_keeps_gain_positions_and_orientations():
    info, L, rr, nn = _small_problem()
    fwd = skf_ref.datasets.forward_from_leadfield(info, L, rr, nn)
    assert mne.forward.is_fixed_orient(fwd) and mne.forward.is_fixed_orient(fwd, orig=True)
    np.testing.assert_array_equal(fwd["sol"]["data"], L)
    np.testing.assert_allclose(fwd["source_rr"], rr)
    np.testing.assert_allclose(fwd["source_nn"], nn)
    assert fwd["sol"]["row_names"] == info.ch_names and fwd["nsource"] == len(rr)


def test_forward_from_leadfield_refuses_what_is_not_a_lead_field():
    info, L, rr, nn = _small_problem()
    with pytest.raises(InputError, match=r"leadfield must have shape \(32, n_sources\)"):
        skf_ref.datasets.forward_from_leadfield(info, L[:30], rr, nn)
    with pytest.raises(InputError, match=r"positions must have shape \(12, 3\)"):
        skf_ref.datasets.forward_from_leadfield(info, L, rr[:5], nn)
    with pytest.raises(InputError, match="orientations must be unit vectors, got a norm of 2"):
        skf_ref.datasets.forward_from_leadfield(info, L, rr, 2 * nn)
    with pytest.raises(InputTypeError, match="info must be an mne.Info"):
        skf_ref.datasets.forward_from_leadfield({}, L, rr, nn)


# --- the 256-channel SEP ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def sep():
    pytest.importorskip("spharapy", reason="the 256-channel SEP ships in spharapy")
    return sep256.load_sep256_evoked()


def test_sep256_shape_times_units_and_nave(sep):
    assert sep.data.shape == (256, 369) and sep.info["sfreq"] == 2048.0 and sep.nave == 6000
    np.testing.assert_allclose(sep.times[:2], [-0.05, -0.05 + 1 / 2048])
    assert 1e-7 < np.abs(sep.data).max() < 1e-4  # volts
    np.testing.assert_allclose(sep.data[:, sep.times <= 0].mean(axis=1), 0, atol=1e-18)
    positions = np.array([ch["loc"][:3] for ch in sep.info["chs"]])
    assert 0.15 < np.ptp(positions, axis=0).max() < 0.3  # metres


def test_sep256_gfp_peaks(sep):
    for peak in SEP256_PEAKS_S:
        assert abs(_gfp_peak_near(sep, peak) - peak) < SEP256_PEAK_TOL_S


def test_sep256_cap_is_turned_to_mne_s_axes(sep):
    positions = np.array([ch["loc"][:3] for ch in sep.info["chs"]])
    names = sep.ch_names
    left = np.array([n.startswith("L") or n.endswith("L") for n in names])
    right = np.array([n.startswith("R") and n.endswith("R") for n in names])
    assert np.all(positions[[n.endswith("L") for n in names], 0] < 0)  # x to the right
    assert positions[left, 0].mean() < 0 < positions[right, 0].mean()
    midline = np.abs(positions[:, 0]) < 0.015
    front, back = (positions[midline][np.argsort(positions[midline, 1])][i] for i in (-1, 0))
    assert back[2] < front[2]  # the cap reaches down to the neck at the back


@pytest.mark.slow
def test_sep256_forward_on_a_fitted_sphere(sep):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        fwd, sphere = skf_ref.datasets.sphere_forward(sep.info, spacing_mm=20.0)
    positions = np.array([ch["loc"][:3] for ch in sep.info["chs"]])
    distances = np.linalg.norm(positions - sphere["r0"], axis=1)
    assert abs(np.median(distances) - sphere.radius) < 0.01
    assert np.linalg.norm(fwd["source_rr"] - sphere["r0"], axis=1).max() < 0.9 * sphere.radius
    cov = skf_ref.datasets.baseline_noise_cov(sep)
    stc = skf_ref.apply_skf(sep, fwd, cov, ep_snr_db=0.0, verbose=False)
    assert np.all(np.isfinite(stc.data)) and stc.data.shape == (fwd["nsource"], 369)
    _same_as_of_the_average(stc, sep, fwd, cov)
    with pytest.raises(InputError, match="spacing_mm must be"):
        skf_ref.datasets.sphere_forward(sep.info, spacing_mm=0)
