"""MNE-BIDS-pipeline configuration for the skf-ref bids check (``validation.bids_pipeline``).

The script (``python -m validation.bids_pipeline``) sets ``SKF_BIDS_ROOT`` and
``SKF_SUBJECTS_DIR`` to the BIDS dataset and the FreeSurfer folder it prepared under
``--work`` before it runs ``mne_bids_pipeline --config=config.py``.

One subject, MEG and EEG of MNE's truncated sample recording (1 s), two conditions made of
fixed-time events (the recording holds no stimulus), no filtering, no ICA/SSP, short
epochs, noise covariance from the baseline, and the inverse (dSPM) on a volume source space
with the sample subject's 3-layer BEM: the testing data has no cortical surfaces, so the
script makes the source space and the BEM solution and stores them under the names the
pipeline reads (its steps ``source/_01`` to ``_03`` are not run).
"""

import os

bids_root = os.environ["SKF_BIDS_ROOT"]
subjects_dir = os.environ["SKF_SUBJECTS_DIR"]
subjects = ["01"]
task = "audvis"
data_type = "meg"
ch_types = ["meg", "eeg"]
eeg_reference = "average"

use_maxwell_filter = False
find_flat_channels_meg = False
find_noisy_channels_meg = False
l_freq = None
h_freq = None
spatial_filter = None
reject = None

conditions = ["fixed/a", "fixed/b"]
epochs_tmin = -0.1
epochs_tmax = 0.15
baseline = (None, 0)
decode = False

run_source_estimation = True
use_template_mri = None
recreate_bem = False
spacing = 10  # a name only: the file holds a 10 mm volume grid the script made
loose = 1.0  # a volume source space's three free orientations
inverse_method = "dSPM"
noise_cov = (None, 0)

report_stc_n_time_points = 1
n_jobs = 1
on_error = "abort"
