"""Channels are matched by name and type, and the reference covers every EEG channel used.

A channel the forward models as EEG that the data call a current source density, ``misc``
or ``ecog`` is not a potential the forward predicts: it is refused by name, on the one-call
route and by an operator alike. An average-reference projector that leaves out an EEG
channel in use gives data and lead field another reference: refused, naming the channels,
as MNE's ``apply_inverse`` refuses it. ``noise_std`` names every channel type in use.
"""

import warnings

import mne
import numpy as np
import pytest
from rounding import assert_same_to_rounding

from skf_ref import InputError, apply_skf, make_skf_operator


@pytest.fixture(scope="module")
def problem(mne_setup):
    epochs = mne_setup["make_epochs"](target=300, seed=4)
    cov = mne.compute_covariance(epochs, tmax=0, verbose=False)
    evoked = epochs.average()
    operator = make_skf_operator(evoked.info, mne_setup["forward"], cov, verbose=False)
    return mne_setup["forward"], evoked, cov, operator


def _retyped(evoked, kind):
    other = evoked.copy().del_proj()
    with warnings.catch_warnings():  # MNE's note that the unit changes from V
        warnings.filterwarnings("ignore", "The unit for channel", RuntimeWarning)
        other.set_channel_types(dict.fromkeys(other.ch_names, kind), verbose=False)
    return other


def _csd(evoked):
    referenced = evoked.copy().del_proj().set_eeg_reference("average", verbose=False)
    return mne.preprocessing.compute_current_source_density(referenced, verbose=False)


@pytest.mark.parametrize(
    "change, match",
    [
        (_csd, r"64 channels of type 'csd' that the forward models as 'eeg'.*current source"),
        (lambda e: _retyped(e, "misc"), r"64 channels of type 'misc' that the forward models"),
        (lambda e: _retyped(e, "ecog"), r"of type 'ecog' .* e\.g\. \['Fp1', 'AF7'"),
    ],
    ids=["csd", "misc", "ecog"],
)
def test_a_channel_of_another_type_is_refused_by_name(problem, change, match):
    forward, evoked, cov, operator = problem
    other = change(evoked)
    with pytest.raises(InputError, match=match):
        apply_skf(other, forward, cov)
    with pytest.raises(InputError, match=match):
        apply_skf(other, operator)


def _partial_projector(evoked, left_out):
    kept = [name for name in evoked.ch_names if name not in left_out]
    partial = evoked.copy().del_proj()
    average = mne.create_info(kept, evoked.info["sfreq"], "eeg")
    partial.add_proj(mne.proj.make_eeg_average_ref_proj(average, activate=False, verbose=False))
    return partial


def test_a_projector_that_leaves_out_a_channel_in_use_is_refused(problem):
    forward, evoked, cov, operator = problem
    partial = _partial_projector(evoked, ["Oz", "Cz"])
    match = r"evoked's average-reference projector leaves out 2 of the 64 EEG channels in use"
    with pytest.raises(InputError, match=match + r": \['Oz', 'Cz'\]"):
        apply_skf(partial, operator)
    with pytest.raises(InputError, match=r"projector leaves out 2 of the 64 .* mark those"):
        apply_skf(partial, forward, cov)
    # MNE refuses it too
    inverse = mne.minimum_norm.make_inverse_operator(evoked.info, forward, cov, verbose=False)
    with pytest.raises(ValueError, match="EEG average reference .* is mandatory"):
        with pytest.warns(RuntimeWarning, match="Incomplete EEG.* projector"):
            mne.minimum_norm.apply_inverse(partial, inverse, verbose=False)
    # the channels left out marked bad: the projector covers every channel used
    bad = partial.copy()
    bad.info["bads"] = ["Oz", "Cz"]
    stc = apply_skf(bad, forward, cov)
    assert np.isfinite(stc.data).all()


def test_noise_std_names_every_type_in_use(problem):
    forward, evoked, _, _ = problem
    with pytest.raises(
        InputError,
        match=r"noise_std must name every channel type in use, "
        r"\['eeg'\]: it lacks \['eeg'\]",
    ):
        apply_skf(evoked, forward, noise_std={"mag": 1e-14})
    with pytest.raises(InputError, match=r"noise_std's keys must be among .* got \['EEG'\]"):
        apply_skf(evoked, forward, noise_std={"EEG": 1e-6})
    one = apply_skf(evoked, forward, noise_std=1e-6)
    named = apply_skf(evoked, forward, noise_std={"eeg": 1e-6, "grad": 1e-11})  # grad unused
    assert_same_to_rounding(one.data, named.data)
