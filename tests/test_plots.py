"""The paper's figure types are drawn and written (Agg backend), with their bad input refused."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from skf_ref import priors_from_snr, reconstruct  # noqa: E402
from skf_ref.study import _plots as plots
from skf_ref.study._regions import region_time_course  # noqa: E402
from skf_ref.study._scenario import make_head_model, p20n20_scenario, simulate  # noqa: E402


@pytest.fixture(scope="module")
def study():
    head = make_head_model(500)
    sim = simulate(head, p20n20_scenario(), 30.0, seed=0)

    def run(ep=20.0, pm=0.0, exponent=1.25, smoother="rts-standardized"):
        theta0, q = priors_from_snr(head.leadfield, sim.sigma, pm, ep, sim.Y.shape[1])
        return reconstruct(
            head.leadfield,
            sim.Y,
            noise_std=sim.sigma,
            theta0=theta0,
            q=q,
            exponent=exponent,
            smoother=smoother,
        )

    return head, sim.truth, run


def is_png(path):
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_time_courses(study, tmp_path):
    head, truth, run = study
    rec = run()
    fig = plots.plot_time_courses(rec, head, truth, title="t", path=tmp_path / "t.png")
    (ax,) = fig.axes
    assert ax.get_xlabel() == "time (ms)" and "normalized" in ax.get_ylabel()
    lines = {(line.get_color(), line.get_linestyle()): line for line in ax.get_lines()}
    # solid: each region's maximum (deep green, superficial red) on one shared scale
    courses = [region_time_course(rec.amplitude(3), head.positions, p) for p in truth.positions]
    scale = max(course.max() for course in courses)
    for colour, course in zip(("tab:green", "tab:red"), courses, strict=True):
        np.testing.assert_allclose(lines[colour, "-"].get_ydata(), course / scale, rtol=1e-12)
        np.testing.assert_allclose(lines[colour, "-"].get_xdata(), truth.times * 1e3)
    # dashed: the true waveforms, the larger peaking at 1
    waves = np.abs(truth.waveforms) / np.abs(truth.waveforms).max()
    for colour, wave in zip(("tab:green", "tab:red"), waves, strict=True):
        np.testing.assert_allclose(lines[colour, "--"].get_ydata(), wave, rtol=1e-12)
    assert len(lines) == 4 and is_png(tmp_path / "t.png")


def test_prior_grid(study, tmp_path):
    head, truth, run = study
    panels = {(ep, pm): run(ep, pm) for ep in (0.0, 20.0) for pm in (0.0, 20.0)}
    fig = plots.plot_prior_grid(panels, head, truth, path=tmp_path / "g.png")
    titles = sorted(ax.get_title() for ax in fig.axes)
    assert titles == ["EP 0, PM 0", "EP 0, PM 20", "EP 20, PM 0", "EP 20, PM 20"]
    assert is_png(tmp_path / "g.png")


def test_exponent_comparison(study, tmp_path):
    head, truth, run = study
    panels = {e: run(exponent=e) for e in (1.0, 1.25, 1.5)}
    fig = plots.plot_exponent_comparison(panels, head, truth, path=tmp_path / "e.png")
    assert len(fig.axes) == 3 and is_png(tmp_path / "e.png")


def test_projections_put_the_maximum_where_it_is(study):
    # one position at 0 dB, all others at -6.02 dB: every projection must show the 0 dB
    # pixel at that position's coordinates (catches transposed or flipped images)
    head, truth, _ = study
    spacing_mm = head.spacing * 1e3
    for index in (0, head.n_positions // 3, head.n_positions - 1):
        amplitude = np.full((head.n_positions, truth.times.size), 0.5)
        amplitude[index] = 1.0
        fig = plots.plot_average_reconstruction(amplitude, head, truth, times_ms=(1.5,))
        for ax in (ax for ax in fig.axes if ax.get_images()):
            image = ax.get_images()[0]
            data = np.ma.masked_invalid(image.get_array())
            assert data.max() == 0.0 and data.min() == pytest.approx(20 * np.log10(0.5))
            row, col = np.unravel_index(np.ma.argmax(data), data.shape)
            left, right, bottom, top = image.get_extent()
            x = left + (col + 0.5) * (right - left) / data.shape[1]
            y = bottom + (row + 0.5) * (top - bottom) / data.shape[0]
            view = ax.get_title().split()[0]
            horizontal, vertical = {"sagittal": (1, 2), "coronal": (0, 2), "axial": (0, 1)}[view]
            true_mm = head.positions[index] * 1e3
            assert abs(x - true_mm[horizontal]) < spacing_mm / 2, (view, index)
            assert abs(y - true_mm[vertical]) < spacing_mm / 2, (view, index)
            assert "MIP" in ax.get_title() and "\u2192" in ax.get_xlabel()  # head frame


def test_average_reconstruction_maps(study, tmp_path):
    head, truth, run = study
    rec = run()
    fig = plots.plot_average_reconstruction(rec, head, truth, path=tmp_path / "m.png")
    images = [ax for ax in fig.axes if ax.get_images()]
    assert len(images) == 6  # three projections at 1.5 and at 2.5 ms
    assert {ax.get_images()[0].get_clim() for ax in images} == {(-6.0, 0.0)}  # 6 dB range
    assert any(ax.get_ylabel() == "dB re. maximum at that time" for ax in fig.axes)
    assert is_png(tmp_path / "m.png")
    # an amplitude averaged over runs is accepted as well
    average = np.mean([rec.amplitude(3), run(exponent=1.0).amplitude(3)], axis=0)
    plots.plot_average_reconstruction(average, head, truth, times_ms=(2.5,))


def test_same_figure_same_bytes(study, tmp_path):
    head, truth, run = study
    rec = run()
    plots.plot_time_courses(rec, head, truth, path=tmp_path / "a.png")
    plots.plot_time_courses(rec, head, truth, path=tmp_path / "b.png")
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda h, t, r: plots.plot_prior_grid({}, h, t), "non-empty dict"),
        (lambda h, t, r: plots.plot_exponent_comparison([r], h, t), "must be a dict"),
        (lambda h, t, r: plots.plot_time_courses(np.ones((3, 41)), h, t), "n_positions"),
        (
            lambda h, t, r: plots.plot_average_reconstruction(r, h, t, times_ms=(9.0,)),
            "times_ms must be times within",
        ),
        (
            lambda h, t, r: plots.plot_average_reconstruction(r, h, t, dynamic_range_db=0),
            "dynamic_range_db must be > 0",
        ),
    ],
)
def test_bad_input(study, call, match):
    head, truth, run = study
    with pytest.raises(ValueError, match=match):
        call(head, truth, run())
