"""Each public call checks its settings once, at its door (issue 45).

The check functions are spied on wherever the package has bound them; each public route
that runs the SKF must call ``check_settings`` exactly once, and ``check_gaps`` once per
data set (it depends on the data's missing steps), whatever path it takes.
"""

import importlib
import pkgutil
import sys

import numpy as np
import pytest

import skf_ref
import skf_ref.io
import skf_ref.method
from skf_ref.method import _settings

# every module of the routes imported now, so that none binds a spy of one test for good
for _package in (skf_ref.method, skf_ref.io):
    for _info in pkgutil.walk_packages(_package.__path__, f"{_package.__name__}."):
        importlib.import_module(_info.name)


@pytest.fixture
def count(monkeypatch):
    """The calls of ``check_settings`` and ``check_gaps`` since the fixture began, by name."""
    calls = {"check_settings": 0, "check_gaps": 0}
    for name in calls:
        original = getattr(_settings, name)

        def spy(*args, _name=name, _original=original, **kwargs):
            calls[_name] += 1
            return _original(*args, **kwargs)

        bound = [
            module
            for module_name, module in list(sys.modules.items())
            if module_name.startswith("skf_ref") and getattr(module, name, None) is original
        ]
        assert _settings in bound and len(bound) > 1
        for module in bound:
            monkeypatch.setattr(module, name, spy)
    return calls


def _problem():
    rng = np.random.default_rng(0)
    L = rng.standard_normal((6, 9))
    Y = rng.standard_normal((6, 5))
    Y[:, 2] = np.nan  # a missing step
    return L, Y


@pytest.mark.parametrize("path", ["auto", "spectral", "dense", "filterpy"])
@pytest.mark.parametrize("standardize", ["column", "position"])
def test_reconstruct_checks_once(count, path, standardize):
    L, Y = _problem()
    skf_ref.reconstruct(
        L,
        Y,
        noise_std=1.0,
        theta0=1.0,
        q=0.1,
        smoother="rts-state",
        path=path,
        standardize=standardize,
        n_orient=3,
    )
    assert count == {"check_settings": 1, "check_gaps": 1}


@pytest.fixture(scope="module")
def mne_problem(mne_setup):
    import mne

    epochs = mne_setup["make_epochs"](target=10, seed=0, n_epochs=4)
    cov = mne.make_ad_hoc_cov(epochs.info, verbose=False)
    # a coarse grid, that the dense and filterpy paths run in a moment
    src = mne.setup_volume_source_space(sphere=mne_setup["sphere"], pos=50.0, verbose=False)
    forward = mne.make_forward_solution(
        epochs.info, None, src, mne_setup["sphere"], eeg=True, meg=False, verbose=False
    )
    operator = skf_ref.make_skf_operator(epochs.info, forward, cov)
    raw = mne.io.RawArray(np.hstack(epochs.get_data()), epochs.info, verbose=False)
    return forward, cov, epochs, raw, operator


def test_make_skf_operator_takes_no_settings_and_checks_none(count, mne_problem):
    # the operator holds the priors; the settings are given where it is applied
    forward, cov, epochs, _, _ = mne_problem
    skf_ref.make_skf_operator(epochs.info, forward, cov)
    assert count == {"check_settings": 0, "check_gaps": 0}


@pytest.mark.parametrize("path", ["auto", "dense"])
def test_the_operator_checks_once(count, mne_problem, path):
    *_, epochs, _, operator = mne_problem
    data = operator.select(epochs.info, epochs.get_data()[0])
    operator.reconstruct(data, path=path, smoother="rts-state")
    assert count == {"check_settings": 1, "check_gaps": 1}


@pytest.mark.parametrize("path", ["auto", "filterpy"])
def test_apply_skf_checks_once_with_an_operator_or_without(count, mne_problem, path):
    forward, cov, epochs, _, operator = mne_problem
    evoked = epochs.average()
    skf_ref.apply_skf(evoked, operator, path=path)
    assert count == {"check_settings": 1, "check_gaps": 1}
    skf_ref.apply_skf(evoked, forward, cov, path=path)  # the operator made inside
    assert count == {"check_settings": 2, "check_gaps": 2}


@pytest.mark.parametrize("return_generator", [False, True])
def test_apply_skf_epochs_checks_once_for_all_epochs(count, mne_problem, return_generator):
    *_, epochs, _, operator = mne_problem
    estimates = skf_ref.apply_skf_epochs(
        epochs, operator, path="dense", smoother=None, return_generator=return_generator
    )
    assert count["check_settings"] == 1  # before any epoch, even for a generator
    assert len(list(estimates)) == len(epochs) == 4
    assert count == {"check_settings": 1, "check_gaps": 4}  # the gaps: each epoch's own


def test_apply_skf_raw_checks_once(count, mne_problem):
    *_, raw, operator = mne_problem
    skf_ref.apply_skf_raw(raw, operator)
    assert count == {"check_settings": 1, "check_gaps": 1}


def test_a_setting_is_refused_before_the_first_epoch(mne_problem):
    *_, epochs, _, operator = mne_problem
    with pytest.raises(skf_ref.InputError, match="exponent"):
        skf_ref.apply_skf_epochs(epochs, operator, exponent=-1.0, return_generator=True)
