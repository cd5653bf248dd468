"""Prior parameters from SNRs (docs/model.md §4, the paper's eqs. 8-10): worked numbers, checks."""

import numpy as np
import pytest

from skf_ref import evolution_variance, lead_field_amplitude, prior_variance, priors_from_snr

# The formulas are a few multiplications and powers of ten: only rounding separates the
# package's value from the hand-worked one.
RTOL = 1e-12


def test_prior_variance_worked_numbers():
    # 10**(0/10) * 2**2 * 3**2 / 9 = 4
    assert prior_variance(0.0, noise_std=2.0, amplitude=3.0, n_sources=9) == pytest.approx(
        4.0, rel=RTOL
    )
    # 20 dB multiplies theta0 by 100, -10 dB divides it by 10
    assert prior_variance(20.0, 2.0, 3.0, 9) == pytest.approx(400.0, rel=RTOL)
    assert prior_variance(-10.0, 2.0, 3.0, 9) == pytest.approx(0.4, rel=RTOL)
    # 10**(3/10) * 0.5**2 * 4**2 / 2
    assert prior_variance(3.0, 0.5, 4.0, 2) == pytest.approx(10**0.3 * 2.0, rel=RTOL)


def test_evolution_variance_worked_numbers():
    # 10**(20/10) * 4 / 40 = 10
    assert evolution_variance(20.0, theta0=4.0, n_steps=40) == pytest.approx(10.0, rel=RTOL)
    assert evolution_variance(0.0, theta0=4.0, n_steps=40) == pytest.approx(0.1, rel=RTOL)
    assert evolution_variance(10.0, theta0=2.5, n_steps=1) == pytest.approx(25.0, rel=RTOL)


class TestLeadFieldAmplitude:
    # Columns of norm 1 and 4, three channels.
    L = np.array([[1.0, 0.0], [0.0, 4.0], [0.0, 0.0]])

    def test_gain(self):
        # sqrt(n_channels) / rms_j ||L_j|| = sqrt(3) / sqrt((1 + 16) / 2)
        expected = np.sqrt(3.0) / np.sqrt(17.0 / 2.0)
        assert lead_field_amplitude(self.L) == pytest.approx(expected, rel=RTOL)
        assert lead_field_amplitude(self.L, "gain") == pytest.approx(expected, rel=RTOL)

    def test_toolbox(self):
        # mean_j ||L_j||**(-1/2) = (1 + 1/2) / 2
        assert lead_field_amplitude(self.L, "toolbox") == pytest.approx(0.75, rel=RTOL)

    def test_gain_is_unit_free_and_toolbox_is_not(self):
        c = 1e3
        assert lead_field_amplitude(c * self.L) == pytest.approx(
            lead_field_amplitude(self.L) / c, rel=RTOL
        )
        assert lead_field_amplitude(c * self.L, "toolbox") == pytest.approx(
            lead_field_amplitude(self.L, "toolbox") / np.sqrt(c), rel=RTOL
        )


@pytest.mark.parametrize("pm_snr_db", [-10.0, 0.0, 13.0, 30.0])
def test_gain_convention_makes_pm_the_prior_predicted_snr(pm_snr_db):
    rng = np.random.default_rng(11)
    L = 50.0 * rng.standard_normal((16, 45))
    sigma = 3e-6
    theta0, q = priors_from_snr(L, sigma, pm_snr_db, ep_snr_db=20.0, n_steps=41)
    # E||L x||^2 = theta0 trace(L^T L) for x ~ N(0, theta0 I); E||r||^2 = n_channels sigma^2
    snr = theta0 * np.sum(L**2) / (L.shape[0] * sigma**2)
    assert snr == pytest.approx(10 ** (pm_snr_db / 10), rel=RTOL)
    assert q == pytest.approx(100.0 * theta0 / 41, rel=RTOL)


class TestToolboxClamp:
    L = np.array([[1.0, 0.0], [0.0, 4.0], [0.0, 0.0]])
    noise_std = 0.1  # relative to max|Y|: SNR = 20 dB

    def theta0(self, pm_snr_db):
        return prior_variance(pm_snr_db, self.noise_std, 0.75, 2)

    def test_no_clamp_below_snr_minus_1db(self):
        theta0, q = priors_from_snr(self.L, self.noise_std, 10.0, 0.0, 5, convention="toolbox")
        assert theta0 == pytest.approx(self.theta0(10.0), rel=RTOL)
        assert q == pytest.approx(theta0 / 5, rel=RTOL)

    @pytest.mark.parametrize("pm_snr_db", [19.5, 20.0, 40.0])
    def test_clamped_to_snr_minus_1db(self, pm_snr_db):
        theta0, _ = priors_from_snr(self.L, self.noise_std, pm_snr_db, 0.0, 5, "toolbox")
        assert theta0 == pytest.approx(self.theta0(19.0), rel=RTOL)

    def test_gain_convention_does_not_clamp(self):
        theta0, _ = priors_from_snr(self.L, self.noise_std, 40.0, 0.0, 5)
        expected = prior_variance(40.0, self.noise_std, lead_field_amplitude(self.L), 2)
        assert theta0 == pytest.approx(expected, rel=RTOL)


L_OK = np.array([[1.0, 0.0], [0.0, 4.0], [0.0, 0.0]])


@pytest.mark.parametrize(
    "call, error, match",
    [
        (lambda: prior_variance(0.0, 0.0, 1.0, 3), ValueError, "noise_std must be > 0"),
        (lambda: prior_variance(0.0, -1.0, 1.0, 3), ValueError, "noise_std must be > 0"),
        (lambda: prior_variance(0.0, 1.0, 0.0, 3), ValueError, "amplitude must be > 0"),
        (lambda: prior_variance(0.0, 1.0, 1.0, 0), ValueError, "n_sources must be >= 1"),
        (lambda: prior_variance(0.0, 1.0, 1.0, 2.5), TypeError, "n_sources must be an integer"),
        (lambda: prior_variance("0", 1.0, 1.0, 3), TypeError, "pm_snr_db must be a real"),
        (lambda: prior_variance(np.nan, 1.0, 1.0, 3), ValueError, "pm_snr_db must be finite"),
        (lambda: evolution_variance(0.0, 1.0, 0), ValueError, "n_steps must be >= 1"),
        (lambda: evolution_variance(0.0, 0.0, 5), ValueError, "theta0 must be > 0"),
        (lambda: evolution_variance(None, 1.0, 5), TypeError, "ep_snr_db must be a real"),
        (lambda: lead_field_amplitude(L_OK, "unit"), ValueError, "convention must be one of"),
        (lambda: lead_field_amplitude(L_OK[:, 0]), ValueError, r"L must have shape"),
        (
            lambda: lead_field_amplitude(np.zeros((3, 2))),
            ValueError,
            "L has zero sensitivity.*column 0",
        ),
        (lambda: priors_from_snr(L_OK, 0.0, 0.0, 0.0, 5), ValueError, "noise_std must be > 0"),
        (lambda: priors_from_snr(L_OK, -0.1, 0.0, 0.0, 5), ValueError, "noise_std must be > 0"),
        (
            lambda: priors_from_snr(L_OK, 0.1, 0.0, 0.0, 5, convention="units"),
            ValueError,
            r"convention must be one of \['gain', 'toolbox'\], got 'units'",
        ),
        (lambda: priors_from_snr(L_OK, 0.1, 0.0, 0.0, 0), ValueError, "n_steps must be >= 1"),
        (lambda: priors_from_snr(L_OK, 0.1, 0.0, "20", 5), TypeError, "ep_snr_db must be a real"),
        (lambda: priors_from_snr(L_OK, 0.1, "auto", 0.0, 5), ValueError, "are skf_ref.tune's"),
    ],
)
def test_invalid_inputs(call, error, match):
    with pytest.raises(error, match=match):
        call()


# --- the stationary AR(1) prior (docs/model.md §4, beyond the paper) ----------------------


def test_ar1_priors_worked_numbers():
    from skf_ref import ar1_priors

    rng = np.random.default_rng(4)
    L = rng.standard_normal((16, 40))
    for convention in ("gain", "toolbox"):
        theta0, q, rho = ar1_priors(L, 0.2, 3.0, 25.0, 400.0, convention=convention)
        # theta0 is priors_from_snr's, whatever the EP-SNR and K it would take
        assert theta0 == priors_from_snr(L, 0.2, 3.0, 0.0, 1, convention)[0]
        # dt = 2.5 ms, tau = 25 ms: rho = exp(-0.1), q = (1 - rho^2) theta0
        assert rho == pytest.approx(np.exp(-0.1), rel=RTOL)
        assert q == pytest.approx((1 - np.exp(-0.2)) * theta0, rel=RTOL)
        # stationary: Var x_t = rho^2 Var x_{t-1} + q = theta0 at every step
        assert rho**2 * theta0 + q == pytest.approx(theta0, rel=1e-15)
    # the memory is in milliseconds: doubling the sampling rate squares rho's root
    _, _, rho_fast = ar1_priors(L, 0.2, 3.0, 25.0, 800.0)
    assert rho_fast**2 == pytest.approx(np.exp(-0.1), rel=RTOL)


def test_ar1_priors_long_time_constant_keeps_q_exact():
    # 1 - rho^2 by expm1: at tau = 1e6 samples q keeps every digit (1 - rho^2 would lose ten)
    from skf_ref import ar1_priors

    L = np.random.default_rng(5).standard_normal((4, 6))
    theta0, q, rho = ar1_priors(L, 1.0, 0.0, time_constant_ms=1e6, sfreq=1000.0)
    assert q / theta0 == pytest.approx(2e-6, rel=1e-6)
    assert q / theta0 == pytest.approx(-np.expm1(-2e-6), rel=1e-15)


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (dict(time_constant_ms=0.0), ValueError, "time_constant_ms must be > 0, got 0.0"),
        (dict(time_constant_ms=-5.0), ValueError, "time_constant_ms must be > 0, got -5.0"),
        (dict(time_constant_ms=np.inf), ValueError, "time_constant_ms must be finite"),
        (dict(time_constant_ms="20"), TypeError, "time_constant_ms must be a real number"),
        (dict(time_constant_ms="auto"), ValueError, "time_constant_ms='auto'.*skf_ref.tune's"),
        (dict(sfreq=0.0), ValueError, "sfreq must be > 0, got 0.0"),
        (dict(sfreq=None), TypeError, "sfreq must be a real number, got None"),
        (dict(pm_snr_db="auto"), ValueError, "ar1_priors takes numbers, got pm_snr_db='auto'"),
        (dict(noise_std=0.0), ValueError, "noise_std must be > 0"),
        (dict(convention="units"), ValueError, "convention must be one of"),
    ],
)
def test_ar1_priors_invalid_inputs(kwargs, error, match):
    from skf_ref import ar1_priors

    given = dict(L=L_OK, noise_std=0.1, pm_snr_db=0.0, time_constant_ms=20.0, sfreq=500.0)
    with pytest.raises(error, match=match):
        ar1_priors(**{**given, **kwargs})
