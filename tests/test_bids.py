"""apply_skf_bids and ``skf-ref bids`` on MNE-BIDS-pipeline's derivatives.

MNE-BIDS-pipeline itself does not run here (it needs mne-bids, a FreeSurfer subject for its
BEM and minutes of recording per subject), so the fixture writes its derivatives with plain
MNE, in the layout and under the names the pipeline (1.10) gives them: per subject (and
session) folder, the evokeds of a task (``sub-01_task-audvis_ave.fif``, conditions by their
comment, a contrast among them), the forward without the task (``sub-01_fwd.fif``), the
noise covariance of the baseline (``sub-01_proc-clean_cov.fif``) and its rank
(``sub-01_proc-clean_rank.json``). The forward is a sphere model of a BioSemi cap; one
subject's evokeds lack the average-reference projector, which the pipeline adds before its
inverse. A slow test writes the sample subject's MEG and EEG the same way (MNE's testing
dataset: its BEM forward, its noise covariance and the rank MNE computes for it).
"""

import json
import os
import shutil
import warnings

import mne
import numpy as np
import pytest
from rounding import TUNED_RTOL, assert_same_to_rounding

import skf_ref
from skf_ref import InputError
from skf_ref.io._bids import output_name

CONDITIONS = ("auditory/left", "visual")
NAMES = ("auditoryleft", "visual", "auditoryleftvisual")  # the contrast's name last
#: The subject folders, with the prefix of their files: a subject with a session too.
FOLDERS = {"sub-01/eeg": "sub-01", "sub-02/ses-a/eeg": "sub-02_ses-a"}


def _write_subject(folder, prefix, forward, info, seed):
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True)
    n, T = 20, 60
    gain = forward["sol"]["data"][:, 300:303] @ [0.0, 0.6, 0.8]
    wave = np.where(np.arange(T) > 10, np.sin(np.linspace(0, np.pi, T)), 0.0)
    events = np.column_stack([np.arange(n) * T, np.zeros(n, int), np.arange(n) % 2 + 1])
    data = 5e-6 * rng.standard_normal((n, len(gain), T))
    data[events[:, 2] == 1] += np.outer(gain, 2e-8 * wave)
    epochs = mne.EpochsArray(
        data,
        info,
        events=events,
        tmin=-0.02,
        event_id={CONDITIONS[0]: 1, CONDITIONS[1]: 2},
        baseline=(None, 0.0),
        verbose=False,
    )
    epochs.set_eeg_reference("average", projection=True, verbose=False)
    evokeds = [epochs[condition].average() for condition in CONDITIONS]
    contrast = mne.combine_evoked(evokeds, weights=[1, -1])
    contrast.comment = f"{CONDITIONS[0]} - {CONDITIONS[1]}"  # the pipeline's contrast name
    if seed:  # no reference projector: given one, as the pipeline does before its inverse
        evokeds = [evoked.copy().del_proj() for evoked in (*evokeds, contrast)]
    else:
        evokeds.append(contrast)
    mne.write_evokeds(folder / f"{prefix}_task-audvis_ave.fif", evokeds)
    mne.write_forward_solution(folder / f"{prefix}_fwd.fif", forward)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # few samples: a test's covariance
        cov = mne.compute_covariance(epochs, tmax=0.0, verbose=False)
    cov.save(folder / f"{prefix}_proc-clean_cov.fif", verbose=False)
    rank = mne.compute_rank(epochs, rank="info", verbose=False)
    (folder / f"{prefix}_proc-clean_rank.json").write_text(json.dumps(rank))


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    """The derivatives, written once: each test copies them (:func:`derivatives`)."""
    montage = mne.channels.make_standard_montage("biosemi32")
    info = mne.create_info(montage.ch_names, 500.0, "eeg").set_montage(montage)
    sphere = mne.make_sphere_model("auto", "auto", info, verbose=False)
    src = mne.setup_volume_source_space(sphere=sphere, pos=20.0, mindist=5.0, verbose=False)
    forward = mne.make_forward_solution(info, None, src, sphere, verbose=False)
    root = tmp_path_factory.mktemp("bids") / "derivatives" / "mne-bids-pipeline"
    for seed, (folder, prefix) in enumerate(FOLDERS.items()):
        _write_subject(root / folder, prefix, forward, info, seed)
    return root


@pytest.fixture
def derivatives(pristine, tmp_path):
    root = tmp_path / "mne-bids-pipeline"
    shutil.copytree(pristine, root)
    return root


def _expected(root):
    return [
        root / folder / f"{prefix}_task-audvis_{name}+SKF+hemi.h5"
        for folder, prefix in FOLDERS.items()
        for name in NAMES
    ]


def _mtimes(paths):
    return {path: os.stat(path).st_mtime_ns for path in paths}


def _hidden(root):
    return [path for path in root.rglob(".*")]


def test_an_estimate_beside_each_evoked_named_as_the_pipeline_names_its_own(derivatives):
    done = skf_ref.apply_skf_bids(derivatives)
    assert done == {"written": _expected(derivatives), "skipped": []}
    folder, prefix = next(iter(FOLDERS.items()))
    evokeds = mne.read_evokeds(derivatives / folder / f"{prefix}_task-audvis_ave.fif")
    operator = skf_ref.make_skf_operator(
        evokeds[0].info,
        mne.read_forward_solution(derivatives / folder / f"{prefix}_fwd.fif"),
        mne.read_cov(derivatives / folder / f"{prefix}_proc-clean_cov.fif"),
        rank={"eeg": 31},
        verbose=False,
    )
    for evoked, path in zip(evokeds, done["written"][:3], strict=True):
        stc = mne.read_source_estimate(path)
        assert isinstance(stc, mne.VolSourceEstimate) and stc.data.shape == (257, 60)
        direct = skf_ref.apply_skf(evoked, operator, verbose=False)
        assert_same_to_rounding(stc.data, direct.data, what=path.name)
        record = json.loads(path.with_suffix(".json").read_text())
        assert record["condition"] == evoked.comment and record["nave"] == evoked.nave
        assert record["forward"] == f"{prefix}_fwd.fif" and record["rank"] == {"eeg": 31}
        assert record["method"] == "SKF" and record["exponent"] == 0.5
    assert not _hidden(derivatives)


def test_a_second_run_skips_what_is_done(derivatives):
    first = skf_ref.apply_skf_bids(derivatives)["written"]
    before = _mtimes(first + [path.with_suffix(".json") for path in first])
    again = skf_ref.apply_skf_bids(derivatives)
    assert again == {"written": [], "skipped": first}
    assert _mtimes(before) == before
    replaced = skf_ref.apply_skf_bids(derivatives, subjects=["01"], overwrite=True)
    assert replaced["written"] == first[:3] and not replaced["skipped"]


def test_an_interrupted_run_resumes_without_redoing_the_first_subject(derivatives, monkeypatch):
    # the second subject is interrupted while its second estimate is being written: that
    # file is half written under its temporary name when the interruption comes
    calls = []
    save = mne.VolSourceEstimate.save

    def interrupted(self, fname, *args, **kwargs):
        calls.append(fname)
        if len(calls) == 5:
            with open(fname, "wb") as half:
                half.write(b"\x89HDF")
            raise KeyboardInterrupt
        return save(self, fname, *args, **kwargs)

    monkeypatch.setattr(mne.VolSourceEstimate, "save", interrupted)
    with pytest.raises(KeyboardInterrupt):
        skf_ref.apply_skf_bids(derivatives)
    monkeypatch.setattr(mne.VolSourceEstimate, "save", save)
    expected = _expected(derivatives)
    assert [path.exists() for path in expected] == [True] * 4 + [False] * 2
    assert not _hidden(derivatives)  # the half file went with its temporary name
    first = _mtimes(expected[:4])
    resumed = skf_ref.apply_skf_bids(derivatives)
    assert resumed == {"written": expected[4:], "skipped": expected[:4]}
    assert _mtimes(first) == first


@pytest.mark.slow  # two worker processes started: CI runs it with the slow tests
def test_two_jobs_write_what_one_writes(pristine, tmp_path):
    roots = []
    for n_jobs in (1, 2):
        root = tmp_path / f"jobs-{n_jobs}"
        shutil.copytree(pristine, root)
        assert skf_ref.apply_skf_bids(root, n_jobs=n_jobs)["written"] == _expected(root)
        roots.append(root)
    for one, two in zip(*(_expected(root) for root in roots), strict=True):
        a, b = mne.read_source_estimate(one), mne.read_source_estimate(two)
        # each worker chooses its subject's priors (one BLAS thread there, two here)
        assert_same_to_rounding(b.data, a.data, rtol=TUNED_RTOL, what=one.name)


@pytest.mark.slow  # a Dask cluster started: CI runs it with the slow tests
@pytest.mark.filterwarnings("ignore:Sending large graph:UserWarning")
def test_a_dask_cluster_writes_what_one_job_writes(pristine, tmp_path):
    distributed = pytest.importorskip("distributed", reason="the extra 'dask' is not installed")
    joblib = pytest.importorskip("joblib")
    one, there = tmp_path / "one", tmp_path / "dask"
    for root in (one, there):
        shutil.copytree(pristine, root)
    assert skf_ref.apply_skf_bids(one, n_jobs=1)["written"] == _expected(one)
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
        joblib.parallel_config(backend="dask"),
        distributed.get_task_stream(client) as tasks,
    ):
        assert skf_ref.apply_skf_bids(there)["written"] == _expected(there)
    assert len(tasks.data) >= 2  # a subject folder a task, on the cluster
    for a, b in zip(_expected(one), _expected(there), strict=True):
        read = mne.read_source_estimate(a), mne.read_source_estimate(b)
        assert_same_to_rounding(read[1].data, read[0].data, rtol=TUNED_RTOL, what=b.name)


def test_the_group_average_folder_is_left_out_unless_named(derivatives):
    # the pipeline's sensor/_99_group_average writes the grand average to sub-average/, with
    # no forward (MNE-BIDS-pipeline 1.10 run on the testing data: validation/bids_pipeline)
    group = derivatives / "sub-average" / "eeg"
    group.mkdir(parents=True)
    shutil.copy(
        derivatives / "sub-01" / "eeg" / "sub-01_task-audvis_ave.fif",
        group / "sub-average_task-audvis_proc-clean_ave.fif",
    )
    assert skf_ref.apply_skf_bids(derivatives)["written"] == _expected(derivatives)
    with pytest.raises(InputError, match="sub-average_task-audvis_proc-clean_ave.fif: no forward"):
        skf_ref.apply_skf_bids(derivatives, subjects=["average"])


def test_the_inputs_are_checked_before_any_work(derivatives):
    folder = derivatives / "sub-02" / "ses-a" / "eeg"
    cov = folder / "sub-02_ses-a_proc-clean_cov.fif"
    shutil.copy(cov, folder / "sub-02_ses-a_task-noise_proc-clean_cov.fif")  # empty room's too
    with pytest.raises(InputError, match="2 noise covariance .* give noise_cov=PART"):
        skf_ref.apply_skf_bids(derivatives)
    done = skf_ref.apply_skf_bids(derivatives, noise_cov="task-noise", subjects=["02"])
    record = json.loads(done["written"][0].with_suffix(".json").read_text())
    assert record["noise_cov"] == "sub-02_ses-a_task-noise_proc-clean_cov.fif"
    (derivatives / "sub-01" / "eeg" / "sub-01_fwd.fif").unlink()
    with pytest.raises(InputError, match=r"sub-01_task-audvis_ave.fif: no forward"):
        skf_ref.apply_skf_bids(derivatives, noise_cov="proc-clean")
    with pytest.raises(InputError, match="subjects: .* has no folder sub-09"):
        skf_ref.apply_skf_bids(derivatives, subjects=["09"])
    with pytest.raises(InputError, match="holds no evoked of MNE-BIDS-pipeline's derivatives"):
        skf_ref.apply_skf_bids(derivatives / "sub-01")
    assert sorted(derivatives.rglob("*+SKF+hemi.h5")) == sorted(done["written"])  # sub-02


def test_output_names_follow_the_pipeline():
    assert output_name("a/sub-01_ses-2_task-rest_acq-x_ave.fif", "a_b c-d/e").name == (
        "sub-01_ses-2_task-rest_acq-x_abcde+SKF+hemi.h5"
    )


def test_the_command_line(cli, derivatives):
    result = cli("bids", str(derivatives), "--quiet")
    assert result.returncode == 0 and result.stderr == ""
    assert all(path.exists() for path in _expected(derivatives))
    again = cli("bids", str(derivatives))
    assert again.returncode == 0
    assert (
        again.stderr == "0 estimates written, 6 there already (--overwrite computes them again)\n"
    )


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["no/such/root"], "argument DERIVATIVES_ROOT: no/such/root: no such folder"),
        (["{root}/sub-01"], "argument DERIVATIVES_ROOT: {root}/sub-01 holds no evoked"),
        (["{root}", "--subject", "07"], "argument --subject: {root} has no folder sub-07"),
        (["{root}", "--jobs", "0"], "argument --jobs: must be a positive number"),
    ],
)
def test_the_command_line_refuses_a_bad_root_in_one_line(cli, derivatives, arguments, message):
    arguments = [a.format(root=derivatives) for a in arguments]
    result = cli("bids", *arguments)
    assert result.returncode == 2
    assert result.stderr.startswith("skf-ref: error: " + message.format(root=derivatives))
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr


@pytest.fixture(scope="module")
def testing_data():
    from skf_ref.study._head import find_testing_data

    found = find_testing_data(os.environ.get("SKF_REF_TESTING_DATA"))
    if found is None:
        pytest.skip(
            "MNE's testing dataset was not found (MNE's lookup without downloading, or the "
            "folder SKF_REF_TESTING_DATA names): this test needs the sample subject"
        )
    return found


@pytest.mark.slow  # the sample subject's BEM forward
@pytest.mark.filterwarnings("ignore:the whitener has rank")  # Maxwell filtered: rank 69 of 306
@pytest.mark.filterwarnings("ignore:The largest eigenvalue")  # MNE's, of the same
def test_the_sample_subject_s_meg_and_eeg(testing_data, tmp_path):
    # the pipeline's derivatives of the sample subject's second of MEG (Maxwell filtered)
    # and EEG (its average-reference projector, as the pipeline's epochs have it): its BEM
    # and head-to-MRI transform (the pipeline's forward, on a 20 mm volume grid), the noise
    # covariance of its recording and the rank the pipeline computes from it ("info")
    raw = mne.io.read_raw_fif(testing_data / "SSS" / "sample_audvis_trunc_raw_sss.fif")
    raw.load_data(verbose=False)
    starts = raw.first_samp + np.arange(30, len(raw.times) - 40, 50)
    events = np.column_stack([starts, np.zeros_like(starts), starts // 50 % 2 + 1])
    event_id = {"auditory": 1, "visual": 2}
    epochs = mne.Epochs(raw, events, event_id, tmin=-0.05, tmax=0.1, preload=True, verbose=False)
    evokeds = [epochs[condition].average() for condition in event_id]
    folder = tmp_path / "sub-01" / "meg"
    folder.mkdir(parents=True)
    mne.write_evokeds(folder / "sub-01_task-audvis_ave.fif", evokeds, verbose=False)
    subjects = testing_data / "subjects"
    surfaces = mne.read_bem_surfaces(subjects / "sample" / "bem" / "sample-1280-1280-1280-bem.fif")
    bem = mne.make_bem_solution(surfaces, verbose=False)
    src = mne.setup_volume_source_space(
        "sample", pos=20.0, bem=bem, subjects_dir=subjects, mindist=5.0, verbose=False
    )
    trans = testing_data / "MEG" / "sample" / "sample_audvis_trunc-trans.fif"
    forward = mne.make_forward_solution(raw.info, trans, src, bem, verbose=False)
    mne.write_forward_solution(folder / "sub-01_fwd.fif", forward, verbose=False)
    cov = mne.read_cov(testing_data / "MEG" / "sample" / "sample_audvis_trunc-cov.fif")
    cov.save(folder / "sub-01_proc-clean_cov.fif", verbose=False)
    rank = mne.compute_rank(cov, rank="info", info=evokeds[0].info, verbose=False)
    (folder / "sub-01_proc-clean_rank.json").write_text(json.dumps(rank))

    done = skf_ref.apply_skf_bids(tmp_path)
    names = [f"sub-01_task-audvis_{name}+SKF+hemi.h5" for name in event_id]
    assert [path.name for path in done["written"]] == names
    evokeds = mne.read_evokeds(folder / "sub-01_task-audvis_ave.fif", verbose=False)  # float32
    forward = mne.read_forward_solution(folder / "sub-01_fwd.fif", verbose=False)
    operator = skf_ref.make_skf_operator(evokeds[0].info, forward, cov, rank=rank, verbose=False)
    for evoked, path in zip(evokeds, done["written"], strict=True):
        stc = mne.read_source_estimate(path)
        assert stc.data.shape == (len(src[0]["vertno"]), len(epochs.times))
        assert_same_to_rounding(stc.data, skf_ref.apply_skf(evoked, operator).data, what=path.name)
        record = json.loads(path.with_suffix(".json").read_text())
        assert record["rank"] == rank and len(record["channels"]["used"]) == 364
        left_out = {"bad in the noise covariance": ["MEG 2443", "EEG 053"]}
        assert record["channels"]["left_out"] == left_out
