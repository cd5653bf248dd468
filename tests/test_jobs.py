"""n_jobs of apply_skf_epochs and apply_skf_raw (MNE's convention): the same estimates, to
rounding, in this process, in joblib's processes and on a Dask cluster."""

import warnings

import joblib
import mne
import numpy as np
import pytest
from rounding import assert_same_to_rounding

import skf_ref
from skf_ref import InputError, InputTypeError
from skf_ref._utils.parallel import plan_jobs


@pytest.fixture(scope="module")
def setup():
    """A biosemi32 sphere forward on a 20 mm grid (257 positions), 8 epochs of 60 samples of
    white noise with the average reference as a projector, their covariance and operator."""
    montage = mne.channels.make_standard_montage("biosemi32")
    info = mne.create_info(montage.ch_names, 500.0, "eeg").set_montage(montage)
    sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    src = mne.setup_volume_source_space(sphere=sphere, pos=20.0, mindist=5.0, verbose=False)
    forward = mne.make_forward_solution(info, None, src, sphere, verbose=False)
    rng = np.random.default_rng(0)
    data = 5e-6 * rng.standard_normal((8, 32, 60))
    epochs = mne.EpochsArray(data, info, tmin=-0.02, baseline=(None, 0.0), verbose=False)
    epochs.set_eeg_reference("average", projection=True, verbose=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # few samples: a test's covariance
        cov = mne.compute_covariance(epochs, verbose=False)
    operator = skf_ref.make_skf_operator(epochs.info, forward, cov, verbose=False)
    raw = mne.io.RawArray(np.concatenate(list(data), axis=1), info, verbose=False)
    raw.set_eeg_reference("average", projection=True, verbose=False)
    return dict(epochs=epochs, operator=operator, raw=raw)


def _same(many, one, what):
    assert len(many) == len(one)
    for k, (a, b) in enumerate(zip(many, one, strict=True)):
        assert type(a) is type(b) and a.tmin == b.tmin and a.tstep == b.tstep
        assert_same_to_rounding(a.data, b.data, what=f"{what}, epoch {k}")


@pytest.mark.slow  # two worker processes started: CI runs it with the slow tests
def test_epochs_give_the_same_estimates_for_any_n_jobs(setup):
    epochs, operator = setup["epochs"], setup["operator"]
    one = skf_ref.apply_skf_epochs(epochs, operator, n_jobs=1, pick_ori="vector")
    two = skf_ref.apply_skf_epochs(epochs, operator, n_jobs=2, pick_ori="vector")
    unset = skf_ref.apply_skf_epochs(epochs, operator, pick_ori="vector")  # no context: here
    with joblib.parallel_config(n_jobs=2):  # None takes the context's (MNE's convention)
        assert plan_jobs(None).count == 2
        context = skf_ref.apply_skf_epochs(epochs, operator, pick_ori="vector")
    assert len(one) == 8
    for many, what in ((two, "n_jobs=2"), (unset, "n_jobs=None"), (context, "context")):
        _same(many, one, what)


def test_more_jobs_than_epochs_and_every_smoother(setup):
    epochs, operator = setup["epochs"][:1], setup["operator"]
    for smoother in (None, "rts-smoothed-weights"):
        one = skf_ref.apply_skf_epochs(epochs, operator, smoother=smoother, n_jobs=1)
        many = skf_ref.apply_skf_epochs(epochs, operator, smoother=smoother, n_jobs=2)
        _same(many, one, f"2 jobs, 1 epoch, {smoother}")


@pytest.mark.parametrize("smoother", [None, "rts-standardized"])
@pytest.mark.parametrize("pick_ori", [None, "vector"])
def test_a_recording_gives_the_same_estimate_for_any_n_jobs(setup, smoother, pick_ori):
    raw, operator = setup["raw"], setup["operator"]
    settings = dict(smoother=smoother, pick_ori=pick_ori, start=10, stop=400)
    one = skf_ref.apply_skf_raw(raw, operator, n_jobs=1, **settings)
    two, rec = skf_ref.apply_skf_raw(
        raw, operator, n_jobs=2, return_reconstruction=True, **settings
    )
    assert rec.computed("z")  # computed by the jobs, held here
    assert one.tmin == two.tmin and type(one) is type(two)
    assert_same_to_rounding(two.data, one.data, what=f"raw, {smoother}, {pick_ori}")
    assert_same_to_rounding(rec.z, rec.lazy_outputs.array("z"), what="held z")


def test_a_recording_with_a_bad_segment(setup):
    raw, operator = setup["raw"].copy(), setup["operator"]
    raw.set_annotations(mne.Annotations(onset=0.2, duration=0.1, description="BAD_blink"))
    one = skf_ref.apply_skf_raw(raw, operator, n_jobs=1, stop=300)
    two = skf_ref.apply_skf_raw(raw, operator, n_jobs=2, stop=300)
    assert np.isnan(two.data[:, 100:150]).all()
    assert_same_to_rounding(two.data, one.data, what="a bad segment")  # NaN at the same steps


def test_outputs_computed_at_once_stay_as_they_are():
    # the dense path computes every output at once: the jobs have nothing to do
    from skf_ref._utils.parallel import Jobs
    from skf_ref.io._jobs import rows_in_jobs

    rng = np.random.default_rng(1)
    L, Y = rng.standard_normal((8, 12)), rng.standard_normal((8, 20))
    rec = skf_ref.reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1, path="dense")
    z = rec.z
    rows_in_jobs(rec, 3, Jobs(2, 2, False))
    assert rec.z is z


def test_the_jobs_write_a_store_of_the_same_numbers(setup, tmp_path):
    pytest.importorskip("zarr")
    raw, operator = setup["raw"], setup["operator"]
    settings = dict(smoother="rts-standardized", pick_ori="vector")
    skf_ref.apply_skf_raw(raw, operator, out=tmp_path / "one.zarr", n_jobs=1, **settings)
    store = skf_ref.apply_skf_raw(raw, operator, out=tmp_path / "two.zarr", n_jobs=2, **settings)
    assert store["data"].shape == (257, 3, 480)
    whole = skf_ref.apply_skf_raw(raw, operator, **settings)
    for name in ("one", "two"):  # every chunk there, its checksum right
        read = skf_ref.read_skf_stream(tmp_path / f"{name}.zarr")
        assert_same_to_rounding(read.data, whole.data, what=name)
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary


@pytest.mark.parametrize(
    "n_jobs, error, message",
    [
        (0, InputError, "n_jobs must be a number of jobs (1: in this process, -1: every core)"),
        (1.5, InputTypeError, "n_jobs must be an integer, got 1.5"),
        ("2", InputTypeError, "n_jobs must be an integer, got '2'"),
        (True, InputTypeError, "n_jobs must be an integer, got True"),
    ],
)
def test_n_jobs_is_checked_before_any_work(setup, n_jobs, error, message):
    for apply, data in ((skf_ref.apply_skf_epochs, "epochs"), (skf_ref.apply_skf_raw, "raw")):
        with pytest.raises(error) as caught:
            apply(setup[data], setup["operator"], n_jobs=n_jobs)
        assert str(caught.value).startswith(message)


def test_a_generator_computes_here(setup):
    epochs, operator = setup["epochs"], setup["operator"]
    with pytest.raises(InputError, match=r"n_jobs=2 shares the epochs .* give one of them"):
        skf_ref.apply_skf_epochs(epochs, operator, return_generator=True, n_jobs=2)
    with joblib.parallel_config(n_jobs=2):  # None: the generator computes here, as asked
        lazily = skf_ref.apply_skf_epochs(epochs, operator, return_generator=True)
        first = next(lazily)
    one = skf_ref.apply_skf_epochs(epochs[:1], operator)
    np.testing.assert_array_equal(first.data, one[0].data)  # the same function, same data


def test_joblib_contexts_that_run_here():
    assert plan_jobs(None).local and plan_jobs(1).local
    with joblib.parallel_config(backend="threading"):  # its default: one job
        assert plan_jobs(None).local
    with joblib.parallel_config(backend="threading", n_jobs=2):
        assert not plan_jobs(None).local and plan_jobs(None).count == 2


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("distributed", reason="the extra 'dask' is not installed")
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield client


@pytest.mark.filterwarnings("ignore:Sending large graph:UserWarning")  # the operator, once
def test_a_dask_cluster_through_joblib(setup, client):
    from distributed import get_task_stream

    epochs, raw, operator = setup["epochs"], setup["raw"], setup["operator"]
    one = skf_ref.apply_skf_epochs(epochs, operator, n_jobs=1)
    whole = skf_ref.apply_skf_raw(raw, operator, smoother="rts-state", n_jobs=1)
    with joblib.parallel_config(backend="dask"), get_task_stream(client) as tasks:
        assert plan_jobs(None).count == 2  # the cluster's threads
        remote = skf_ref.apply_skf_epochs(epochs, operator)
        recording = skf_ref.apply_skf_raw(raw, operator, smoother="rts-state")
    assert len(tasks.data) >= 4  # two parts of the epochs and two of the rows, there
    _same(remote, one, "dask")
    assert_same_to_rounding(recording.data, whole.data, what="dask raw")
