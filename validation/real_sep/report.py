"""REAL.md: the criteria first, then the results against them, then what cannot be known."""

import numpy as np

from . import criteria

CHECKS = ("N20_left", "N20_central", "N20_cortical", "P14_deep", "P16_deep")
TITLES = {
    "A0206": "A0206: its own FEM head model (73 channels, 5046 fixed sources)",
    "sep256": "The 256-channel recording: a sphere fitted to the cap (10 mm grid, free)",
    "sep256-head": "The 256-channel recording without its neck rows (221 channels, the same "
    "sphere)",
}
#: The candidates' table: the settings' names (settings.CANDIDATES) in the study's words, and
#: the dynamics in the order the columns show them.
CANDIDATE_NAMES = {
    "recommended": "column",
    "column, smoothed weights": "column, smoothed weights",
    "position": "position",
    "position, smoothed weights": "position, smoothed weights",
}
DYNAMICS = {
    "PM0/EP0": "walk EP 0 dB",
    "PM0/EP20": "walk EP 20 dB",
    "PM0/AR10ms": "AR(1) 10 ms",
    "PM0/AR30ms": "AR(1) 30 ms",
    "PM0/AR100ms": "AR(1) 100 ms",
    "PM0/ARauto": "AR(1) auto",
}
RECOMMENDED, PAPER = "SKF recommended", "SKF paper"


def criteria_and_unknowns():
    criteria_text, unknowns = criteria.CRITERIA.split("### What cannot be known here")
    return criteria_text.strip(), "### What cannot be known here" + unknowns.rstrip()


def _marks(row):
    return " ".join("✓" if row[f"check_{name}"] else "✗" for name in CHECKS)


def results_table(rows):
    """The markdown table of one recording's rows."""
    axis = "N20_axis" in rows and rows["N20_axis"].notna().any()
    head = (
        "| setting | chosen | N20 maximum x, y, z (mm) | side | to the region / p* (mm) | "
        "depth (mm) |"
        + (" axis (° to u) |" if axis else "")
        + " P14 depth (mm), deep share | P16 depth (mm) | checks | met | s |"
    )
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for _, r in rows.iterrows():
        cells = [
            r["setting"],
            r["note"],
            f"{r['N20_x_mm']:.0f}, {r['N20_y_mm']:.0f}, {r['N20_z_mm']:.0f}",
            "left" if r["N20_left"] else "right",
            f"{r['N20_to_central_mm']:.0f} / {r['N20_to_p_star_mm']:.0f}",
            f"{r['N20_depth_mm']:.0f}",
        ]
        if axis:
            cells.append(f"{r['N20_axis']} ({r['N20_angle_to_radial_deg']:.0f})")
        cells += [
            f"{r['P14_depth_mm']:.0f}, {r['P14_deep_share']:.2f}",
            f"{r['P16_depth_mm']:.0f}",
            _marks(r),
            f"{r['checks_met']}/5",
            f"{r['seconds']:.1f}",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def candidates_table(rows):
    """The SKF candidates at a glance: checks met and the N20's distance to the region.

    One line per candidate (exponent 0.5; standardization, smoother), one column per
    dynamics (PM-SNR 0 dB); a cell ``met/5, mm``, in bold where the three N20 checks are
    met (the N20 in the left central region, not deep).
    """
    head = "| candidate (exponent 0.5) | " + " | ".join(DYNAMICS.values()) + " |"
    lines = [head, "|" + "---|" * (len(DYNAMICS) + 1)]
    for setting, label in CANDIDATE_NAMES.items():
        cells = []
        for priors in DYNAMICS:
            found = rows[rows["setting"] == f"SKF {setting}, {priors}"]
            if not len(found):
                cells.append("")
                continue
            cells.append(_cell(found.iloc[0]))
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _cell(r):
    cell = f"{r['checks_met']}/5, {r['N20_to_central_mm']:.0f} mm"
    n20 = r["check_N20_left"] and r["check_N20_central"] and r["check_N20_cortical"]
    return f"**{cell}**" if n20 else cell


def variants_table(rows, variants, dropped):
    """The rule's rows beside its neighbours': one line per setting run on all of them.

    ``rows``: the rule's recording's rows; ``variants``: :func:`run.neck_variants`'s table;
    ``dropped``: the number of rows the rule drops.
    """
    labels = list(dict.fromkeys(variants["recording"]))
    sizes = variants.groupby("recording", sort=False)["rows"].first()
    head = (
        f"| setting | the rule ({dropped} rows) | "
        + " | ".join(f"{label} ({sizes[label]} rows)" for label in labels)
        + " |"
    )
    lines = [head, "|" + "---|" * (len(labels) + 2)]
    for setting in dict.fromkeys(variants["setting"]):
        rule = rows[rows["setting"] == setting]
        cells = [_cell(rule.iloc[0]) if len(rule) else ""]
        for label in labels:
            found = variants[(variants["recording"] == label) & (variants["setting"] == setting)]
            cells.append(_cell(found.iloc[0]) if len(found) else "")
        lines.append(f"| {setting.removeprefix('SKF ')} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _best(rows):
    order = rows.sort_values(["checks_met", "N20_to_central_mm"], ascending=[False, True])
    return order.iloc[0]


def _versus(a, b):
    """Contrast words: a against b, by checks met, then the N20's distance to the region."""
    key_a = (a["checks_met"], -a["N20_to_central_mm"])
    key_b = (b["checks_met"], -b["N20_to_central_mm"])
    if np.allclose(key_a, key_b, atol=0.5):
        return "as good as"
    return "better than" if key_a > key_b else "worse than"


def _brief(row):
    return f"{row['checks_met']}/5, N20 {row['N20_to_central_mm']:.0f} mm from the region"


def contrasts(rows):
    """The two contrasts named before the numbers, for one recording, as sentences."""
    lines = []
    for priors in ("auto", "PM0/EP20", "PM0/EP0"):
        rec = rows[rows["setting"] == f"{RECOMMENDED}, {priors}"]
        pap = rows[rows["setting"] == f"{PAPER}, {priors}"]
        if len(rec) and len(pap):
            r, p = rec.iloc[0], pap.iloc[0]
            lines.append(
                f"- (a) priors {priors}: the recommended setting ({_brief(r)}) is "
                f"{_versus(r, p)} the paper's ({_brief(p)})."
            )
    skf = rows[rows["setting"] == f"{RECOMMENDED}, auto"]
    mne = rows[(rows["family"] == "minimum_norm") & (rows["priors"] == "data")]
    if len(skf) and len(mne):
        s, m = skf.iloc[0], _best(mne)
        lines.append(
            f"- (b) the recommended SKF with priors chosen by the data ({_brief(s)}) is "
            f"{_versus(s, m)} the best of MNE's minimum-norm methods with lambda2 by the "
            f"discrepancy principle, {m['setting']} ({_brief(m)})."
        )
    return "\n".join(lines)


def summary(rows):
    """Which settings met which checks, in words."""

    def names(mask):
        chosen = rows[mask]["setting"].tolist()
        return "; ".join(chosen) if chosen else "none"

    n20 = rows["check_N20_left"] & rows["check_N20_central"] & rows["check_N20_cortical"]
    deep = rows["check_P14_deep"] & rows["check_P16_deep"]
    return "\n".join(
        [
            f"- All three N20 checks: {names(n20)}.",
            f"- N20 in the left hemisphere only: {names(rows['check_N20_left'] & ~n20)}.",
            f"- Both deep checks (P14 and P16): {names(deep)}.",
            f"- One of them: {names(rows['check_P14_deep'] ^ rows['check_P16_deep'])}.",
        ]
    )


def _best_named(rows):
    """The best row, and the names of every setting tied with it."""
    best = _best(rows)
    tied = rows[[_versus(r, best) == "as good as" for _, r in rows.iterrows()]]
    return best, "; ".join(tied["setting"])


def verdict(table):
    """The SKF's best against MNE's best on each recording, and the sentence it leads to."""
    lines, outcomes = [], []
    for name, rows in table.groupby("recording", sort=False):
        for label, subset in (
            ("every prior", rows),
            ("priors chosen by the data", rows[rows["priors"] == "data"]),
        ):
            skf, skf_names = _best_named(subset[subset["family"] == "skf"])
            mne, mne_names = _best_named(subset[subset["family"] != "skf"])
            outcomes.append(_versus(skf, mne))
            lines.append(
                f"- {name}, {label}: the SKF's best ({_brief(skf)}: {skf_names}) is "
                f"{_versus(skf, mne)} MNE's best ({_brief(mne)}: {mne_names})."
            )
    if all(outcome != "better than" for outcome in outcomes):
        lines.append(
            "\n**On these recordings the SKF did no better than MNE-Python's methods**, at "
            "any of its settings and with either kind of prior."
        )
    elif all(outcome != "worse than" for outcome in outcomes):
        lines.append("\n**On these recordings the SKF did at least as well as MNE's methods.**")
    else:
        lines.append(
            "\n**On these recordings the SKF did better in some comparisons, worse in others.**"
        )
    return "\n".join(lines)


def _groups(rows):
    """The rows in the groups the report speaks of: the SKF's candidates, its other
    settings, the minimum-norm methods, LCMV and MxNE."""
    candidates = {f"SKF {s}, {p}" for s in CANDIDATE_NAMES for p in DYNAMICS}
    is_candidate = rows["setting"].isin(candidates)
    skf = rows["family"] == "skf"
    return {
        "the SKF's candidates": rows[skf & is_candidate],
        "the SKF's other settings (the paper's, priors auto)": rows[skf & ~is_candidate],
        "MNE's minimum-norm methods": rows[rows["family"] == "minimum_norm"],
        "LCMV and MxNE": rows[rows["family"].isin(("lcmv", "mxne"))],
    }


def where_they_land(rows, recording):
    """Where each group puts its N20 maximum on one recording, in words (generated)."""
    lines = []
    for group, found in _groups(rows).items():
        if not len(found):
            continue
        n = len(found)
        n20 = found["check_N20_left"] & found["check_N20_central"] & found["check_N20_cortical"]
        below = found["N20_z_mm"] < recording.centre[2] * 1e3
        distance = found["N20_to_central_mm"]
        named = "; ".join(found[n20]["setting"]) if n20.any() else "none"
        left = int(found["N20_left"].sum())
        lines.append(
            f"- {group} ({n}): the N20 maximum in the left hemisphere in {left}, "
            f"in the central region in {int(n20.sum())} ({named}); its distance to the region "
            f"{distance.min():.0f}-{distance.max():.0f} mm (median {distance.median():.0f}); "
            f"below the head's centre in {int(below.sum())}."
        )
    return "\n".join(lines)


def observations(table, recordings):
    """What the numbers show beyond the criteria: said after reading them, not criteria."""
    lines = [
        "Observations made after reading the numbers (they are not among the criteria):",
        "",
    ]
    for recording in recordings:
        rows = table[table["recording"] == recording.name]
        depth = np.linalg.norm(recording.positions - recording.centre, axis=1) * 1e3
        edge = rows["N20_depth_mm"] >= depth.max() - 10
        below = rows["N20_z_mm"] < recording.centre[2] * 1e3
        lines.append(
            f"- {recording.name}: {int(below.sum())} of {len(rows)} settings put the N20 "
            f"maximum below the head's centre, {int(edge.sum())} within 10 mm of the source "
            f"space's outer edge ({depth.max():.0f} mm from the centre)."
        )
    dspm = table[table["setting"].str.startswith("dSPM")]
    if len(dspm) and dspm["check_P14_deep"].any():
        lines.append(
            "- dSPM meets deep checks where the others do not, but its maxima are deep at other "
            f"latencies too: its N20 maxima lie {dspm['N20_depth_mm'].min():.0f}-"
            f"{dspm['N20_depth_mm'].max():.0f} mm from the centre, where physiology puts a "
            "cortical generator; its deep maxima are no evidence of a deep P14."
        )
    lines.append(
        "- The 256-channel cap reaches down over the back of the neck; its lowest posterior "
        "electrodes carry the largest amplitudes at 13.5 ms (the cervical N13 and the P14) "
        "and still at 19.3 ms, beside the N20/P20 over the left central scalp (the sensor "
        "figure). The sphere's grid fills the sphere down there, where there is no brain. "
        "With those rows (sep256) the maxima go to the bottom of the grid, and may stand for "
        "those generators (the brainstem and the cervical cord, far below the 40 mm of the "
        "deep region) or for the sphere's misfit; without them (sep256-head) the same grid "
        "is there, and fewer maxima go down (the counts above)."
    )
    return "\n".join(lines)
