"""The study of the SKF's worth, v2, on a small sphere head: the sets, and the exact sums.

The linear study adds up exact responses instead of running each method on each data set;
these tests check, on a head of 492 positions, that the sums equal the methods run on the
data themselves (slow; ``tests/test_worth.py`` holds the same principle on a random model),
that the sets are disjoint and off the grid, and MNE's side of the comparison.
"""

from dataclasses import replace

import numpy as np
import pytest

from validation.reproduce.worth import design
from validation.reproduce.worth.design import SNRS
from validation.reproduce.worth.linear import (
    matched_lambda2,
    mne_kernel,
    skf_response,
    static_response,
)
from validation.reproduce.worth.measure import measure
from validation.reproduce.worth.perrun import discrepancy_lambda2, measure_run
from validation.reproduce.worth.runs import data_of
from validation.reproduce.worth.sets import make_study, split_positions
from validation.reproduce.worth.skf import Prepared
from validation.reproduce.worth.tasks import design_waves, geometry, head

#: A small sphere head: 492 positions, 4 thalamic per side.
HEAD = dict(conductor="sphere", source_space="anatomical", spacing_mm=12.0)
SIZES = replace(design.QUICK, choice_cortical=12, scored_cortical=12, thalamic=None, pool=5)
#: Sums of exact responses against the method run on the data: rounding only.
SUM_RTOL = 1e-9


@pytest.fixture(scope="module")
def study():
    from skf_ref.study.head import make_head

    return make_study(make_head(**HEAD), HEAD, SIZES)


# --------------------------------------------------------------------------- the sets


def test_the_sets_share_no_position_and_every_source_is_off_the_grid(study):
    choice, scored = study.sets["choice"], study.sets["scored"]
    for kind in ("thalamic", "cortical"):
        a, b = getattr(choice, kind), getattr(scored, kind)
        assert not set(a.position) & set(b.position)
        moved = np.linalg.norm(a.points - study.positions[a.position], axis=1)
        assert (moved > 0).all() and (moved <= 6e-3 * np.sqrt(3) / 1 + 1e-12).all()
    assert set(choice.thalamic.structure) == {"thalamus"}
    assert set(scored.cortical.structure) == {"cortex"}


def test_a_positions_orientations_are_orthonormal_and_configurations_pair_distinct_cortex(study):
    sources = study.sets["scored"].thalamic
    o = sources.orientations.reshape(-1, 3, 3)
    assert np.allclose(np.einsum("pij,pkj->pik", o, o), np.eye(3), atol=1e-12)
    partner = study.sets["scored"].cortical_of(np.arange(len(sources)))
    positions = study.sets["scored"].cortical.position[partner]
    assert len(set(positions)) == len(sources)


def test_the_thalamic_split_halves_each_thalamus_and_is_reproducible(study):
    from skf_ref.study.sources import position_labels

    labels = position_labels(head(study))
    first = split_positions(labels, SIZES)
    assert {k: [v.tolist() for v in pair] for k, pair in first.items()} == {
        k: [v.tolist() for v in pair] for k, pair in split_positions(labels, SIZES).items()
    }
    for side in ("Left-Thalamus", "Right-Thalamus"):
        counts = [np.sum(labels[first[s][0]] == side) for s in ("choice", "scored")]
        assert counts[0] == np.sum(labels == side) // 2
        assert sum(counts) == np.sum(labels == side)


def test_the_fields_are_mnes_forward_at_the_points(study):
    sources = study.sets["choice"].cortical
    expected = head(study).dipole_gain(sources.points[:3], sources.orientations[:3])
    assert np.allclose(sources.gain[:, :3], expected, rtol=1e-10, atol=0)


# --------------------------------------------------------------------------- exact sums


def _direct_skf(study, setting, run):
    """The SKF run on the data set itself (whitened by its noise level)."""
    sim, points = data_of(study, run, SIZES.pool)
    waves, samples, n_times = design_waves(design.DESIGNS[0])
    prepared = Prepared(head(study).leadfield, setting.priors, n_times)
    z = prepared.z(sim.Y / sim.sigma, setting)
    amplitude = np.sqrt(np.square(z.reshape(-1, 3, n_times)).sum(axis=1))
    return measure_run(amplitude, geometry(study), points, samples, waves["thalamic"])


@pytest.fixture(scope="module")
def skf_runs(study):
    setting = design.NAMED["N2"]  # the paper's: the smoother exercises the backward pass
    waves, samples, n_times = design_waves(design.DESIGNS[0])
    geo = geometry(study)
    prepared = Prepared(head(study).leadfield, setting.priors, n_times)
    pool = study.pool("scored", 0, SIZES.pool, n_times)
    response = skf_response(prepared, setting, waves, samples, geo.near_columns, pool)
    sigmas = {snr: study.sigma(snr) for snr in SNRS}
    tables = measure(geo, response, study.sets["scored"], samples, sigmas, waves["thalamic"],
                     with_lone=True, with_courses=True)  # fmt: skip
    return setting, tables


@pytest.mark.slow
def test_configurations_from_responses_equal_the_skf_on_their_data(study, skf_runs):
    setting, tables = skf_runs
    configs = tables["configurations"]
    for index, snr, moment in ((0, 20.0, 1.0), (4, 10.0, 0.5)):
        row = configs[
            (configs["config"] == index)
            & (configs["snr_db"] == snr)
            & (configs["moment"] == moment)
        ].iloc[0]
        direct = _direct_skf(study, setting, ("scored", "config", index, snr, moment))
        assert row["level"] == pytest.approx(direct["level"], rel=SUM_RTOL)
        assert row["deep_error_mm"] == pytest.approx(direct["deep_error_mm"], rel=SUM_RTOL)
        if moment == 1.0:
            assert row["superficial_error_mm"] == pytest.approx(direct["superficial_error_mm"])
            assert row["deep_r"] == pytest.approx(direct["deep_r"], rel=1e-8)


@pytest.mark.slow
def test_lone_sources_and_nulls_from_responses_equal_the_skf_on_their_data(study, skf_runs):
    setting, tables = skf_runs
    lone, nulls = tables["lone"], tables["nulls"]
    row = lone[(lone["kind"] == "thalamic") & (lone["index"] == 2) & (lone["snr_db"] == 30.0)]
    direct = _direct_skf(study, setting, ("scored", "thalamic", 2, 30.0, 1.0))
    assert row["error_mm"].iloc[0] == pytest.approx(direct["deep_error_mm"])
    assert row["dispersion_mm"].iloc[0] == pytest.approx(direct["dispersion_mm"], rel=1e-8)
    assert bool(row["own_structure"].iloc[0]) == direct["deep_in_thalamus"]
    cortical = nulls[(nulls["kind"] == "cortical") & (nulls["index"] == 7)]
    direct = _direct_skf(study, setting, ("scored", "cortical-null", 7, 10.0, 0.0))
    assert cortical[cortical["snr_db"] == 10.0]["level"].iloc[0] == pytest.approx(
        direct["level"], rel=SUM_RTOL
    )
    noise = nulls[(nulls["kind"] == "noise") & (nulls["index"] == 3)]["level"].iloc[0]
    direct = _direct_skf(study, setting, ("scored", "noise", 3, 20.0, 0.0))
    assert noise == pytest.approx(direct["level"], rel=SUM_RTOL)


def test_a_static_kernel_on_windowed_data_is_the_kernel_on_the_filtered_data(study):
    rng = np.random.default_rng(0)
    waves, samples, n_times = design_waves(design.DESIGNS[0])
    geo = geometry(study)
    K = rng.standard_normal((3 * len(study.positions), study.n_channels))
    window = np.tril(rng.uniform(size=(n_times, n_times)))
    window /= window.sum(axis=1, keepdims=True)
    pool = study.pool("choice", 0, 3, n_times)
    response = static_response(K, waves, samples, geo.near_columns, pool, window)
    g = rng.standard_normal(study.n_channels)
    t = samples[0]
    Y = np.outer(g, waves["thalamic"]) + pool[1]
    expected = K @ (Y @ window.T)[:, t]
    got = response.at["thalamic", t] @ g + response.noise_at[t][:, 1]
    assert np.allclose(got, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


# --------------------------------------------------------------------------- MNE's side


@pytest.mark.slow
def test_the_skf_at_t1_is_mnes_sloreta_at_the_matched_lambda2():
    """The pre-registration's correspondence: exponent 0.5, P = p I, fixed orientation."""
    import mne
    from mne.minimum_norm import apply_inverse, make_inverse_operator

    from skf_ref.method import SpectralModel, StateSpaceModel, priors_from_snr
    from skf_ref.study.baselines import mne_data
    from skf_ref.study.scenario import make_head_model, p20n20_scenario, simulate

    h = make_head_model(500)
    sim = simulate(h, p20n20_scenario(), 20.0, 0)
    evoked, cov = mne_data(h, sim)
    fwd = mne.convert_forward_solution(h.fwd, force_fixed=True, verbose=False)
    L = np.asarray(fwd["sol"]["data"], dtype=float)
    L = L - L.mean(axis=0)
    y = sim.Y[:, 15:16]
    inverse = make_inverse_operator(evoked.info, fwd, cov, loose=0.0, fixed=True, depth=None,
                                    verbose=False)  # fmt: skip
    for pm in (0.0, 20.0):
        theta0, _ = priors_from_snr(L, sim.sigma, pm, 0.0, 1)
        model = StateSpaceModel.create(L, noise_std=sim.sigma, theta0=theta0, q=0.0)
        z = SpectralModel(model, 1).apply(y, 0.5, None).z[:, 0]
        lambda2 = matched_lambda2(pm, len(y), len(y) - 1)
        one = mne.EvokedArray(y, evoked.info, verbose=False)
        sloreta = apply_inverse(one, inverse, lambda2, "sLORETA", verbose=False).data[:, 0]
        assert np.allclose(z, sloreta, rtol=1e-10, atol=0)
        off = apply_inverse(one, inverse, 10 ** (-pm / 10), "sLORETA", verbose=False).data[:, 0]
        assert not np.allclose(z, off, rtol=1e-3)


@pytest.mark.slow
def test_mnes_kernel_gives_apply_inverse_and_the_discrepancy_lambda2_meets_its_target(study):
    from mne.minimum_norm import apply_inverse, prepare_inverse_operator

    from skf_ref.study.baselines import amplitude_on_positions, inverse_operator, mne_data

    sim, _ = data_of(study, ("scored", "config", 1, 20.0, 1.0), SIZES.pool)
    h = head(study)
    lambda2, bound = discrepancy_lambda2(h.leadfield, sim.Y, sim.sigma)
    assert bound is None
    kernel = mne_kernel(h, "MNE", lambda2)
    evoked, _ = mne_data(h, sim)
    inverse = prepare_inverse_operator(inverse_operator(h, sim), 1, lambda2, "MNE", verbose=False)
    stc = apply_inverse(evoked, inverse, lambda2, "MNE", prepared=True, pick_ori="vector",
                        verbose=False)  # fmt: skip
    x = kernel @ (sim.Y / sim.sigma)
    assert np.allclose(x * sim.sigma, stc.data.reshape(x.shape), rtol=1e-8,
                       atol=1e-10 * np.abs(x).max() * sim.sigma)  # fmt: skip
    norm = np.sqrt(np.square(x.reshape(-1, 3, x.shape[1])).sum(axis=1)) * sim.sigma
    plain = apply_inverse(evoked, inverse, lambda2, "MNE", prepared=True, verbose=False)
    assert np.allclose(norm, amplitude_on_positions(plain, h), rtol=1e-8)
    # MNE's own fit leaves the noise's expected energy, to the rounding of lambda2 (0.5 dB)
    n, T = sim.Y.shape
    residual = sim.Y - h.leadfield @ (stc.data.reshape(x.shape))
    residual -= residual.mean(axis=0)
    energy = np.sum(residual**2) / sim.sigma**2
    assert energy == pytest.approx((n - 1) * T, rel=0.1)
