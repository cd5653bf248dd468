"""What ``reconstruct`` says before it computes: the priors it needs, a transposed lead
field, a run that would take long; one check of the settings and one memory budget for
every route; how a result and a tuning show in a notebook."""

import warnings

import numpy as np
import pytest

from skf_ref import InputError, InputTypeError, reconstruct, tune
from skf_ref._utils import memory
from skf_ref.method import _reconstruct
from skf_ref.method._settings import Settings, check_settings


def _problem(m=6, n=10, T=5, seed=0):
    rng = np.random.default_rng(seed)
    return rng.standard_normal((m, n)), rng.standard_normal((m, T))


def test_the_priors_are_required_and_the_message_says_how_to_get_them():
    L, Y = _problem()
    with pytest.raises(InputTypeError, match=r"needs the priors theta0 and q .*, got no theta0"):
        reconstruct(L, Y, noise_std=1.0, q=0.1)
    with pytest.raises(TypeError, match=r"got no theta0 and no q: .*skf_ref.priors_from_snr\("):
        reconstruct(L, Y, noise_std=1.0)
    with pytest.raises(InputError, match=r"or chosen by the data, result = skf_ref.tune\("):
        reconstruct(L, Y, noise_std=1.0, theta0=1.0)


def test_a_transposed_lead_field_is_named_as_the_lead_field():
    L, Y = _problem()
    with pytest.raises(InputError, match=r"L must have shape \(n_channels, n_sources\) .* got L "
                       r"of shape \(10, 6\): L looks transposed \(give L.T\)"):  # fmt: skip
        reconstruct(L.T, Y, noise_std=1.0, theta0=1.0, q=0.1)
    with pytest.raises(InputError, match="L looks transposed"):
        tune(L.T, Y, noise_std=1.0)
    # a Y of another size is still Y's mistake
    with pytest.raises(InputError, match=r"Y must have shape \(6, n_times\), got \(7, 5\)"):
        reconstruct(L, np.ones((7, 5)), noise_std=1.0, theta0=1.0, q=0.1)


def test_the_estimated_time_of_a_long_dense_run():
    assert _reconstruct.slow_path_seconds(600, 64, 100) == pytest.approx(450.432)
    assert _reconstruct.slow_path_seconds(30, 8, 10) < 0.01


@pytest.mark.parametrize("method", ["dense", "filterpy"])
def test_a_long_run_warns_before_it_starts(method):
    # 3000 sources x 2000 steps: estimated at about 1e6 s; the memory budget stops it
    # before any work, after the warning
    L, Y = np.eye(4, 3000) + 1.0, np.ones((4, 2000))
    expected = rf"path='{method}' on 3000 sources x 2000 steps is estimated to take 1.08e\+06 s"
    with pytest.warns(UserWarning, match=expected + ".*path='spectral' computes this"):
        with pytest.raises(MemoryError, match="stores 2000 covariances"):
            reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1, path=method, memory_limit=1e6)


def test_a_short_run_does_not_warn_unless_the_machine_is_slow(monkeypatch):
    L, Y = _problem()
    kwargs = dict(noise_std=1.0, theta0=1.0, q=0.1, path="dense")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        reconstruct(L, Y, **kwargs)
        reconstruct(L, Y, **{**kwargs, "path": "spectral"})  # never estimated
    monkeypatch.setattr(_reconstruct, "_FLOPS_PER_SECOND", 1.0)
    with pytest.warns(UserWarning, match=r"10 sources x 5 steps is estimated to take 1.24e\+05 s"):
        reconstruct(L, Y, **kwargs)
    matrix = dict(kwargs, q=np.diag(np.linspace(0.1, 0.2, 10)))  # no spectral path to offer
    with pytest.warns(UserWarning, match=r"a second\)$"):
        reconstruct(L, Y, **matrix)


def test_the_settings_are_checked_in_one_place():
    assert check_settings() == Settings(exponent=0.5, smoother=None, path="auto")
    assert check_settings(1, "none", "dense") == Settings(1.0, None, "dense")
    L, Y = _problem()
    for kwargs, match in [
        (dict(exponent=-1), "exponent must be >= 0, got -1.0"),
        (dict(exponent="1"), r"exponent must be a real number, got '1' \(str\)"),
        (dict(smoother="rts"), r"smoother must be one of \[None, 'rts-standardized', 'rts-st"),
        (dict(path="kalman"), r"path must be one of \['auto', 'filterpy', 'dense', 'spe"),
    ]:
        with pytest.raises(InputError, match=match):
            check_settings(**kwargs)
        with pytest.raises(InputError, match=match):
            reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1, **kwargs)


def test_one_memory_budget(monkeypatch):
    assert memory.memory_budget(123.0) == 123.0
    monkeypatch.setattr(memory, "available_memory", lambda: 2**30)
    assert memory.memory_budget() == 2**29
    with pytest.raises(MemoryError, match=r"over the memory budget of 0.5 GiB \(half the memory"):
        memory.require(2**30, "a test")
    L, Y = _problem(n=5000, T=3)
    with pytest.warns(UserWarning, match="estimated to take"):  # and then refused
        with pytest.raises(MemoryError, match=r"'dense' stores 3 covariances .* budget of 0.5"):
            reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1, path="dense")


def test_a_reconstruction_and_a_tuning_show_as_tables_in_a_notebook():
    L, Y = _problem(T=30)
    rec = reconstruct(L, Y, noise_std=1.0, theta0=1.0, q=0.1, smoother="rts-state")
    table = rec._repr_html_()
    assert table.startswith("<table><caption>Reconstruction</caption>")
    assert "<tr><th>Sources x steps</th><td>10 x 30</td></tr>" in table
    assert "<tr><th>smoother</th><td>rts-state</td></tr>" in table
    assert "<tr><th>In memory</th><td>none yet</td></tr>" in table  # nothing computed
    assert not rec.computed("z")
    with pytest.warns(UserWarning, match="lies on the lower bound"):  # shown in the table
        result = tune(L, Y, noise_std=1.0, grid=3, pm_snr_db=(-10.0, 10.0), ep_snr_db=0.0)
    table = result._repr_html_()
    assert table.startswith("<table><caption>TuneResult</caption>")
    assert f"<tr><th>PM-SNR (dB)</th><td>{result.pm_snr_db:.2f}</td></tr>" in table
    assert "<tr><th>Grid cells</th><td>3</td></tr>" in table
    assert "<tr><th>On a bound</th><td>pm_snr_db: lower</td></tr>" in table
    tuned = rec.with_tuning(result)._repr_html_()
    assert "&lt;TuneResult | PM-SNR" in tuned  # escaped
