"""Run an SKF on every conformance case, save its outputs, and compare them.

    python run_cases.py CASE_DIR OUT_DIR [--skf MODULE:FUNCTION]

CASE_DIR is a folder ``skf-ref conformance export`` wrote. For each case listed in its
``manifest.json`` this reads the ``.npz`` file, makes the model's matrices (a scalar
``noise_cov``, ``theta0``, ``q`` or ``transition`` is that number times the identity;
``noise_cov`` is a variance), calls

    FUNCTION(L, Y, R, A, Q, P0, exponent, smoother)

(a case that standardizes each position as a whole, suite version 3, also passes
``standardize="position", n_orient=3``; a FUNCTION without those parameters skips it) and
saves what it returns to ``OUT_DIR/<case>.npz``. FUNCTION returns a mapping with any of
``z``, ``z_filtered``, ``x``, ``x_filtered``, ``weights`` (arrays of shape
(n_sources, n_times)) and ``log_likelihood``, and any of the intermediate quantities it
computes (:data:`INTERMEDIATES`, their shapes in the suite's docs/conformance.md: ``P_pred``
is (n_sources, n_sources, n_times), time last), which ``compare`` uses to name the first
quantity that goes wrong; ``smoother`` is ``"none"``, ``"rts-standardized"``,
``"rts-state"`` or ``"rts-smoothed-weights"``. Without ``--skf`` it runs ``skf_ref``'s own
SKF: replace :func:`my_skf` with yours, or name yours with ``--skf`` (MODULE is imported
from the current folder or the Python path).

Then, where ``skf_ref`` is installed, every case is compared (``skf-ref compare``): one
line per case, the full report of each that disagrees, and the exit status 0 when every
case agrees, 1 when one does not. Without ``skf_ref`` it only saves; compare elsewhere
with ``skf-ref compare CASE_DIR/<case>.npz OUT_DIR/<case>.npz``.

Needs numpy only: copy it into your project and adapt it.
"""

import argparse
import importlib
import inspect
import json
import re
import sys
from pathlib import Path

import numpy as np

OUTPUTS = ("z", "z_filtered", "x", "x_filtered", "weights", "log_likelihood")
#: What FUNCTION may return besides the outputs: saved too, for compare's first divergence.
INTERMEDIATES = (
    *("theta0", "q", "x_pred", "P_pred", "S", "K", "P_filt", "w"),
    *("G", "P_smooth", "Sigma", "w_smooth"),
)


def my_skf(L, Y, R, A, Q, P0, exponent, smoother, standardize="column", n_orient=None):
    """Replace with your SKF. This one is skf_ref's, so that the runner runs as it is."""
    import skf_ref

    rec = skf_ref.reconstruct(
        L, Y, noise_cov=R, theta0=P0, q=Q, transition=A, exponent=exponent, smoother=smoother,
        standardize=standardize, n_orient=n_orient,
    )  # fmt: skip
    return {name: getattr(rec, name) for name in OUTPUTS}


def read_case(path):
    """The inputs of a case file, as matrices: L, Y, R, A, Q, P0, exponent, smoother (and
    standardize, n_orient when the case standardizes each position as a whole)."""
    with np.load(path, allow_pickle=False) as case:
        m, n = case["L"].shape

        def matrix(name, size):  # a scalar c means c times the identity
            value = case[name]
            return value * np.eye(size) if value.ndim == 0 else value

        found = dict(
            L=case["L"],
            Y=case["Y"],
            R=matrix("noise_cov", m),
            A=matrix("transition", n),
            Q=matrix("q", n),
            P0=matrix("theta0", n),
            exponent=float(case["exponent"]),
            smoother=str(case["smoother"]),
        )
        if "standardize" in case.files and str(case["standardize"]) != "column":
            found |= dict(standardize=str(case["standardize"]), n_orient=int(case["n_orient"]))
        return found


def takes(skf, name):
    """Whether ``skf`` has a parameter ``name`` (or takes any keyword)."""
    parameters = inspect.signature(skf).parameters.values()
    return any(p.name == name or p.kind is p.VAR_KEYWORD for p in parameters)


def case_name(entry):
    """A case's name from manifest.json, refused unless it is a plain file name: a name
    such as ``../elsewhere/x`` or ``/tmp/x`` would read and write outside the folders."""
    name = entry.get("name") if isinstance(entry, dict) else None
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", name):
        raise SystemExit(
            f"run_cases.py: manifest.json names a case {name!r}, which is not a plain file "
            "name (letters, digits, '_', '-', '.'): refused"
        )
    return name


def run(case_dir, out_dir, skf):
    """Run ``skf`` on every case of ``case_dir``; save its outputs in ``out_dir``.

    Returns the list of (case file, output file).
    """
    case_dir, out_dir = Path(case_dir), Path(out_dir)
    manifest = json.loads((case_dir / "manifest.json").read_text(encoding="utf-8"))
    names = [case_name(entry) for entry in manifest["cases"]]  # all checked before any work
    out_dir.mkdir(parents=True, exist_ok=True)
    done = []
    for case in names:
        case_file, out_file = case_dir / f"{case}.npz", out_dir / f"{case}.npz"
        inputs = read_case(case_file)
        if "standardize" in inputs and not takes(skf, "standardize"):
            print(
                f"{case:<24} skipped: it standardizes each position as a whole "
                f"(standardize={inputs['standardize']!r}, n_orient={inputs['n_orient']}), "
                "and the function has no such parameters"
            )
            continue
        outputs = skf(**inputs)
        kept = [name for name in OUTPUTS + INTERMEDIATES if name in outputs]
        np.savez(out_file, **{name: outputs[name] for name in kept})
        done.append((case_file, out_file))
    return done


def compare_all(done):
    """Compare each output file with its case (needs skf_ref); the exit status, 0 or 1."""
    from skf_ref import compare

    status = 0
    for case_file, out_file in done:
        result = compare(case_file, out_file)
        print(f"{case_file.stem:<24} {'agrees' if result.agrees else 'DISAGREES'}")
        if not result.agrees:
            print(result.report(), end="\n\n")
            status = 1
    return status


def _function(spec):
    module, _, name = spec.partition(":")
    if not name:
        raise SystemExit(f"run_cases.py: --skf must be MODULE:FUNCTION, got {spec!r}")
    if str(Path.cwd()) not in sys.path:
        sys.path.insert(0, str(Path.cwd()))
    return getattr(importlib.import_module(module), name)


def main(argv=None):
    """The command line; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("case_dir", type=Path, help="a folder skf-ref conformance export wrote")
    parser.add_argument("out_dir", type=Path, help="where to save the outputs (made if missing)")
    parser.add_argument("--skf", help="your SKF as MODULE:FUNCTION (default: my_skf)")
    args = parser.parse_args(argv)
    done = run(args.case_dir, args.out_dir, _function(args.skf) if args.skf else my_skf)
    print(f"saved the outputs of {len(done)} cases to {args.out_dir}")
    try:
        import skf_ref  # noqa: F401
    except ImportError:
        print("skf_ref is not installed here: compare with skf-ref compare CASE_FILE OUT_FILE")
        return 0
    return compare_all(done)


if __name__ == "__main__":
    sys.exit(main())
