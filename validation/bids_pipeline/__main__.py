"""``skf-ref bids`` on derivatives that MNE-BIDS-pipeline itself wrote.

Usage::

    python -m validation.bids_pipeline --mne-testing-data DIR --work DIR

(with ``mne``, ``mne-bids``, ``mne-bids-pipeline`` and ``skf_ref[mne]`` in the Python that
runs it; ``mne_bids_pipeline`` and ``skf-ref`` are taken beside that Python). Steps:

1. a FreeSurfer folder ``WORK/subjects/sub-01``: the testing data's ``subjects/sample``
   (T1 and BEM surfaces, no cortical surfaces), plus the BEM solution of its 3-layer
   1280-triangle model and a 10 mm volume source space, stored under the names the
   pipeline's forward step reads (``sub-01-5120-5120-5120-bem-sol.fif``,
   ``sub-01-10-src.fif``, as ``config.py`` sets ``spacing = 10``);
2. a BIDS dataset ``WORK/bids`` (mne-bids): ``sub-01_task-audvis_meg.fif`` from the
   Maxwell-filtered truncated sample recording (1 s, MEG and EEG) with eight events at fixed
   times alternately ``fixed/a`` and ``fixed/b`` (the recording holds no stimulus), and
   the T1 with the fiducials the testing data's trans gives (the pipeline's head-MRI
   transform);
3. ``mne_bids_pipeline --config=config.py`` (its entry point, run by ``_pipeline.py``,
   which stubs the HTML report's 3-D figures where no 3-D backend loads) over the steps
   ``init``, ``preprocessing``, ``sensor``, ``source/make_forward`` and
   ``source/make_inverse``;
4. ``skf-ref bids WORK/bids/derivatives/mne-bids-pipeline`` twice: the second run must
   skip every estimate.

It prints the files each stage wrote and the run times, and saves them in
``WORK/summary.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
BIN = Path(sys.executable).parent
STEPS = "init,preprocessing,sensor,source/make_forward,source/make_inverse"
CONDITIONS = {"fixed/a": 1, "fixed/b": 2}


def prepare_subject(testing: Path, subjects_dir: Path) -> Path:
    """The FreeSurfer folder of ``sub-01`` with the BEM solution and source space."""
    import mne

    subject = subjects_dir / "sub-01"
    if subject.exists():
        shutil.rmtree(subject)
    shutil.copytree(testing / "subjects" / "sample", subject)
    bem = subject / "bem"
    model = mne.read_bem_surfaces(bem / "sample-1280-1280-1280-bem.fif", verbose=False)
    solution = mne.make_bem_solution(model, verbose=False)
    mne.write_bem_solution(bem / "sub-01-5120-5120-5120-bem-sol.fif", solution, overwrite=True)
    src = mne.setup_volume_source_space(
        "sub-01", pos=10.0, bem=solution, subjects_dir=subjects_dir, verbose=False
    )
    mne.write_source_spaces(bem / "sub-01-10-src.fif", src, overwrite=True, verbose=False)
    return subject


def prepare_bids(testing: Path, subjects_dir: Path, bids_root: Path) -> None:
    """The BIDS dataset: the recording with fixed-time events, and the T1 with landmarks."""
    import mne
    import numpy as np
    from mne_bids import BIDSPath, get_anat_landmarks, write_anat, write_raw_bids

    if bids_root.exists():
        shutil.rmtree(bids_root)
    raw = mne.io.read_raw_fif(testing / "SSS" / "sample_audvis_trunc_raw_sss.fif", verbose=False)
    sfreq = raw.info["sfreq"]
    times = 0.15 + 0.09 * np.arange(8)  # 0.15 ... 0.78 s of the 1 s
    samples = raw.first_samp + np.round(times * sfreq).astype(int)
    events = np.column_stack([samples, np.zeros(8, int), np.tile([1, 2], 4)])
    bids_path = BIDSPath(subject="01", task="audvis", datatype="meg", root=bids_root)
    write_raw_bids(
        raw,
        bids_path,
        events=events,
        event_id=CONDITIONS,
        overwrite=True,
        allow_preload=False,
        verbose=False,
    )
    t1 = subjects_dir / "sub-01" / "mri" / "T1.mgz"
    landmarks = get_anat_landmarks(
        t1,
        info=raw.info,
        trans=mne.read_trans(testing / "MEG" / "sample" / "sample_audvis_trunc-trans.fif"),
        fs_subject="sub-01",
        fs_subjects_dir=subjects_dir,
    )
    write_anat(
        t1,
        bids_path=BIDSPath(subject="01", root=bids_root),
        landmarks=landmarks,
        overwrite=True,
        verbose=False,
    )


def run(command: list[str], env: dict[str, str], log: Path) -> float:
    """Run a command, its output to ``log``; its time in seconds (raises if it fails)."""
    start = time.perf_counter()
    with log.open("w") as out:
        done = subprocess.run(command, env=env, stdout=out, stderr=subprocess.STDOUT)
    seconds = time.perf_counter() - start
    if done.returncode:
        tail = "\n".join(log.read_text().splitlines()[-30:])
        raise SystemExit(f"{' '.join(command)} failed ({done.returncode}); see {log}:\n{tail}")
    return seconds


def listing(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mne-testing-data", type=Path, required=True)
    parser.add_argument("--work", type=Path, required=True)
    args = parser.parse_args(argv)
    testing, work = args.mne_testing_data.resolve(), args.work.resolve()
    work.mkdir(parents=True, exist_ok=True)
    subjects_dir, bids_root = work / "subjects", work / "bids"
    summary: dict = {"seconds": {}}

    start = time.perf_counter()
    prepare_subject(testing, subjects_dir)
    summary["seconds"]["prepare_subject"] = time.perf_counter() - start
    start = time.perf_counter()
    prepare_bids(testing, subjects_dir, bids_root)
    summary["seconds"]["prepare_bids"] = time.perf_counter() - start

    env = dict(os.environ, SKF_BIDS_ROOT=str(bids_root), SKF_SUBJECTS_DIR=str(subjects_dir))
    env["PYTHONPATH"] = os.pathsep.join([str(HERE.parents[1]), env.get("PYTHONPATH", "")])
    # mne_bids_pipeline's own entry point, with the report's 3-D figures stubbed if no 3-D
    # backend loads (_pipeline.py)
    pipeline = [sys.executable, "-m", "validation.bids_pipeline._pipeline"]
    pipeline.append(f"--config={HERE / 'config.py'}")
    summary["seconds"]["pipeline"] = run(
        [*pipeline, f"--steps={STEPS}"], env, work / "pipeline.log"
    )
    deriv = bids_root / "derivatives" / "mne-bids-pipeline"
    folder = deriv / "sub-01" / "meg"
    summary["pipeline_wrote"] = listing(folder)

    skf = [str(BIN / "skf-ref"), "bids", str(deriv)]
    summary["seconds"]["skf_first"] = run(skf, env, work / "skf_first.log")
    after = listing(folder)
    summary["skf_wrote"] = sorted(set(after) - set(summary["pipeline_wrote"]))
    summary["skf_first_output"] = (work / "skf_first.log").read_text()
    summary["seconds"]["skf_second"] = run(skf, env, work / "skf_second.log")
    summary["skf_second_output"] = (work / "skf_second.log").read_text()
    summary["second_run_changed"] = sorted(set(listing(folder)) - set(after))

    import mne
    import mne_bids
    import mne_bids_pipeline

    import skf_ref

    summary["versions"] = {
        "mne": mne.__version__,
        "mne-bids": mne_bids.__version__,
        "mne-bids-pipeline": mne_bids_pipeline.__version__,
        "skf_ref": skf_ref.__version__,
        "python": sys.version.split()[0],
    }
    (work / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    print(json.dumps(summary, indent=1))
    return summary


if __name__ == "__main__":
    main()
