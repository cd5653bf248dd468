"""Every number the README and the documentation quote from the study comes from the report.

The evidence study v3 (``python -m validation.reproduce``) writes
``validation/report/headline.json``: the tables the pages print (a summary, where a baseline
beats the default, one table per design) and every number they may quote (the tables' and
the design's). The README's section "What the SKF is worth", and the documentation's
sections on it, must print those tables as written and quote no number the report did not
produce. The retired studies' report (``validation/archive/report-v2/``) is still quoted by
a few sentences of history, tied below.

Elsewhere the pages quote other committed outputs: the report's other sections, the demo
(``validation/demo/``), the real recordings (``validation/report/real/``) and the benchmarks
(``validation/bench/``). :data:`QUOTES` holds each such sentence with its numbers read from
its source, so that a page keeps no number its source no longer says (issue 41).
"""

import csv
import json
import re
import string
from collections.abc import Callable
from dataclasses import dataclass
from decimal import ROUND_HALF_UP, Decimal, InvalidOperation, localcontext
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEADLINE = ROOT / "validation" / "report" / "headline.json"
REPORT = ROOT / "validation" / "report" / "REPORT.md"
BENCH = ROOT / "validation" / "bench"
#: (file, the heading of the section that quotes the study, the headline tables it prints;
#: None: all): the section runs to the next heading of the same or a higher level. The
#: README, kept short, prints the summary and links to the others.
QUOTING = (
    ("README.md", "## What the SKF is worth", ("summary",)),
    ("docs/choosing.md", "## What the SKF is worth", None),
    ("docs/study.md", "## What the report says", ("summary",)),
)


def _section(path, heading):
    text = (ROOT / path).read_text()
    start = text.index(f"\n{heading}\n")
    level = heading.split(" ", 1)[0]
    rest = text[start + len(heading) + 2 :]
    stop = re.search(rf"^#{{1,{len(level)}}} ", rest, flags=re.MULTILINE)
    return rest[: stop.start()] if stop else rest


@pytest.fixture(scope="module")
def headline():
    return json.loads(HEADLINE.read_text())


@pytest.mark.parametrize(("path", "heading", "names"), QUOTING)
def test_the_headline_tables_are_printed_as_the_report_wrote_them(headline, path, heading, names):
    section = _section(path, heading)
    for name in names or headline["tables"]:
        assert f"**{name}**" in section, f"{path}: no {name} table"
        table = headline["tables"][name]
        assert table in section, f"{path}: the {name} table differs from headline.json's"


@pytest.mark.parametrize(("path", "heading", "names"), QUOTING)
def test_every_number_quoted_is_the_reports(headline, path, heading, names):
    section = _section(path, heading)
    for table in headline["tables"].values():
        section = section.replace(table, "")
    section = re.sub(r"`[^`]*`|\([^()]*\.(?:md|png|py)[^()]*\)", "", section)  # code, links
    quotable = set(headline["quotable"])
    quoted = set(re.findall(r"\d+(?:\.\d+)?", section))
    assert quoted <= quotable, f"{path}: numbers not in headline.json: {sorted(quoted - quotable)}"


def test_the_report_prints_the_same_tables(headline):
    report = REPORT.read_text()
    for table in headline["tables"].values():
        assert table in report


# Issue 41: numbers the pages quote from other committed outputs (the report's sections
# beyond the headline, the demo, the real recordings, the benchmarks) are tied to them the
# same way: each quote is the page's sentence with a field for every number, filled from its
# source; a page that keeps a number its source no longer says fails here.


@dataclass(frozen=True)
class Quote:
    """A sentence of a page whose numbers come from a committed file.

    ``text`` is the sentence as a ``str.format`` template (whitespace is compared collapsed),
    each field filled from ``source``: by ``pattern``, a regular expression whose named
    groups are the fields, or by ``read``, a function of the source's text returning them.
    Numbers are Decimals, rounded half up as the sources' tables are written (``{s:.2f}``).
    """

    page: str
    text: str
    source: str
    pattern: str | None = None
    read: Callable[[str], dict] | None = None

    def values(self):
        text = (ROOT / self.source).read_text()
        if self.read is not None:
            return self.read(text)
        found = re.search(self.pattern, text)
        assert found, f"{self.source} no longer says {self.pattern!r}"
        return {k: _number(v) for k, v in found.groupdict().items()}


def _number(value):
    try:
        return Decimal(value)
    except InvalidOperation:
        return value


def _tables(text, heading=None):
    """The Markdown tables of a text (of its section under ``heading``), in order: each a list
    of rows, each a list of cells, without the header."""
    if heading is not None:
        text = _section_of(text, heading)
    tables = []
    for block in re.findall(r"(?:^\|.*\|\n)+", text + "\n", flags=re.MULTILINE):
        rows = [row[2:-2].split(" | ") for row in block.splitlines()]
        tables.append(rows[2:])  # the header and its rule
    return tables


def _section_of(text, heading):
    start = text.index(f"\n{heading}\n") + len(heading) + 2
    stop = re.search(r"^#+ ", text[start:], flags=re.MULTILINE)
    return text[start : start + stop.start()] if stop else text[start:]


def _tuned_priors(text):
    """The report's priors chosen by the data against the best cell of the map, per setting."""
    settings = {}
    rows = _tables(text, "## Priors chosen by the data")[0]  # the second: choices on a bound
    for cell, snr, setting, priors, _, _, _, corr, target in rows:
        entry = settings.setdefault((cell, snr, setting), {})
        entry[priors.split(",")[0]] = (Decimal(corr.split()[0]), target)
    likelihood = [s["marginal likelihood"] for s in settings.values()]
    best = [s["best of the map"][0] for s in settings.values()]
    return {
        "n": len(settings),
        "correlated": sum(c >= b for (c, _), b in zip(likelihood, best, strict=True)),
    }


def _demo(text):
    """The committed demo's deep errors, once its calibrated detections say what the page says."""
    rows = {line.split(",", 1)[0]: line for line in text.splitlines()}
    header = next(csv.reader([rows["metric"]]))[1:]
    table = {
        name: dict(zip(header, next(csv.reader([rows[name]]))[1:], strict=True))
        for name in ("deep_error_mm", "deep_detected_calibrated")
    }
    for column, detected in table["deep_detected_calibrated"].items():
        assert detected == str(column.endswith("present")), (column, detected)
    error = {c: Decimal(v) for c, v in table["deep_error_mm"].items()}
    return {key: error[f"{key}, present"] for key in ("skf", "paper", "sLORETA")}


def _demo_within_6db(text):
    """Which deep-absent columns of the committed demo have the deep region within 6 dB."""
    table = list(csv.DictReader(text.splitlines()))
    row = next(r for r in table if r["metric"] == "deep_within_6db")
    within = {key: row[f"{key}, deep absent"] == "True" for key in ("skf", "paper", "sLORETA")}
    assert within == {"skf": False, "paper": True, "sLORETA": True}, within
    return {}


def _real(text):
    """The real recordings' distances the page quotes (validation/report/real/real.csv)."""
    lines = list(csv.DictReader(text.splitlines()))
    row = {(r["recording"], r["setting"]): r for r in lines}

    def mm(recording, setting, column):
        return Decimal(row[recording, setting][column])

    # the paper's setting and the recommended one, but the paper's at EP 0 dB (quoted apart)
    a0206 = ["SKF paper, auto", "SKF paper, PM0/EP20", "SKF recommended, auto"]
    a0206 += [
        f"SKF {s}, {p}" for s in ("recommended", "position") for p in ("PM0/EP20", "PM0/EP0")
    ]
    to_p = [mm("A0206", s, "N20_to_p_star_mm") for s in a0206]
    loreta = {
        mm("A0206", f"{m}, lambda2 {l2}", "N20_to_p_star_mm").quantize(1, ROUND_HALF_UP)
        for m in ("sLORETA", "eLORETA")
        for l2 in ("discrepancy", "1/9")
    }
    assert len(loreta) == 1, loreta
    assert mm("A0206", "SKF paper, PM0/EP0", "N20_to_central_mm") > 0  # "just outside"
    minimum_norm = [
        mm("sep256", f"{m}, lambda2 discrepancy", "N20_to_central_mm")
        for m in ("MNE", "dSPM", "sLORETA", "eLORETA")
    ]
    position = row["sep256", "SKF position, PM0/EP0"]
    assert position["checks_met"] == row["sep256", "SKF recommended, PM0/EP0"]["checks_met"]
    return {
        "a_lo": min(to_p),
        "a_hi": max(to_p),
        "a_paper0": mm("A0206", "SKF paper, PM0/EP0", "N20_to_p_star_mm"),
        "a_loreta": loreta.pop(),
        "s_position": Decimal(position["N20_to_central_mm"]),
        "s_column": mm("sep256", "SKF recommended, PM0/EP0", "N20_to_central_mm"),
        "s_mn_lo": min(minimum_norm),
        "s_mn_hi": max(minimum_norm),
        "s_lcmv": mm("sep256", "LCMV", "N20_to_central_mm"),
        "s_met": int(position["checks_met"]),
    }


def _sloreta_150000(text):
    row = _bench_row(text, "150000", "128", "1000", "mne-sloreta")
    return {"s": Decimal(row[4].split()[0])}


def _bench_row(text, *key):
    """The cells of validation/bench/results.md's "Every path" row for a size and path."""
    for row in _tables(text, "## Every path")[0]:
        if tuple(row[:4]) == key:
            return row
    raise AssertionError(f"results.md has no row {key}")


def _operator(text):
    """The operator benchmark's table (operator.md), its ratios on one thread beside."""
    one = {r[0]: r for r in _tables((BENCH / "operator-blas1.md").read_text())[0]}
    values = {}
    for path, wall, cpu, ratio, *_ in _tables(text)[0]:
        if path in one:
            key = path.replace("-", "_")
            median, iqr = re.fullmatch(r"([\d.]+) \(([\d.]+)\)", ratio).groups()
            values[f"{key}_wall"] = Decimal(wall.split()[0])
            values[f"{key}_cpu"] = Decimal(cpu.split()[0])
            values[f"{key}_ratio"], values[f"{key}_iqr"] = median, iqr
            values[f"{key}_one"] = one[path][3].split()[0]
    return values


def _epochs(text):
    """The epochs benchmark's tables on two BLAS threads (epochs.md) and one (-blas1)."""
    values = {}
    for suffix, source in (("2", "epochs.md"), ("1", "epochs-blas1.md")):
        page = (BENCH / source).read_text()
        for path, wall, cpu, ratio, *_ in _tables(page)[0]:
            key = f"{path.replace('-', '_')}{suffix}"
            values[f"{key}_wall"] = Decimal(wall.split()[0])
            values[f"{key}_cpu"] = Decimal(cpu.split()[0])
            values[f"{key}_ratio"] = re.sub(r"\((.*)\)", r"[\1]", ratio)  # as the page's
        loads = re.search(r"before: ([\d.]+) .*; after: ([\d.]+) ", page).groups()
        values[f"load{suffix}"] = [Decimal(v) for v in loads]
    loads = values.pop("load1") + values.pop("load2")
    values.update(load_lo=min(loads), load_hi=max(loads))
    values["ratios"] = [Decimal(values[f"skf{s}_ratio"].split()[0]) for s in "12"]
    return values


def _record(text):
    """The benchmark of record's raw and first-application tables (epochs.md's second and
    third, and epochs-blas1.md's), keyed as :func:`_epochs`'s."""
    values = {}
    for suffix, source in (("2", "epochs.md"), ("1", "epochs-blas1.md")):
        _, raw, first, *_ = _tables((BENCH / source).read_text())
        for path, wall, cpu, ratio, *_ in raw:
            key = f"{path.replace('-', '_')}{suffix}"
            values[f"{key}_wall"] = Decimal(wall.split()[0])
            values[f"{key}_cpu"] = Decimal(cpu.split()[0])
            values[f"{key}_ratio"] = re.sub(r"\((.*)\)", r"[\1]", ratio)
        for path, wall, cpu, _, made in first:
            key = f"first_{path.replace('-', '_')}{suffix}"
            values[f"{key}_wall"], values[f"{key}_cpu"] = Decimal(wall), Decimal(cpu)
            values[f"{key}_made"] = Decimal(made)
    return values


def _quiet(text):
    """The benchmark of record rerun on a quieter machine (epochs-quiet.md)."""
    epochs, raw, first, *_ = _tables(text)
    ratios = {row[0]: re.sub(r"\((.*)\)", r"[\1]", row[3]) for row in epochs + raw}
    walls = {row[0]: Decimal(row[1]) for row in first}
    loads = [Decimal(v) for v in re.findall(r"(?:before|after): ([\d.]+) ", text)]
    return dict(skf_ratio=ratios["skf"], raw_ratio=ratios["skf-raw"], fixed=walls["skf"],
                auto=walls["skf-auto"], load_lo=min(loads), load_hi=max(loads))  # fmt: skip


def _before(text):
    """The benchmark of record before issue 46's speed work (epochs-before.md)."""
    epochs, raw, first, *_ = _tables(text)
    ratios = {row[0]: re.sub(r"\((.*)\)", r"[\1]", row[3]) for row in epochs + raw}
    skf_first = next(Decimal(row[1]) for row in first if row[0] == "skf")
    return dict(skf_ratio=ratios["skf"], raw_ratio=ratios["skf-raw"], first=skf_first)


def _speeds(text):
    """The ranges the README quotes: the operator's ratios on one and two threads, epochs'."""
    operator, epochs = _operator(text), _epochs(text)

    def span(*keys):
        values = [Decimal(operator[key]) for key in keys]
        return min(values), max(values)

    lo, hi = span("skf_ratio", "skf_one")
    s_lo, s_hi = span("skf_rts_standardized_ratio", "skf_rts_standardized_one")
    ratios = epochs["ratios"]
    return dict(lo=lo, hi=hi, s_lo=s_lo, s_hi=s_hi, e_lo=min(ratios), e_hi=max(ratios))


_PRIORS = (
    r"over (?P<lo>-\d+) \.\. \d+ dB.*by the marginal likelihood: met in (?P<met>\d+) of "
    r"(?P<n>\d+) settings; by the discrepancy principle: met in (?P<disc>\d+) of \d+"
)
_FLOOR = (
    r"\| quiet \| \d+ \| (?P<path>[\d.]+) \((?P<path_cpu>[\d.]+)\) \| (?P<floor>[\d.]+) "
    r"\((?P<floor_cpu>[\d.]+)\) \| (?P<svd>[\d.]+) \+ (?P<products>[\d.]+) \+ "
    r"(?P<elementwise>[\d.]+) \| (?P<ratio>[\d.]+) \[(?P<q1>[\d.]+), (?P<q3>[\d.]+)\] \| "
    r"(?P<ratio_cpu>[\d.]+) .*\n.*\| competitor \| \d+ \| (?P<c_path>[\d.]+) "
    r"\((?P<c_path_cpu>[\d.]+)\) \| (?P<c_floor>[\d.]+) \((?P<c_floor_cpu>[\d.]+)\) \| [^|]+ \| "
    r"(?P<c_ratio>[\d.]+) \[(?P<c_q1>[\d.]+), (?P<c_q3>[\d.]+)\] \| (?P<c_ratio_cpu>[\d.]+) "
)
_LONG = (
    r"held from step (?P<step>\d+) on.*\n(?:.*\n){3}\| (?P<s>[\d.]+) \| (?P<cpu>[\d.]+) \| "
    r"(?P<load>[\d.]+ / \d+) \| (?P<gib>[\d.]+) \| (?P<mibs>\d+) \| \d+ \| (?P<share>[\d.]+) "
    r"(?s:.*)Targets: (?P<faster>[\d.]+)x faster than before the steady state "
    r"\((?P<before>[\d.]+) s; target (?P<target>\d+)x\), [\d.]+ GiB resident "
    r"\(target < (?P<gib_target>[\d.]+) GiB\)"
)
_TARGETS = (
    r"at 1500 columns: (?P<filterpy>\d+)x faster.*\n.*paper scale, smoothed: "
    r"(?P<paper>[\d.]+) s.*\n.*\(9000, 64, 1000\): (?P<sloreta>[\d.]+)x MNE's sLORETA.*\n"
    r".*apply_skf (?P<apply>[\d.]+)x MNE's make.*\n.*smoothed z: (?P<big>[\d.]+) s, "
    r"(?P<big_gib>[\d.]+) GiB traced peak.*\n.*\(9000, 64, 41\): (?P<tune>[\d.]+) s.*\n"
    r".*\(150000, 128, 1000\): (?P<tune_big>[\d.]+) s"
)
_POSITION = (
    r"\| position-0\.5 \| 0\.68\.1 \| 5 \| [^|]+ \| [^|]+ \| (?P<half>[\d.]+) \[.*\n"
    r"\| position-1\.25 \| 0\.68\.1 \| 5 \| [^|]+ \| [^|]+ \| (?P<one>[\d.]+) \[(?s:.*)"
    r"\*\*Without numba\*\*.*: (?P<no_half>[\d.]+)x at 0\.5 and (?P<no_one>[\d.]+)x at 1\.25"
)
QUOTES = (
    Quote(
        "docs/choosing.md",
        "it puts PM-SNR on the lower end of the range searched, {lo} dB, in {pm} of its {n} "
        "choices",
        "validation/archive/report-v2/REPORT.md",
        r"over (?P<lo>-\d+) \.\. \d+ dB.*\n(?s:.*)by the marginal likelihood \((?P<n>\d+) "
        r"choices\), PM-SNR in (?P<pm>\d+)",
    ),
    Quote(
        "docs/choosing.md",
        "its priors meet the localization target set against the best cells found with the "
        "ground truth in {met} of {n} settings (the discrepancy principle's in {disc} of {n})",
        "validation/archive/report-v2/REPORT.md",
        _PRIORS,
    ),
    Quote(
        "docs/choosing.md",
        "their time courses correlate with the truth as well as the best cell's or better in "
        "{correlated} of {n}",
        "validation/archive/report-v2/REPORT.md",
        read=_tuned_priors,
    ),
    Quote(
        "docs/study.md",
        "the recommended setting and the paper's put the deep maximum {skf:.0f} and "
        "{paper:.0f} mm from the source, sLORETA {sLORETA:.0f} mm",
        "validation/demo/metrics.csv",
        read=_demo,
    ),
    Quote(
        "docs/study.md",
        "in that one data set ({snr:.0f} dB, seed {seed})",
        "validation/demo/settings.json",
        r'"snr_db": (?P<snr>[\d.]+),(?s:.*)"seed": (?P<seed>\d+),',
    ),
    Quote(
        "docs/study.md",
        "the data chose a time constant of {tau:.0f} ms, the lower end of the range searched",
        "validation/demo/settings.json",
        r'"tuned_time_constant_ms": (?P<tau>1\.00\d*),',  # 1.00x ms: the lower end
    ),
    Quote(
        "docs/study.md",
        "the paper's setting's and sLORETA's deep regions are within 6 dB without the deep "
        "source too",
        "validation/demo/metrics.csv",
        read=_demo_within_6db,
    ),
    Quote(
        "docs/study.md",
        "the smoothed SKF at the paper's scale (9000 columns, 41 steps) in {paper} s, "
        "{filterpy}x faster than the filterpy subclass at 1500 columns; 150 000 columns x 128 "
        "channels x 1000 steps in {big} s and {big_gib} GiB",
        "validation/bench/results.md",
        _TARGETS,
    ),
    Quote(
        "docs/study.md",
        "MNE's sLORETA applied to the same data took {s:.1f} s",
        "validation/bench/results.md",
        read=_sloreta_150000,
    ),
    Quote(
        "docs/study.md",
        "at 9000 columns x 1000 steps it takes {sloreta}x the time of applying MNE's prepared "
        "sLORETA operator, and `apply_skf` {apply}x making and applying it",
        "validation/bench/results.md",
        _TARGETS,
    ),
    Quote(
        "docs/study.md",
        "Tuning the priors takes {tune} s at the paper's scale and {tune_big} s at 150 000 x "
        "1000.",
        "validation/bench/results.md",
        _TARGETS,
    ),
    Quote(
        "docs/study.md",
        "{s} s ({before} s before the steady state was held) at {gib} GiB peak resident memory "
        "(target {gib_target} GiB: met), {share:.0P} of the disk's plain sequential write speed",
        "validation/bench/results.md",
        _LONG,
    ),
    Quote(
        "docs/performance.md",
        "In the run of record it took {floor:.2f} s ({svd:.2f} + {products:.2f} + "
        "{elementwise:.2f}) against the path's {path:.2f} s",
        "validation/bench/results.md",
        _FLOOR,
    ),
    Quote(
        "docs/performance.md",
        "| quiet | {path:.2f} ({path_cpu:.2f}) | {floor:.2f} ({floor_cpu:.2f}) | {ratio:.2f} "
        "[{q1:.2f}, {q3:.2f}] | {ratio_cpu:.2f} |",
        "validation/bench/results.md",
        _FLOOR,
    ),
    Quote(
        "docs/performance.md",
        "| beside a competitor | {c_path:.2f} ({c_path_cpu:.2f}) | {c_floor:.2f} "
        "({c_floor_cpu:.2f}) | {c_ratio:.2f} [{c_q1:.2f}, {c_q3:.2f}] | {c_ratio_cpu:.2f} |",
        "validation/bench/results.md",
        _FLOOR,
    ),
    Quote(
        "docs/performance.md",
        "the recursions held from step {step} on.",
        "validation/bench/results.md",
        _LONG,
    ),
    Quote(
        "docs/performance.md",
        "| before the steady state was held | {before} |",
        "validation/bench/results.md",
        _LONG,
    ),
    Quote(
        "docs/performance.md",
        "| now | {s} | {cpu} | {load} | {gib} GiB |",
        "validation/bench/results.md",
        _LONG,
    ),
    Quote(
        "docs/performance.md",
        "{faster} times faster (target {target}), within the {gib_target} GiB target",
        "validation/bench/results.md",
        _LONG,
    ),
    Quote(
        "docs/performance.md",
        "written at {mibs} MiB/s, {share:.0P} of this disk's plain sequential speed",
        "validation/bench/results.md",
        _LONG,
    ),
    Quote(
        "docs/performance.md",
        "| MNE sLORETA | {mne_sloreta_wall:.3f} | {mne_sloreta_cpu:.3f} | 1 | 1 | |",
        "validation/bench/operator.md",
        read=_operator,
    ),
    Quote(
        "docs/performance.md",
        "| SKF, exponent 0.5, no smoother | {skf_wall:.3f} | {skf_cpu:.3f} | {skf_ratio} "
        "[{skf_iqr}] | {skf_one} | <= 1 |",
        "validation/bench/operator.md",
        read=_operator,
    ),
    Quote(
        "docs/performance.md",
        '| SKF, `"rts-state"` | {skf_rts_state_wall:.3f} | {skf_rts_state_cpu:.3f} | '
        "{skf_rts_state_ratio} [{skf_rts_state_iqr}] | {skf_rts_state_one} | <= 1.5 |",
        "validation/bench/operator.md",
        read=_operator,
    ),
    Quote(
        "docs/performance.md",
        '| SKF, `"rts-standardized"` | {skf_rts_standardized_wall:.3f} | '
        "{skf_rts_standardized_cpu:.3f} | {skf_rts_standardized_ratio} "
        "[{skf_rts_standardized_iqr}] | {skf_rts_standardized_one} | <= 1.5 |",
        "validation/bench/operator.md",
        read=_operator,
    ),
    Quote(
        "docs/performance.md",
        "| MNE sLORETA, 2 BLAS threads | {mne_sloreta2_wall:.2f} | {mne_sloreta2_cpu:.2f} | 1 "
        "| |\n| SKF, 2 BLAS threads | {skf2_wall:.2f} | {skf2_cpu:.2f} | {skf2_ratio} | "
        "<= 1.5 |\n| MNE sLORETA, 1 BLAS thread | {mne_sloreta1_wall:.2f} | "
        "{mne_sloreta1_cpu:.2f} | 1 | |\n| SKF, 1 BLAS thread | {skf1_wall:.2f} | "
        "{skf1_cpu:.2f} | {skf1_ratio} | <= 1.5 |",
        "validation/bench/epochs.md",
        read=_epochs,
    ),
    Quote(
        "docs/performance.md",
        "load average {load_lo:.0f} to {load_hi:.0f}",
        "validation/bench/epochs.md",
        read=_epochs,
    ),
    Quote(
        "docs/performance.md",
        "| MNE sLORETA, raw, 2 BLAS threads | {mne_sloreta_raw2_wall:.2f} | "
        "{mne_sloreta_raw2_cpu:.2f} | 1 | |\n| SKF, raw, 2 BLAS threads | {skf_raw2_wall:.2f} | "
        "{skf_raw2_cpu:.2f} | {skf_raw2_ratio} | <= 2 |\n| MNE sLORETA, raw, 1 BLAS thread | "
        "{mne_sloreta_raw1_wall:.2f} | {mne_sloreta_raw1_cpu:.2f} | 1 | |\n| SKF, raw, 1 BLAS "
        "thread | {skf_raw1_wall:.2f} | {skf_raw1_cpu:.2f} | {skf_raw1_ratio} | <= 2 |",
        "validation/bench/epochs.md",
        read=_record,
    ),
    Quote(
        "docs/performance.md",
        "| MNE sLORETA, `apply_inverse` | {first_mne_sloreta2_wall:.2f} | "
        "{first_mne_sloreta2_cpu:.2f} | {first_mne_sloreta1_wall:.2f} | |\n| SKF, priors fixed "
        "in the operator | {first_skf2_wall:.2f} | {first_skf2_cpu:.2f} | "
        '{first_skf1_wall:.2f} | < 2 |\n| SKF, priors chosen by the data (`"auto"`, the '
        "default) | {first_skf_auto2_wall:.2f} | {first_skf_auto2_cpu:.2f} | "
        "{first_skf_auto1_wall:.2f} | |",
        "validation/bench/epochs.md",
        read=_record,
    ),
    Quote(
        "docs/performance.md",
        "gave the SKF {skf_ratio} times MNE on epochs, {raw_ratio} on the recording and "
        "{first:.2f} s for a first application",
        "validation/bench/epochs-before.md",
        read=lambda text: _before(text),
    ),
    Quote(
        "docs/performance.md",
        "On a quieter machine (load average {load_lo} to {load_hi}, 3 rounds; "
        "`validation/bench/epochs-quiet.md`) the same benchmark gave the SKF {skf_ratio} times "
        "MNE on epochs and {raw_ratio} on the recording, and a first application in {fixed:.2f} "
        's with the priors fixed in the operator and {auto:.2f} s with the default `"auto"` '
        "priors, tuned in that first call.",
        "validation/bench/epochs-quiet.md",
        read=lambda text: _quiet(text),
    ),
    Quote(
        "docs/mne.md",
        "`apply_skf_epochs` took {ratios[0]} times as long as MNE's `apply_inverse_epochs` with "
        "a prepared sLORETA operator on one BLAS thread, and {ratios[1]} times on two (medians "
        "of 9 interleaved rounds, on a 2-core machine shared with other work: load average "
        "{load_lo:.0f} to {load_hi:.0f};",
        "validation/bench/epochs.md",
        read=_epochs,
    ),
    Quote(
        "docs/performance.md",
        "it costs {one:.1f} times the column form's time at exponent 1.25 and {half:.2f} "
        "times it at 0.5",
        "validation/bench/results.md",
        _POSITION,
    ),
    Quote(
        "docs/performance.md",
        "without numba {no_one:.1f}-{no_half:.1f} times",
        "validation/bench/results.md",
        _POSITION,
    ),
    Quote(
        "docs/real_data.md",
        "the SKF puts the N20 in the left central region, {a_lo:.0f}-{a_hi:.0f} mm from the "
        "point under C3/CP3 (the paper's setting at EP 0 dB: {a_paper0:.0f} mm, just "
        "outside), as MNE's minimum norm does (sLORETA and eLORETA {a_loreta} mm)",
        "validation/report/real/real.csv",
        read=_real,
    ),
    Quote(
        "docs/real_data.md",
        "puts the N20 {s_position:.0f} mm from the central region (the column form "
        "{s_column:.0f} mm, MNE's minimum-norm methods with lambda2 by the discrepancy "
        "principle {s_mn_lo:.0f}-{s_mn_hi:.0f} mm, LCMV {s_lcmv:.0f} mm), with {s_met} of "
        "the 5 checks as before",
        "validation/report/real/real.csv",
        read=_real,
    ),
    Quote(
        "docs/choosing.md",
        "the walk's filtered peak comes {wd} ms late for the deep source and {ws} ms for the "
        "cortical one (time-course r {wdr} and {wsr}), where the AR(1) at 10 ms is {ad} and "
        "{as_} ms off (r {adr} and {asr}). A smoother takes the walk's lag back (the paper's "
        '`"rts-standardized"`: {rd} and {rs} ms), but the paper\'s smoother, which runs over '
        "the standardized sequence, pulls the AR(1)'s deep peak early ({early} ms at 20 ms)",
        "validation/timecourses/timecourses.md",
        read=lambda text: _timecourses(text),
    ),
    Quote(
        "docs/choosing.md",
        "The likelihood chose a median time constant of {erp} ms on the evoked response and "
        "{pulse} ms on the pulses.",
        "validation/timecourses/timecourses.md",
        r"median ms\): erp (?P<erp>[\d.]+), pulse (?P<pulse>[\d.]+)\.",
    ),
    Quote(
        "docs/performance.md",
        "the AR(1) at 10 ms took {r} of the walk's wall time [{r1}, {r3}] and {c} of its CPU "
        "time [{c1}, {c3}] (median [IQR] over {n} rounds), on a machine busy with other work "
        "(load {load})",
        "validation/bench/ar1.md",
        read=lambda text: _ar1(text),
    ),
    Quote(
        "docs/performance.md",
        "took {tau} s wall ({cpu} s of CPU) at 60 channels x 8000 columns x 300 samples, "
        "against {walk} s for the walk's two SNRs",
        "validation/bench/tune_time_constant.md",
        r"\| tune-time-constant \| (?P<tau>[\d.]+) \| (?P<cpu>[\d.]+) \|[\s\S]*"
        r"\| tune-ep-snr \| (?P<walk>[\d.]+) \|",
    ),
    Quote(
        "README.md",
        "150 000 sources x 128 channels x 1000 steps, smoothed, in {big} s on 2 cores",
        "validation/bench/results.md",
        _TARGETS,
    ),
    Quote(
        "README.md",
        "({ratio:.2f}x the floor of its products, {c_ratio:.2f}x beside a busy process)",
        "validation/bench/results.md",
        _FLOOR,
    ),
    Quote(
        "README.md",
        "streamed to disk in {s:.0f} s ({before:.0f} s before the steady state)",
        "validation/bench/results.md",
        _LONG,
    ),
    Quote(
        "README.md",
        "an operator at {lo:.1f}-{hi:.1f}x MNE's sLORETA ({s_lo:.1f}-{s_hi:.1f}x with the "
        "paper's smoother), {e_lo:.1f}-{e_hi:.1f}x on epochs",
        "validation/bench/operator.md",
        read=_speeds,
    ),
    Quote(
        "docs/choosing.md",
        "With {n_samples} samples per dataset, the SKF came in place {g_place} of {n_solvers} "
        "solvers by invertmeeg's global rank ({g_rank}):",
        "validation/invertmeeg/results.csv",
        read=lambda text: _invertmeeg(text),
    ),
    Quote(
        "docs/choosing.md",
        "By dataset: place {focal} (focal), {multi} (multi-source), {extended} (extended) and "
        "{noisy} (noisy). The time constant its likelihood chose was short (median {tau:.1f} "
        "ms)",
        "validation/invertmeeg/results.csv",
        read=lambda text: _invertmeeg(text),
    ),
)


def _timecourses(text):
    """The medians of validation/timecourses/timecourses.md's cells the page quotes."""
    rows = {tuple(row[:3]): row[3:] for row in _tables(text)[0]}

    def median(design, prior, smoother, column):
        return rows[design, prior, smoother][column].split(" [")[0]

    walk, ar10, ar20 = "random walk, EP 0 dB", "AR(1), 10 ms", "AR(1), 20 ms"
    return dict(
        wd=median("erp", walk, "none", 0), wdr=median("erp", walk, "none", 1),
        ws=median("erp", walk, "none", 2), wsr=median("erp", walk, "none", 3),
        ad=median("erp", ar10, "none", 0), adr=median("erp", ar10, "none", 1),
        as_=median("erp", ar10, "none", 2), asr=median("erp", ar10, "none", 3),
        rd=median("erp", walk, "rts-standardized", 0),
        rs=median("erp", walk, "rts-standardized", 2),
        early=median("erp", ar20, "rts-standardized", 0),
    )  # fmt: skip


def _invertmeeg(text):
    """The SKF's places on invertmeeg's benchmark (validation/invertmeeg/results.csv; its
    rank columns are invertmeeg's), the samples and the time constants (run.json)."""
    rows = list(csv.DictReader(text.splitlines()))
    run = json.loads((ROOT / "validation" / "invertmeeg" / "run.json").read_text())

    def place(rank_of):
        skf = rank_of["skf"]
        return 1 + sum(rank < skf for rank in rank_of.values())

    by_dataset = {}
    for row in rows:
        by_dataset.setdefault(row["dataset"], {})[row["solver"]] = Decimal(row["rank"])
    global_rank = {row["solver"]: Decimal(row["global rank"]) for row in rows}
    (n_solvers,) = {len(ranks) for ranks in by_dataset.values()}
    taus = sorted(run["time_constants_ms"])
    middle = len(taus) // 2
    tau = taus[middle] if len(taus) % 2 else (taus[middle - 1] + taus[middle]) / 2
    return {
        "n_samples": run["n_samples"],
        "n_solvers": n_solvers,
        "g_place": place(global_rank),
        "g_rank": global_rank["skf"],
        "focal": place(by_dataset["focal_source"]),
        "multi": place(by_dataset["multi_source"]),
        "extended": place(by_dataset["extended_source"]),
        "noisy": place(by_dataset["noisy"]),
        "tau": Decimal(repr(tau)),
    }


def _ar1(text):
    """validation/bench/ar1.md's ratios, their quartiles, rounds and load."""
    ratios = re.search(
        r"wall (?P<r>[\d.]+) \[(?P<r1>[\d.]+), (?P<r3>[\d.]+)\], CPU (?P<c>[\d.]+) "
        r"\[(?P<c1>[\d.]+), (?P<c3>[\d.]+)\].*?; load (?P<load>[\d.]+)",
        text,
        flags=re.S,
    )
    rounds = re.search(r"(?P<n>\d+) alternated rounds", text)
    assert ratios and rounds, "validation/bench/ar1.md no longer says its ratios"
    return ratios.groupdict() | rounds.groupdict()


def _collapsed(text):
    return re.sub(r"\s+", " ", text)


class _Formatter(string.Formatter):
    """``str.format``, and ``P``: a fraction as a percentage followed by " %" (``{x:.0P}``)."""

    def format_field(self, value, format_spec):
        if format_spec.endswith("P"):
            return format(100 * value, format_spec[:-1] + "f") + " %"
        return super().format_field(value, format_spec)


@pytest.mark.parametrize("quote", QUOTES, ids=lambda q: f"{q.page}:{q.text[:40]}")
def test_every_number_quoted_from_a_committed_output_is_its_own(quote):
    with localcontext() as context:
        context.rounding = ROUND_HALF_UP
        expected = _Formatter().format(quote.text, **quote.values())
    page = _collapsed((ROOT / quote.page).read_text())
    assert _collapsed(expected) in page, f"{quote.page} should say: {expected}"
