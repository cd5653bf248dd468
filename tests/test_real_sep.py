"""The real-SEP analysis's parts, on made-up data: the discrepancy principle, the criteria's
geometry and latencies, the settings list and the report's verdict (the report itself is
``python -m validation.real_sep``)."""

import numpy as np
import pandas as pd
import pytest

mne = pytest.importorskip("mne")

from skf_ref.datasets import forward_from_leadfield  # noqa: E402
from validation.real_sep import criteria, geometry, methods, report, settings  # noqa: E402


def _problem(seed=0, n_sources=40, amplitude=3e-6):
    """A fixed forward of random columns on biosemi32, and an average with a pulse."""
    montage = mne.channels.make_standard_montage("biosemi32")
    info = mne.create_info(montage.ch_names, 1000.0, "eeg").set_montage(montage)
    rng = np.random.default_rng(seed)
    rr = rng.uniform(-0.04, 0.04, (n_sources, 3)) + [0.0, 0.0, 0.04]
    nn = np.tile([0.0, 0.0, 1.0], (n_sources, 1))
    L = rng.standard_normal((32, n_sources)) * 1e-6 / 1e-9
    L -= L.mean(axis=0)
    forward = forward_from_leadfield(info, L, rr, nn)
    times = np.arange(-0.05, 0.05, 0.001)
    pulse = np.exp(-(((times - 0.02) / 0.005) ** 2))
    data = np.outer(L[:, 3], pulse) * amplitude / np.abs(
        L[:, 3]
    ).max() + 1e-6 * rng.standard_normal((32, len(times)))
    evoked = mne.EvokedArray(data - data.mean(axis=0), info, tmin=times[0], nave=1)
    evoked.set_eeg_reference("average", projection=True, verbose=False)
    cov = mne.make_ad_hoc_cov(info, std=dict(eeg=1e-6), verbose=False)
    return evoked, forward, cov


def test_the_discrepancy_lambda2_makes_the_residual_the_noise_s_energy():
    from mne.minimum_norm import apply_inverse, make_inverse_operator
    from mne.proj import make_projector

    evoked, forward, cov = _problem()
    inverse = make_inverse_operator(
        evoked.info, forward, cov, loose=0.0, depth=None, verbose=False
    )
    lambda2, solved = methods.discrepancy_lambda2(evoked, inverse)
    assert solved
    stc = apply_inverse(evoked, inverse, lambda2, "MNE", verbose=False)
    residual = evoked.data - forward["sol"]["data"] @ stc.data
    whitener = mne.cov.compute_whitener(cov, evoked.info, pca=True, verbose=False)[0]
    P = make_projector(evoked.info["projs"], evoked.ch_names)[0]
    after = evoked.times > 0
    energy = ((whitener @ P @ residual[:, after]) ** 2).sum()
    assert energy == pytest.approx(whitener.shape[0] * after.sum(), rel=1e-6)


def test_the_discrepancy_keeps_a_bound_when_the_data_are_within_the_noise():
    from mne.minimum_norm import make_inverse_operator

    evoked, forward, cov = _problem(amplitude=0.0)
    evoked.data *= 1e-3  # far below the noise the covariance announces
    inverse = make_inverse_operator(
        evoked.info, forward, cov, loose=0.0, depth=None, verbose=False
    )
    assert methods.discrepancy_lambda2(evoked, inverse) == (10.0**4, False)


def _recording():
    """A made-up recording: a 10 mm grid in a 80 mm ball, its centre at the origin."""
    axis = np.arange(-0.08, 0.081, 0.01)
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), -1).reshape(-1, 3)
    positions = grid[np.linalg.norm(grid, axis=1) <= 0.08]
    radial = np.array([-0.7, -0.2, 0.68])
    radial /= np.linalg.norm(radial)
    times = np.arange(0.0, 0.03, 0.001)
    evoked = type("E", (), {"times": times})()
    return geometry.Recording(
        name="made-up",
        evoked=evoked,
        forward=None,
        noise_cov=None,
        centre=np.zeros(3),
        radius=0.09,
        central=(0.09 - criteria.CENTRAL_DEPTH) * radial,
        radial=radial,
        positions=positions,
        orientations=None,
        latencies={"P14": 0.014, "P16": 0.016, "N20": 0.020},
    )


def test_measure_scores_a_central_n20_and_deep_p14_and_p16():
    recording = _recording()
    amplitude = np.full((len(recording.positions), len(recording.evoked.times)), 0.1)
    central = np.argmin(np.linalg.norm(recording.positions - recording.central, axis=1))
    deep = np.argmin(np.linalg.norm(recording.positions, axis=1))
    amplitude[central, recording.sample("N20")] = 1.0
    amplitude[deep, [recording.sample("P14"), recording.sample("P16")]] = 1.0
    row, courses = geometry.measure(recording, amplitude)
    assert row["checks_met"] == 5 and row["N20_left"] and row["N20_to_central_mm"] == 0
    assert row["P14_deep_share"] == 1.0 and row["N20_deep_share"] == pytest.approx(0.1)
    assert set(courses) == {"N20 maximum", "P14 maximum", "central region", "deep region"}
    # the same maxima mirrored to the right hemisphere and the surface: checks fail
    mirrored = recording.positions * [-1, 1, 1]
    right = np.argmin(np.linalg.norm(mirrored - recording.positions[central], axis=1))
    amplitude[right, recording.sample("N20")] = 2.0
    row, _ = geometry.measure(recording, amplitude)
    assert not row["check_N20_left"] and not row["check_N20_central"]
    assert row["checks_met"] == 3


def test_latencies_from_the_gfp():
    info = mne.create_info(4, 1000.0, "eeg")
    times = np.arange(-0.01, 0.04, 0.001)
    gfp = sum(np.exp(-(((times - t) / 0.0015) ** 2)) * a for t, a in ((0.014, 1), (0.019, 2)))
    data = np.array([1.0, -1.0, 0.5, -0.5])[:, None] * gfp
    evoked = mne.EvokedArray(data, info, tmin=times[0], verbose=False)
    found = geometry.latencies(evoked, 0.0193)
    assert found == pytest.approx({"P14": 0.014, "P16": 0.0165, "N20": 0.019}, abs=1e-9)
    with pytest.raises(ValueError, match="no GFP peak from 8 to 4 ms before the N20"):
        geometry.latencies(evoked, 0.014)


def test_the_settings_hold_both_skf_settings_and_every_mne_method():
    rows = settings.settings()
    names = [name for name, _, _ in rows]
    for setting in ("paper", "recommended"):
        assert {f"SKF {setting}, {p}" for p in settings.SKF_PRIORS} <= set(names)
    families = {family for _, family, _ in rows}
    assert families == set(methods.FAMILIES)
    assert {params["priors"] for _, _, params in rows} == {"data", "fixed"}
    assert len(names) == len(set(names))


def _table(skf_checks, mne_checks):
    rows = []
    for setting, family, priors, checks in (
        ("SKF recommended, auto", "skf", "data", skf_checks),
        ("SKF paper, auto", "skf", "data", skf_checks - 1),
        ("sLORETA, lambda2 discrepancy", "minimum_norm", "data", mne_checks),
    ):
        rows.append(
            dict(
                recording="r",
                setting=setting,
                family=family,
                priors=priors,
                checks_met=checks,
                N20_to_central_mm=0.0,
            )
        )
    return pd.DataFrame(rows)


def test_the_verdict_says_so_when_the_skf_does_no_better():
    assert "SKF did no better than MNE-Python's methods" in report.verdict(_table(3, 3))
    assert "SKF did no better" in report.verdict(_table(2, 3))
    assert "at least as well" in report.verdict(_table(4, 3))
    assert "is better than the paper's" in report.contrasts(_table(3, 3))


def test_the_criteria_come_before_what_cannot_be_known():
    text, unknowns = report.criteria_and_unknowns()
    assert text.startswith("### The criteria, written before the numbers")
    assert unknowns.startswith("### What cannot be known here")
    for check in ("N20 left", "N20 central", "N20 cortical", "P14 deep", "P16 deep"):
        assert check in text


def test_every_candidate_runs_with_every_dynamics():
    rows = {name: params for name, _, params in settings.settings()}
    for candidate in settings.CANDIDATES:
        for priors in (*settings.SKF_PRIORS, *settings.AR1_PRIORS):
            params = rows[f"SKF {candidate}, {priors}"]
            assert params["exponent"] == 0.5
            assert ("time_constant_ms" in params) != ("ep_snr_db" in params)
            assert params["priors"] == ("data" if priors in settings.BY_DATA else "fixed")
    assert rows["SKF position, PM0/ARauto"]["time_constant_ms"] == "auto"
    assert rows["SKF position, PM0/ARauto"]["pm_snr_db"] == 0.0
    # the earlier rows are kept as they were
    assert (
        rows["SKF paper, auto"]["exponent"] == 1.25
        and "time_constant_ms" not in rows["SKF paper, auto"]
    )


def test_the_skf_note_says_which_evolution_prior():
    from types import SimpleNamespace

    assert methods._skf_note(dict(pm_snr_db=0.0, ep_snr_db=20.0), None) == "PM 0.0 / EP 20.0 dB"
    assert methods._skf_note(dict(pm_snr_db=0.0, time_constant_ms=30.0), None) == (
        "PM 0.0 dB / tau 30 ms"
    )
    chosen = SimpleNamespace(
        pm_snr_db=0.0,
        ep_snr_db=None,
        time_constant_ms=1000.0,
        at_bound={"time_constant_ms": "upper"},
    )
    note = methods._skf_note(dict(pm_snr_db=0.0, time_constant_ms="auto"), chosen)
    assert note == "PM 0.0 dB / tau 1e+03 ms (time_constant_ms at its upper bound)"


def test_the_candidates_table_marks_a_left_central_n20():
    rows = []
    for setting in report.CANDIDATE_NAMES:
        for priors in report.DYNAMICS:
            n20 = setting == "position" and priors == "PM0/ARauto"
            rows.append(
                dict(
                    setting=f"SKF {setting}, {priors}",
                    checks_met=3 if n20 else 1,
                    N20_to_central_mm=0.0 if n20 else 40.0,
                    check_N20_left=True,
                    check_N20_central=n20,
                    check_N20_cortical=True,
                )
            )
    table = report.candidates_table(pd.DataFrame(rows))
    assert table.count("**") == 2 and "**3/5, 0 mm**" in table
    assert len(table.splitlines()) == 2 + len(report.CANDIDATE_NAMES)


def test_the_neck_rows_are_the_ones_the_rule_names():
    """The rule's text (criteria.NECK_RULE, committed before the run that used it) names
    the rows the code drops."""
    pytest.importorskip("spharapy", reason="the 256-channel SEP ships in spharapy")
    import re

    from skf_ref.datasets import load_sep256_evoked
    from validation.real_sep import neck

    evoked = load_sep256_evoked()
    rows = neck.neck_rows(evoked, neck.sep256_triangles())
    listed = re.search(r"35 electrodes below the plane: (.*?)\. 29", criteria.NECK_RULE, re.S)
    assert rows.names == [name.strip() for name in listed.group(1).split(",")]
    assert rows.scale == pytest.approx(0.935, abs=5e-4) and rows.kept == 331
    positions = np.array([ch["loc"][:3] for ch in evoked.info["chs"]])
    # below the plane: lower than every electrode kept at the back, none on the crown
    assert positions[rows.below, 2].max() < 0.035 < positions[~rows.below, 2].max()
    behind = positions[rows.below, 1] < rows.landmarks["lpa"][1]
    assert behind.sum() == 29


def test_the_variants_table_sets_the_rule_beside_its_neighbours():
    def row(recording, setting, met, mm, central):
        return dict(
            recording=recording,
            setting=setting,
            checks_met=met,
            N20_to_central_mm=mm,
            check_N20_left=True,
            check_N20_central=central,
            check_N20_cortical=True,
            rows=39 if recording == "trim 5 mm" else 33,
        )

    rule = pd.DataFrame([row("sep256-head", "SKF position, PM0/EP0", 3, 0.0, True)])
    variants = pd.DataFrame(
        [
            row("trim 5 mm", "SKF position, PM0/EP0", 3, 0.0, True),
            row("rotation allowed", "SKF position, PM0/EP0", 2, 24.0, False),
        ]
    )
    table = report.variants_table(rule, variants, 35).splitlines()
    assert table[0] == (
        "| setting | the rule (35 rows) | trim 5 mm (39 rows) | rotation allowed (33 rows) |"
    )
    assert table[2] == "| position, PM0/EP0 | **3/5, 0 mm** | **3/5, 0 mm** | 2/5, 24 mm |"
