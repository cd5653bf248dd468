"""How well ``skf-ref compare`` locates mistakes it does not know (issue 36).

    python -m validation.conformance_mistakes [--write] [--label NAME]

Runs every case of the pinned suite through the SKFs of validation/skf_independent.py
(correct), validation/skf_from_the_docs.py (the template, correct) and
validation/skf_mistaken.py (mistaken: outside the catalogue, and a newcomer's), each with
its six outputs alone and with every intermediate too, and scores what ``skf_ref.compare``
says by the rules of validation/conformance_mistakes.md (committed before the numbers).
Works with any ``compare``: one without a first divergence names nothing. ``--write``
writes the tables under the rules' heading of ``conformance_mistakes.md`` (``--label``
names the section). Exit status 0 when every target holds.
"""

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

from .skf_from_the_docs import OUTPUTS, SKF, case_matrices, run_case
from .skf_independent import CORRECT
from .skf_mistaken import MISTAKES, NEWCOMER

__all__ = ["evaluate", "main"]

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "conformance_mistakes.md"
#: A shown suspect that is further than this many tolerances from their outputs misleads.
FACTOR = 10.0
#: What "named right" must reach, intermediates mode, outside the catalogue.
TARGET = 0.8
_MARK = "\n## Results"


def _correct_runs(case):
    """Each correct SKF's variables on the case (the priors as the runner gives them)."""
    arguments, _ = case_matrices(case, SKF())
    n = case.shape[0]
    for key, name in (("P0", "theta0"), ("Q", "q")):
        value = case.inputs[name]
        arguments[key] = value * np.eye(n) if np.ndim(value) == 0 else value
    priors = {"theta0": case.inputs["theta0"], "q": case.inputs["q"]}
    yield "template", run_case(case, SKF())
    for name, skf in CORRECT.items():
        yield name, skf(**arguments) | priors


def _given(variables, mode, case):
    """What the implementation hands to compare in ``mode``."""
    if mode == "outputs":
        return {name: variables[name] for name in OUTPUTS}
    from skf_ref.conformance._intermediates import variables as defined

    names = defined(case.inputs["smoother"])
    return {name: value for name, value in variables.items() if name in names}


def _expected(case):
    from skf_ref.conformance._expected import expected_intermediates, scales

    expected = {**case.expected, **expected_intermediates(case)}
    return expected, scales(case, expected)


def _shown(result):
    """The known mistakes compare names: the likely causes and the nearest."""
    closest = getattr(result, "closest", None)
    return list(result.diagnosis) + ([closest] if closest else [])


def _misleading(case, shown, theirs, scales):
    """The shown suspects whose outputs do not reproduce theirs within FACTOR tolerances."""
    from skf_ref.conformance._distances import distance
    from skf_ref.conformance._mistakes import SUSPECTS

    wrong = []
    for name in shown:
        outputs = next(s for s in SUSPECTS if s.name == name).compute(case)
        floor = {"log_likelihood": scales["log_likelihood"]}
        far = max(distance(theirs[k], outputs[k], floor.get(k, 0.0)) for k in OUTPUTS)
        if not far <= FACTOR * case.tolerance:
            wrong.append(name)
    return wrong


def _named(result):
    found = getattr(result, "first_divergence", None)
    if found is None:
        return None
    return found["quantity"] if isinstance(found, dict) else found.quantity


def evaluate(cases):
    """Every run: a list of dicts (implementation, group, case, mode, flagged, ...)."""
    from skf_ref import compare

    runs = []
    for case in cases:
        expected, scales = _expected(case)
        for name, variables in _correct_runs(case):
            for mode in ("outputs", "intermediates"):
                given = _given(variables, mode, case)
                result = compare(case, given)
                worst = max(
                    float(np.max(np.abs(np.asarray(v, dtype=float) - expected[k]))) / scales[k]
                    for k, v in given.items()
                )
                runs.append(
                    dict(skf=name, group="correct", case=case.name, mode=mode,
                         flagged=not result.agrees, worst=worst)
                )  # fmt: skip
        for group, classes in (("outside", MISTAKES), ("newcomer", NEWCOMER)):
            for cls in classes:
                try:
                    with np.errstate(all="ignore"):
                        variables = run_case(case, cls())
                except (ValueError, IndexError, np.linalg.LinAlgError):
                    continue  # this mistake cannot run on this case
                for mode in ("outputs", "intermediates"):
                    result = compare(case, _given(variables, mode, case))
                    shown = [] if result.agrees else _shown(result)
                    runs.append(
                        dict(
                            skf=cls.__name__,
                            group=group,
                            case=case.name,
                            mode=mode,
                            flagged=not result.agrees,
                            declared=cls.quantity,
                            named=None if result.agrees else _named(result),
                            shown=shown,
                            misleading=_misleading(case, shown, variables, scales),
                        )
                    )
    return runs


def _rate(count, total):
    return f"{count} / {total} ({100 * count / total:.0f} %)" if total else "0 / 0"


def summary(runs):
    """The scores by group and mode, and whether every target holds."""
    lines = [
        "| group | mode | runs | flagged | named right | suspect shown | misleading |",
        "|---|---|---|---|---|---|---|",
    ]
    holds = True
    for group in ("outside", "newcomer"):
        for mode in ("outputs", "intermediates"):
            mine = [r for r in runs if r["group"] == group and r["mode"] == mode]
            flagged = [r for r in mine if r["flagged"]]
            right = sum(r["named"] == r["declared"] for r in flagged)
            shown = sum(bool(r["shown"]) for r in flagged)
            misleading = sum(bool(r["misleading"]) for r in flagged)
            lines.append(
                f"| {group} | {mode} | {len(mine)} | {len(flagged)} | "
                f"{_rate(right, len(flagged))} | {_rate(shown, len(flagged))} | {misleading} |"
            )
            holds &= misleading == 0
            if group == "outside" and mode == "intermediates":
                holds &= bool(flagged) and right >= TARGET * len(flagged)
    correct = [r for r in runs if r["group"] == "correct"]
    agree = sum(not r["flagged"] for r in correct)
    holds &= agree == len(correct)
    worst = max(r["worst"] for r in correct)
    lines += [
        "",
        f"Correct SKFs ({', '.join(sorted({r['skf'] for r in correct}))}): {agree} of "
        f"{len(correct)} runs agree; the largest difference of any output or intermediate, "
        f"over its own scale, is {worst:.1e}.",
    ]
    return lines, holds


def per_mistake(runs):
    """One row per mistaken SKF: its declared quantity and what compare named."""
    lines = [
        "| mistake | declared | flagged (outputs / intermediates) | named right "
        "(intermediates) | named instead | outputs mode names | shown | misleading |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for skf in dict.fromkeys(r["skf"] for r in runs if r["group"] != "correct"):
        mine = [r for r in runs if r["skf"] == skf]
        flagged = {
            m: [r for r in mine if r["mode"] == m and r["flagged"]]
            for m in ("outputs", "intermediates")
        }
        full = flagged["intermediates"]
        wrong = Counter(str(r["named"]) for r in full if r["named"] != r["declared"])
        outputs_named = Counter(str(r["named"]) for r in flagged["outputs"])
        shown = Counter(s for r in full + flagged["outputs"] for s in r["shown"])
        misleading = sum(bool(r["misleading"]) for r in full + flagged["outputs"])
        lines.append(
            f"| {skf} | {mine[0]['declared']} | {len(flagged['outputs'])} / {len(full)} | "
            f"{sum(r['named'] == r['declared'] for r in full)} | "
            f"{', '.join(f'{k} ({v})' for k, v in wrong.most_common()) or '-'} | "
            f"{', '.join(f'{k} ({v})' for k, v in outputs_named.most_common()) or '-'} | "
            f"{', '.join(f'{k} ({v})' for k, v in shown.most_common()) or '-'} | {misleading} |"
        )  # fmt: skip
    return lines


def main(argv=None):
    """The command line; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help=f"write {RESULTS.name}")
    parser.add_argument("--label", default="the current compare", help="the section's name")
    args = parser.parse_args(argv)
    from skf_ref import __version__
    from skf_ref.conformance import cases

    start, cpu = time.perf_counter(), time.process_time()
    chosen = cases()
    runs = evaluate(chosen)
    lines, holds = summary(runs)
    text = "\n".join(
        [
            f"### {args.label}",
            "",
            f"skf_ref {__version__}; the {len(chosen)} cases of the pinned suite; "
            f"{len(MISTAKES)} mistakes outside the catalogue, {len(NEWCOMER)} a newcomer's. "
            f"Every target holds: {'yes' if holds else 'no'}.",
            "",
            *lines,
            "",
            *per_mistake(runs),
            "",
            f"Wall time {time.perf_counter() - start:.0f} s, "
            f"CPU {time.process_time() - cpu:.0f} s.",
        ]
    )
    print(text)
    if args.write:
        kept = RESULTS.read_text(encoding="utf-8")
        if _MARK not in kept:
            kept += _MARK + "\n"
        head, _, rest = kept.partition(_MARK)
        sections = [s for s in rest.split("\n### ") if s.strip() and not s.startswith(args.label)]
        sections = ["### " + s.removeprefix("### ").strip() for s in sections]
        RESULTS.write_text(
            head + _MARK + "\n\n" + "\n\n".join([*sections, text]) + "\n", encoding="utf-8"
        )
    return 0 if holds else 1


if __name__ == "__main__":
    sys.exit(main())
