"""The SKF as an invertmeeg solver (validation/invertmeeg/, issue 46).

invertmeeg (GPL-3) is not a dependency of skf_ref: the adapter's tests skip where it is not
installed. The forward helper's orientation is tested everywhere. Everything here runs on an
MNE sphere (no dataset, no download).
"""

import re
from pathlib import Path

import numpy as np
import pytest

mne = pytest.importorskip("mne")

import skf_ref  # noqa: E402
from validation.invertmeeg.forward import fixed_orientation, radial_normals  # noqa: E402

NO_INVERTMEEG = "invertmeeg is not installed (pip install invertmeeg; GPL-3, not a dependency)"


@pytest.fixture(scope="module")
def sphere():
    """A small EEG sphere forward (free orientation, 25 mm grid) and its info."""
    montage = mne.channels.make_standard_montage("biosemi32")
    info = mne.create_info(montage.ch_names, 1000.0, "eeg")
    info.set_montage(montage)
    raw = mne.io.RawArray(np.zeros((len(info["ch_names"]), 1)), info, verbose=False)
    raw.set_eeg_reference(projection=True, verbose=False)
    info = raw.info
    model = mne.make_sphere_model("auto", "auto", info, verbose=False)
    src = mne.setup_volume_source_space(pos=25.0, sphere=model, mindist=5.0, verbose=False)
    # Without an MRI, MNE calls the grid "discrete" (it has no interpolator); invertmeeg's
    # runner takes mne.spatial_src_adjacency, which reads a grid's neighbours only as "vol".
    src[0]["type"] = "vol"
    fwd = mne.make_forward_solution(info, None, src, model, eeg=True, meg=False, verbose=False)
    return fwd, info


@pytest.fixture(scope="module")
def fixed(sphere):
    fwd, info = sphere
    return fixed_orientation(fwd, radial_normals(fwd)), info


def test_fixed_orientation_combines_each_positions_three_columns(sphere, fixed):
    free, fwd = sphere[0], fixed[0]
    normals = radial_normals(free)
    gain = free["sol"]["data"]
    for j in (0, 7, free["nsource"] - 1):
        expected = gain[:, 3 * j : 3 * j + 3] @ normals[j]
        np.testing.assert_allclose(fwd["sol"]["data"][:, j], expected, rtol=1e-12)
    assert mne.forward.is_fixed_orient(fwd) and fwd["sol"]["data"].shape[1] == free["nsource"]
    with pytest.raises(ValueError, match="free orientation"):
        fixed_orientation(fwd, normals)


def _evoked(fwd, info, source, snr=10.0, seed=0):
    rng = np.random.default_rng(seed)
    times = np.arange(50)
    signal = np.outer(fwd["sol"]["data"][:, source], np.sin(2 * np.pi * times / 50))
    noise_std = np.abs(signal).max() / snr
    data = signal + noise_std * rng.standard_normal(signal.shape)
    cov = mne.Covariance(
        noise_std**2 * np.eye(len(info["ch_names"])), info["ch_names"], [], info["projs"], 1
    )
    return mne.EvokedArray(data, info, tmin=0.0, verbose=False), cov


def test_the_adapter_gives_apply_skf_s_estimate(fixed):
    pytest.importorskip("invert", reason=NO_INVERTMEEG)
    from validation.invertmeeg.solver import CHOICES, SolverSKF

    fwd, info = fixed
    source = 10
    evoked, cov = _evoked(fwd, info, source)
    solver = SolverSKF()
    assert solver.require_recompute and solver.require_data
    solver.make_inverse_operator(fwd, evoked, alpha="auto", noise_cov=cov)
    before = len(CHOICES)
    stc = solver.apply_inverse_operator(evoked)
    direct = skf_ref.apply_skf(evoked, fwd, cov)  # the package's defaults
    np.testing.assert_array_equal(stc.data, direct.data)
    assert len(CHOICES) == before + 1 and CHOICES[-1].time_constant_ms is not None
    assert np.argmax(np.abs(stc.data).mean(axis=1)) == source  # 20 dB, one source: found
    # a setting passed on to apply_skf changes the estimate
    other = SolverSKF(exponent=1.25).make_inverse_operator(fwd, evoked, noise_cov=cov)
    assert not np.allclose(other.apply_inverse_operator(evoked).data, stc.data)


def test_the_adapter_needs_a_noise_covariance(fixed):
    pytest.importorskip("invert", reason=NO_INVERTMEEG)
    from validation.invertmeeg.solver import SolverSKF

    with pytest.raises(ValueError, match="noise_cov"):
        SolverSKF().make_inverse_operator(fixed[0], alpha="auto")


def test_invertmeeg_s_runner_scores_the_registered_skf(fixed):
    pytest.importorskip("invert", reason=NO_INVERTMEEG)
    from invert.benchmark import BENCHMARK_DATASETS, BenchmarkRunner
    from invert.solver_registry import create_solver, get_solver_spec

    from validation.invertmeeg.solver import SolverSKF, register

    spec = register()
    assert register() is spec  # once
    assert get_solver_spec("SKF") is spec and isinstance(create_solver("skf"), SolverSKF)
    assert get_solver_spec("mne").solver_id == "mne"  # the others still there
    fwd, info = fixed
    runner = BenchmarkRunner(
        fwd,
        info,
        solvers=["skf", "random-noise"],
        datasets={"focal_source": BENCHMARK_DATASETS["focal_source"]},
        n_samples=2,
        n_jobs=1,
        random_seed=0,
    )
    results = {r.solver_name: r for r in runner.run()}
    skf = results["skf"]
    assert len(skf.samples) == 2
    for sample in skf.samples:
        values = [sample.mle, sample.emd, sample.sd, sample.ap, sample.correlation]
        assert np.all(np.isfinite(values)), sample
    # a focal source at 3-5 dB on 32 electrodes: the SKF is no random estimate
    assert (
        skf.metrics["average_precision"].mean
        > results["random-noise"].metrics["average_precision"].mean
    )


def _docs_snippet():
    """docs/choosing.md's adapter for users (the ```python block of its invertmeeg section)."""
    page = (Path(__file__).resolve().parents[1] / "docs" / "choosing.md").read_text()
    section = page[page.index("## Beside invertmeeg's solvers") :]
    return re.search(r"```python\n(.*?)```", section, flags=re.S).group(1)


def test_the_docs_adapter_registers_and_gives_apply_skf_s_estimate(fixed, monkeypatch):
    pytest.importorskip("invert", reason=NO_INVERTMEEG)
    from invert import solver_registry

    for name in ("_SOLVER_SPECS", "_SPECS_BY_ID", "_ALIAS_TO_ID"):  # restored afterwards
        monkeypatch.setattr(solver_registry, name, getattr(solver_registry, name))
    key = solver_registry.normalize_solver_name("skf")
    if key in solver_registry._SPECS_BY_ID:  # the repository's adapter, registered above
        specs = tuple(s for s in solver_registry._SOLVER_SPECS if s.normalized_id() != key)
        by_id, aliases = solver_registry._build_solver_indexes(specs)
        monkeypatch.setattr(solver_registry, "_SOLVER_SPECS", specs)
        monkeypatch.setattr(solver_registry, "_SPECS_BY_ID", by_id)
        monkeypatch.setattr(solver_registry, "_ALIAS_TO_ID", aliases)
    code = _docs_snippet()
    setup, run = code.split("runner = ", 1)
    assert "BenchmarkRunner(forward, info" in run  # the page's run: the user's forward
    namespace = {"__name__": "docs_snippet"}
    exec(compile(setup, "docs/choosing.md", "exec"), namespace)
    spec = solver_registry.get_solver_spec("skf")
    assert (spec.module_path, spec.class_name) == ("docs_snippet", "SolverSKF")
    fwd, info = fixed
    evoked, cov = _evoked(fwd, info, 20)
    solver = namespace["SolverSKF"]()
    solver.make_inverse_operator(fwd, evoked, alpha="auto", noise_cov=cov)
    stc = solver.apply_inverse_operator(evoked)
    np.testing.assert_array_equal(stc.data, skf_ref.apply_skf(evoked, fwd, cov).data)
