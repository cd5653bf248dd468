"""Every method and setting the real SEPs go through: the one list to extend.

A row is ``(name, family, parameters)``; :mod:`validation.real_sep.methods` runs a family with
its parameters. When the SKF gains an option, add its settings to :data:`SKF_SETTINGS` and
rerun ``python -m validation.real_sep``; nothing else changes.
"""

import skf_ref

#: The SKF's settings: exponent, smoother and standardization. "paper" and "recommended"
#: standardize each column on its own, as when the criteria were written; "position" (each
#: position's columns together, as apply_skf does by default with EEG since 0.4.0; with
#: its PM 0 / EP 0 dB priors, the package's default) and the same with the smoother
#: standardized by its own variance were added after the first run; "column, smoothed
#: weights" with the AR(1) priors (issue 43), to hold every candidate of
#: :data:`CANDIDATES`. "recommended" is the candidate "column" without a smoother.
SKF_SETTINGS = {
    "paper": dict(skf_ref.PAPER_SETTING, standardize="column"),
    "recommended": dict(skf_ref.RECOMMENDED_SETTING, standardize="column"),
    "position": dict(skf_ref.RECOMMENDED_SETTING, standardize="position"),
    "position, smoothed weights": dict(
        exponent=0.5, smoother="rts-smoothed-weights", standardize="position"
    ),
    "column, smoothed weights": dict(
        exponent=0.5, smoother="rts-smoothed-weights", standardize="column"
    ),
}
#: The SKF's priors: chosen by the data (marginal likelihood), and two fixed pairs.
SKF_PRIORS = {
    "auto": dict(pm_snr_db="auto", ep_snr_db="auto"),
    "PM0/EP20": dict(pm_snr_db=0.0, ep_snr_db=20.0),
    "PM0/EP0": dict(pm_snr_db=0.0, ep_snr_db=0.0),
}
#: The stationary AR(1) evolution prior (skf_ref 0.4.0, :func:`skf_ref.ar1_priors`) in place
#: of the random walk, at PM-SNR 0 dB: three time constants, and the time constant chosen by
#: the marginal likelihood (1 ... 1000 ms) with the PM-SNR kept at 0 dB, as
#: ``apply_skf(..., time_constant_ms="auto")`` does by default.
AR1_PRIORS = {
    "PM0/AR10ms": dict(pm_snr_db=0.0, time_constant_ms=10.0),
    "PM0/AR30ms": dict(pm_snr_db=0.0, time_constant_ms=30.0),
    "PM0/AR100ms": dict(pm_snr_db=0.0, time_constant_ms=100.0),
    "PM0/ARauto": dict(pm_snr_db=0.0, time_constant_ms="auto"),
}
#: The candidates an evidence study is choosing the package's default among (exponent 0.5;
#: "position" or "column"; no smoother or "rts-smoothed-weights"), each with the random
#: walk at EP 0 dB (the default) and 20 dB (the paper's), both in :data:`SKF_PRIORS`, and
#: with :data:`AR1_PRIORS`. "column, smoothed weights" also gets the walk's "auto" priors.
CANDIDATES = (
    "recommended",
    "position",
    "position, smoothed weights",
    "column, smoothed weights",
)
#: Which priors count as chosen by the data: both SNRs of the walk's "auto", and the AR(1)'s
#: time constant (its PM-SNR is fixed).
BY_DATA = ("auto", "PM0/ARauto")
#: MNE's minimum-norm methods, each at lambda2 by the discrepancy principle and at 1/9.
MINIMUM_NORM = ("MNE", "dSPM", "sLORETA", "eLORETA")
LAMBDA2 = {"discrepancy": "discrepancy", "1/9": 1.0 / 9.0}
#: MxNE's alpha: by SURE (chosen by the data), and 50 % of alpha_max.
MXNE_ALPHA = {"SURE": "sure", "50%": 50.0}
#: LCMV: MNE's regularization default.
LCMV_REG = 0.05


def settings():
    """Every setting, in the report's order.

    Returns
    -------
    list of (str, str, dict)
        ``(name, family, parameters)``; family one of ``"skf"``, ``"minimum_norm"``,
        ``"lcmv"``, ``"mxne"``; ``parameters["priors"]`` says how the prior or
        regularization was set (``"data"`` or ``"fixed"``).
    """
    rows = []
    for setting, skf in SKF_SETTINGS.items():
        every = {**SKF_PRIORS, **(AR1_PRIORS if setting in CANDIDATES else {})}
        for label, priors in every.items():
            kind = "data" if label in BY_DATA else "fixed"
            rows.append((f"SKF {setting}, {label}", "skf", dict(**skf, **priors, priors=kind)))
    for method in MINIMUM_NORM:
        for label, lambda2 in LAMBDA2.items():
            kind = "data" if label == "discrepancy" else "fixed"
            rows.append(
                (
                    f"{method}, lambda2 {label}",
                    "minimum_norm",
                    dict(method=method, lambda2=lambda2, priors=kind),
                )
            )
    rows.append(("LCMV", "lcmv", dict(reg=LCMV_REG, priors="data")))
    for label, alpha in MXNE_ALPHA.items():
        kind = "data" if alpha == "sure" else "fixed"
        rows.append((f"MxNE, alpha {label}", "mxne", dict(alpha=alpha, priors=kind)))
    return rows
