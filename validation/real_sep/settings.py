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
#: standardized by its own variance were added after the first run.
SKF_SETTINGS = {
    "paper": dict(skf_ref.PAPER_SETTING, standardize="column"),
    "recommended": dict(skf_ref.RECOMMENDED_SETTING, standardize="column"),
    "position": dict(skf_ref.RECOMMENDED_SETTING, standardize="position"),
    "position, smoothed weights": dict(
        exponent=0.5, smoother="rts-smoothed-weights", standardize="position"
    ),
}
#: The SKF's priors: chosen by the data (marginal likelihood), and two fixed pairs.
SKF_PRIORS = {
    "auto": dict(pm_snr_db="auto", ep_snr_db="auto"),
    "PM0/EP20": dict(pm_snr_db=0.0, ep_snr_db=20.0),
    "PM0/EP0": dict(pm_snr_db=0.0, ep_snr_db=0.0),
}
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
        for label, priors in SKF_PRIORS.items():
            kind = "data" if label == "auto" else "fixed"
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
