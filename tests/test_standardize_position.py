"""Standardization per position (``standardize="position"``, docs/model.md §2).

Every property runs on every path: sLORETA's free-orientation statistic at the first step,
exact localization of a noise-free dipole of any orientation, rotation of the coordinate
frame (which the column form fails), and the column form as the case of one orientation.
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import linalg

from skf_ref import InputError, reconstruct

PATHS = ("dense", "filterpy", "spectral")
SMOOTHERS = (None, "rts-standardized", "rts-state", "rts-smoothed-weights")
# Closed forms against the paths, on problems whose blocks and covariances have condition
# numbers below 1e3: a few hundred eps times those (the dense path takes eigh of
# P_{t|t-1} and of each block; the spectral path the 3 x 3 closed form).
CLOSED_FORM_RTOL = 1e-10


@pytest.fixture(params=PATHS)
def method(request):
    return request.param


def relative(actual, desired):
    return np.max(np.abs(actual - desired)) / np.max(np.abs(desired))


def free_lead_field(rng, n_channels, n_positions, reference="average"):
    """A random free-orientation lead field, (n_channels, 3 n_positions), MNE's order."""
    L = rng.standard_normal((n_channels, 3 * n_positions))
    L *= np.repeat(rng.uniform(0.2, 2.0, n_positions), 3)  # deep and superficial positions
    if reference == "average":
        L -= L.mean(axis=0)
    return L


def blocks_of(M, k):
    """The (n // k, k, k) diagonal blocks of M."""
    n = len(M) // k
    return np.array([M[k * i : k * i + k, k * i : k * i + k] for i in range(n)])


def pascual_marqui(L, y, p, R):
    """Free-orientation sLORETA (Pascual-Marqui 2002): ``||x_i||`` in the metric of the
    inverse of its own block of the estimate's covariance ``p^2 L^T S^-1 L``."""
    S = p * L @ L.T + R
    x = p * L.T @ linalg.solve(S, y, assume_a="pos")
    covariance = p**2 * L.T @ linalg.solve(S, L, assume_a="pos")
    blocks = blocks_of(covariance, 3)
    x_blocks = x.reshape(-1, 3)
    solved = np.linalg.solve(blocks, x_blocks[..., None])[..., 0]
    return np.sqrt(np.einsum("ia,ia->i", x_blocks, solved))


@pytest.mark.parametrize("noise", ["noise_std", "noise_cov"])
@pytest.mark.parametrize("split", [0.0, 0.25], ids=["q=0", "q=p/4"])
def test_first_step_is_free_orientation_sloreta(method, noise, split):
    rng = np.random.default_rng(1)
    L = free_lead_field(rng, 16, 12)
    sigma, p = 1e-6, 3e-16
    y = L @ (np.sqrt(p) * rng.standard_normal(L.shape[1])) + sigma * rng.standard_normal(16)
    if noise == "noise_std":
        R, noise_kwargs = sigma**2 * np.eye(16), {"noise_std": sigma}
    else:
        B = rng.standard_normal((16, 16))
        R = sigma**2 * (B @ B.T / 16 + 0.3 * np.eye(16))
        noise_kwargs = {"noise_cov": R}
    rec = reconstruct(
        L,
        y[:, None],
        **noise_kwargs,
        theta0=(1 - split) * p,
        q=split * p,
        exponent=0.5,
        standardize="position",
        n_orient=3,
        path=method,
    )
    expected = pascual_marqui(L, y, p, R)
    assert relative(rec.amplitude(3)[:, 0], expected) < CLOSED_FORM_RTOL


def test_fixed_orientation_is_mne_sloreta(mne_setup):
    # One orientation per position: blocks of one, the column form, and MNE's own sLORETA.
    # MNE's source covariance c (scaled by make_inverse_operator) over lambda2 is the SKF's
    # theta0 (MNE whitens the gain by the noise, as R = sigma^2 I does); with q = 0 and T = 1
    # the two agree to rounding (5.7e-14 measured; MNE keeps its gain in float32, the SKF
    # gets the same numbers).
    mne = pytest.importorskip("mne")
    from mne.minimum_norm import apply_inverse, make_inverse_operator

    rng = np.random.default_rng(4)
    positions = mne_setup["positions"]
    normals = rng.standard_normal(positions.shape)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    src = mne.setup_volume_source_space(
        pos=dict(rr=positions, nn=normals), sphere=mne_setup["sphere"], verbose=False
    )
    forward = mne.make_forward_solution(
        mne_setup["info"], None, src, mne_setup["sphere"], eeg=True, meg=False, verbose=False
    )
    forward = mne.convert_forward_solution(forward, surf_ori=True, force_fixed=True, verbose=False)
    gain = forward["sol"]["data"].astype(float)  # MNE's float32, referenced in float64
    sigma = 1e-6
    x = np.zeros(gain.shape[1])
    x[[3, 40]] = 1e-8
    data = gain @ x + sigma * rng.standard_normal(gain.shape[0])
    evoked = mne.EvokedArray(data[:, None], mne_setup["info"], verbose=False)
    evoked.set_eeg_reference("average", projection=True, verbose=False)
    cov = mne.Covariance(
        sigma**2 * np.eye(len(evoked.ch_names)), evoked.ch_names, [], [], nfree=100, verbose=False
    )
    inverse = make_inverse_operator(
        evoked.info, forward, cov, loose=0.0, depth=None, fixed=True, verbose=False
    )
    lambda2 = 1 / 9
    sloreta = apply_inverse(evoked, inverse, lambda2, "sLORETA", verbose=False).data[:, 0]
    theta0 = inverse["source_cov"]["data"][0] / lambda2
    L, Y = gain - gain.mean(axis=0), (data - data.mean())[:, None]  # the average reference
    for standardize in ("column", "position"):  # the spectral path (the others equal it)
        rec = reconstruct(
            L, Y, noise_std=sigma, theta0=theta0, q=0.0, exponent=0.5,
            standardize=standardize, n_orient=1, path="spectral",
        )  # fmt: skip
        assert relative(rec.z[:, 0], sloreta) < CLOSED_FORM_RTOL, standardize


@given(
    position=st.integers(0, 11),
    orientation=st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1),
)
def test_noise_free_dipole_of_any_orientation_is_localized_exactly(position, orientation):
    # docs/model.md §2, "Exact localization": ||z_i|| <= ||z_j|| for the dipole's position j
    rng = np.random.default_rng(5)
    L = free_lead_field(rng, 16, 12)
    eta = np.asarray(orientation) / np.linalg.norm(orientation)
    y = L[:, 3 * position : 3 * position + 3] @ eta
    for method in PATHS:
        rec = reconstruct(
            L,
            y[:, None],
            noise_std=1e-3,
            theta0=1.0,
            q=0.0,
            standardize="position",
            n_orient=3,
            path=method,
        )
        amplitude = rec.amplitude(3)[:, 0]
        assert np.argmax(amplitude) == position, method
        others = np.delete(amplitude, position)
        assert others.max() < amplitude[position] * (1 - 1e-9), method


def test_the_column_form_moves_an_oblique_dipole():
    # the same data: the position form finds every dipole, the column form misses some
    rng = np.random.default_rng(6)
    L = free_lead_field(rng, 16, 12)
    missed = 0
    for position in range(12):
        for _ in range(20):
            eta = rng.standard_normal(3)
            y = L[:, 3 * position : 3 * position + 3] @ (eta / np.linalg.norm(eta))
            common = dict(noise_std=1e-3, theta0=1.0, q=0.0, n_orient=3, path="dense")
            column = reconstruct(L, y[:, None], standardize="column", **common)
            position_form = reconstruct(L, y[:, None], standardize="position", **common)
            assert np.argmax(position_form.amplitude(3)[:, 0]) == position
            missed += np.argmax(column.amplitude(3)[:, 0]) != position
    assert missed > 0


def random_rotations(rng, n):
    Q, R = np.linalg.qr(rng.standard_normal((n, 3, 3)))
    Q *= np.sign(np.diagonal(R, axis1=1, axis2=2))[:, None, :]
    Q[np.linalg.det(Q) < 0, :, 0] *= -1
    return Q


@pytest.mark.parametrize("smoother", SMOOTHERS)
@pytest.mark.parametrize("exponent", [0.5, 1.25])
def test_rotating_every_position_rotates_z_and_keeps_the_amplitude(method, smoother, exponent):
    # docs/model.md §2, "Rotation": L' = L D, D = blockdiag(R_i) gives z'[c(i)] = R_i^T z[c(i)]
    rng = np.random.default_rng(7)
    n_positions, T = 5, 6
    L = free_lead_field(rng, 12, n_positions)
    Y = rng.standard_normal((12, T))
    rotations = random_rotations(rng, n_positions)
    D = linalg.block_diag(*rotations)
    common = dict(
        noise_std=0.5,
        theta0=0.7,
        q=0.2,
        exponent=exponent,
        smoother=smoother,
        n_orient=3,
        path=method,
    )
    for standardize in ("position", "column"):
        rec = reconstruct(L, Y, standardize=standardize, **common)
        rotated = reconstruct(L @ D, Y, standardize=standardize, **common)
        change = relative(rotated.amplitude(3), rec.amplitude(3))
        if standardize == "position":
            assert change < 1e-12
            assert relative(rotated.z, D.T @ rec.z) < 1e-12
            assert relative(rotated.x, D.T @ rec.x) < 1e-12
        else:  # the column form's amplitudes depend on the coordinate frame
            assert change > 1e-3


@pytest.mark.parametrize("smoother", SMOOTHERS)
def test_one_orientation_per_position_is_the_column_form(method, smoother):
    rng = np.random.default_rng(8)
    L = free_lead_field(rng, 10, 4)
    Y = rng.standard_normal((10, 5))
    common = dict(noise_std=0.5, theta0=0.7, q=0.2, exponent=1.25, smoother=smoother)
    column = reconstruct(L, Y, **common, path=method)
    position = reconstruct(L, Y, standardize="position", n_orient=1, **common, path=method)
    for name in ("z", "x", "z_filtered", "weights"):
        assert relative(getattr(position, name), getattr(column, name)) < 1e-13, name


def first_step_by_blocks(L, y, sigma, p, exponent):
    """T = 1, P_{1|0} = p I: the weights' diagonal and z from W = blockdiag(B_i^-alpha),
    B = p L^T S^-1 L, by eigh of each block."""
    S = p * L @ L.T + sigma**2 * np.eye(len(L))
    B = blocks_of(p * L.T @ linalg.solve(S, L, assume_a="pos"), 3)
    eigenvalues, E = np.linalg.eigh(B)
    powers = np.einsum("nij,nj,nkj->nik", E, eigenvalues**-exponent, E)
    x = p * L.T @ linalg.solve(S, y, assume_a="pos")
    z = np.einsum("nij,nj->ni", powers, x.reshape(-1, 3) / np.sqrt(p)).ravel()
    return np.diagonal(powers, axis1=1, axis2=2).ravel(), z


@pytest.mark.parametrize("exponent", [0.0, 0.5, 1.0, 1.25, 2.0])
def test_weights_are_the_diagonal_of_the_block_powers(method, exponent):
    rng = np.random.default_rng(9)
    L = free_lead_field(rng, 12, 5)
    y = rng.standard_normal(12)
    sigma, p = 0.5, 0.8
    rec = reconstruct(
        L,
        y[:, None],
        noise_std=sigma,
        theta0=p,
        q=0.0,
        exponent=exponent,
        standardize="position",
        n_orient=3,
        path=method,
    )
    weights, z = first_step_by_blocks(L, y, sigma, p, exponent)
    assert relative(rec.weights[:, 0], weights) < 1e-12
    assert relative(rec.z[:, 0], z) < CLOSED_FORM_RTOL


@pytest.mark.parametrize("first", ["z", "weights"])
def test_weights_and_z_of_many_positions_in_either_order(first):
    # more positions than the spectral path computes at once within a tile, both outputs
    # from one reconstruction: what one output keeps for a tile must not serve the other
    rng = np.random.default_rng(19)
    L = free_lead_field(rng, 12, 700)
    y = rng.standard_normal(12)
    rec = reconstruct(
        L,
        y[:, None],
        noise_std=0.5,
        theta0=0.8,
        q=0.0,
        standardize="position",
        n_orient=3,
        path="spectral",
    )
    weights, z = first_step_by_blocks(L, y, 0.5, 0.8, 0.5)
    expected = dict(weights=weights, z=z)
    for name in (first, *(set(expected) - {first})):
        assert relative(getattr(rec, name)[:, 0], expected[name]) < CLOSED_FORM_RTOL, name


def test_settings_record_the_standardization():
    rng = np.random.default_rng(10)
    L = free_lead_field(rng, 8, 3)
    rec = reconstruct(
        L, rng.standard_normal((8, 2)), noise_std=1.0, theta0=1.0, q=0.1,
        standardize="position", n_orient=3,
    )  # fmt: skip
    assert rec.settings["standardize"] == "position" and rec.settings["n_orient"] == 3
    assert "position" in repr(rec)
    default = reconstruct(L, rng.standard_normal((8, 2)), noise_std=1.0, theta0=1.0, q=0.1)
    assert default.settings["standardize"] == "column"


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(standardize="positions"), r"standardize must be one of \['column', 'position'\]"),
        (dict(standardize=3), r"standardize must be one of"),
        (dict(standardize="position"), r"standardize='position' needs n_orient"),
        (dict(standardize="position", n_orient=2), r"n_orient must be 1 or 3, got 2"),
        (dict(n_orient=0), r"n_orient must be 1 or 3, got 0"),
        (dict(standardize="position", n_orient=3.0), r"n_orient must be an integer"),
        (dict(n_orient=3, L_columns=10), r"n_orient=3 must divide the 10 columns of L"),
    ],
)
def test_bad_standardization_settings_are_refused(kwargs, match):
    rng = np.random.default_rng(11)
    n = kwargs.pop("L_columns", 9)
    L = rng.standard_normal((6, n))
    with pytest.raises((InputError, TypeError), match=match):
        reconstruct(L, rng.standard_normal((6, 2)), noise_std=1.0, theta0=1.0, q=0.1, **kwargs)


@pytest.mark.parametrize("method", PATHS)
def test_a_position_not_seen_in_every_orientation_is_refused(method):
    # three orientations, two independent channels (average reference of three)
    rng = np.random.default_rng(12)
    L = rng.standard_normal((3, 6))
    L -= L.mean(axis=0)
    with pytest.raises(InputError, match=r"position 0 \(columns 0-2 of L\) has a singular"):
        reconstruct(
            L, rng.standard_normal((3, 2)), noise_std=1.0, theta0=1.0, q=0.1,
            standardize="position", n_orient=3, path=method,
        )  # fmt: skip
    # the column form is defined there
    reconstruct(L, rng.standard_normal((3, 2)), noise_std=1.0, theta0=1.0, q=0.1, n_orient=3)


@pytest.mark.parametrize("exponent", [0.5, 1.25])
def test_components_held_one_at_a_time_agree_with_the_dense_path(exponent):
    # channels seen from 1 to 1e3 times more strongly: the components of the covariance
    # recursion settle tens to hundreds of steps apart, and the spectral path holds each
    # from its own step on (skf_ref.method._paths.block_weights)
    rng = np.random.default_rng(29)
    L = free_lead_field(rng, 8, 4) * np.logspace(0, 1.5, 8)[:, None]
    Y = rng.standard_normal((8, 300))
    settings = dict(noise_std=1.0, theta0=1e-2, q=1e-3, exponent=exponent)
    settings.update(standardize="position", n_orient=3)
    spectral = reconstruct(L, Y, **settings, path="spectral")
    dense = reconstruct(L, Y, **settings, path="dense")
    for name in ("z", "weights"):
        assert relative(getattr(spectral, name), getattr(dense, name)) < 1e-10, name


@pytest.mark.parametrize("smoother", [None, "rts-state", "rts-smoothed-weights"])
def test_a_model_applied_again_keeps_its_block_powers(monkeypatch, smoother):
    # more positions than a chunk and more steps than a chunk before the steady state: from
    # the second data set on, the powers of the transient blocks are kept, not recomputed
    from skf_ref.method import SpectralModel, StateSpaceModel
    from skf_ref.method._paths import block_weights

    rng = np.random.default_rng(31)
    L = free_lead_field(rng, 8, 300) * np.logspace(0, 1.5, 8)[:, None]
    data = [rng.standard_normal((8, 200)) for _ in range(3)]
    model = StateSpaceModel.create(L, noise_std=1.0, theta0=1e-2, q=1e-3)
    kwargs = dict(standardize="position", n_orient=3)

    def fresh(Y, name):
        return getattr(SpectralModel(model, n_times=200).apply(Y, 0.5, smoother, **kwargs), name)

    prepared = SpectralModel(model, n_times=200)
    standardization = prepared.standardization(
        0.5, block=3, smoothed=smoother == "rts-smoothed-weights"
    )
    for k, Y in enumerate(data):
        rec = prepared.apply(Y, 0.5, smoother, **kwargs)
        for name in ("z", "weights"):
            assert relative(getattr(rec, name), fresh(Y, name)) <= 1e-13, (k, name)
        assert standardization.kept == (k > 0)
    monkeypatch.setattr(block_weights, "CACHE_BYTES", 0)
    uncached = SpectralModel(model, n_times=200)
    for Y in data[:2]:
        assert relative(uncached.apply(Y, 0.5, smoother, **kwargs).z, fresh(Y, "z")) <= 1e-13
    assert not uncached.standardization(
        0.5, block=3, smoothed=smoother == "rts-smoothed-weights"
    ).kept
