"""The conformance suite, checked from outside: the tolerance each case supports, the runners.

``python -m validation.conformance_suite precision`` computes every pinned case with 50
significant digits (mpmath) and measures how far double-precision computations are from it:
the package's three paths and three other ways to write the filter (an explicit inverse of
``S_t``; Joseph's form of the covariance update; ``P^{-1/2}`` as the inverse of
``scipy.linalg.sqrtm``), and the same filter in float32. This is what the tolerance of each
case (docs/conformance.md) rests on.

``python -m validation.conformance_suite runners`` exports the suite, runs the MATLAB/Octave
runner ``run_cases.m`` in GNU Octave on ``validation/octave/skf_plain.m`` (an SKF written from
docs/model.md in MATLAB) and the Python runner ``run_cases.py`` on ``skf_ref``'s own SKF, and
compares every output. It needs ``octave`` on the path (Debian: ``apt-get install octave``).

``python -m validation.conformance_suite float32`` measures correct SKFs computing in single
precision, by algorithm: the package's (Cholesky solves, ``eigh``), a plain covariance-form
loop, Joseph's form, a loop counting from 1 with explicit inverses, and the information
form (validation/skf_from_the_docs.py, validation/skf_independent.py), against each pinned
case, in ``compare``'s measure. The float32 tolerance and ``compare``'s float32 hint rest
on these ranges.

``--write`` also writes the tables to ``validation/conformance_suite.md``. Exit status 0 when
every check holds.
"""

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy import linalg

__all__ = [
    "float32_table",
    "main",
    "precision_table",
    "reference",
    "runners_table",
    "variant",
]

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "conformance_suite.md"
OUTPUTS = ("z", "z_filtered", "x", "x_filtered", "weights", "log_likelihood")
#: Significant digits of the reference computation.
DIGITS = 50
#: What double precision must reach against the reference on every case (measured: at most
#: 1e-10, on ill_conditioned): the suite's tolerance, 1e-6, stays three orders above it.
DOUBLE_BOUND = 1e-9


def _matrices(case):
    p = case.inputs
    m, n = p["L"].shape

    def full(value, k):
        return value * np.eye(k) if np.ndim(value) == 0 else np.asarray(value)

    return (p["L"], p["Y"], full(p["noise_cov"], m), full(p["transition"], n), full(p["q"], n))


def _block(case):
    """Columns standardized together: ``n_orient`` for ``standardize="position"``, else 1."""
    p = case.inputs
    return int(p.get("n_orient", 1)) if p.get("standardize") == "position" else 1


def _mp_weight_matrix(mp, Psi, alpha, block):
    """``W = blockdiag_i B_i ** -alpha``, ``B_i`` the diagonal blocks of ``Psi`` (mpmath)."""
    n = Psi.rows
    W = mp.zeros(n, n)
    for i in range(0, n, block):
        B = Psi[i : i + block, i : i + block]
        values, vectors = mp.eigsy((B + B.T) / 2)
        power = vectors * mp.diag([v**-alpha for v in values]) * vectors.T
        for a in range(block):
            for b in range(block):
                W[i + a, i + b] = power[a, b]
    return W


def _mp_inverse_sqrt(mp, P):
    values, vectors = mp.eigsy((P + P.T) / 2)
    return vectors * mp.diag([1 / mp.sqrt(v) for v in values]) * vectors.T


def reference(case, digits=DIGITS):
    """The case's six outputs computed with ``digits`` significant digits (mpmath)."""
    import mpmath as mp

    p = case.inputs
    block, alpha = _block(case), mp.mpf(p["exponent"])
    L, Y, R, A, Q = _matrices(case)
    P0 = p["theta0"] * np.eye(L.shape[1]) if np.ndim(p["theta0"]) == 0 else p["theta0"]
    with mp.workdps(digits):
        L, Y, R, A, Q, P0 = (
            mp.matrix(np.asarray(v, dtype=float).tolist()) for v in (L, Y, R, A, Q, P0)
        )
        m, n, T = L.rows, L.cols, Y.cols
        x, P, log_likelihood = mp.zeros(n, 1), P0, mp.mpf(0)
        keep = {key: [] for key in ("x", "z", "weights", "W", "P", "P_pred", "whitening")}
        for t in range(T):
            x_pred, P_pred = A * x, A * P * A.T + Q
            S = L * P_pred * L.T + R
            S_inv = S**-1
            K = P_pred * L.T * S_inv
            e = Y[:, t] - L * x_pred
            x, P = x_pred + K * e, P_pred - K * S * K.T
            log_likelihood -= (
                m * mp.log(2 * mp.pi) + mp.log(mp.det(S)) + (e.T * S_inv * e)[0]
            ) / 2
            whitening = _mp_inverse_sqrt(mp, P_pred)
            W = _mp_weight_matrix(mp, whitening * K * S * K.T * whitening, alpha, block)
            z = W * (whitening * x)
            step = dict(x=x, z=z, weights=[W[i, i] for i in range(n)], W=W, P=P, P_pred=P_pred)
            for key, value in (step | {"whitening": whitening}).items():
                keep[key].append(value)

        def rts(means):
            s, P_s = list(means), list(keep["P"])
            for t in range(T - 2, -1, -1):
                G = keep["P"][t] * A.T * keep["P_pred"][t + 1] ** -1
                s[t] = means[t] + G * (s[t + 1] - A * means[t])
                P_s[t] = keep["P"][t] + G * (P_s[t + 1] - keep["P_pred"][t + 1]) * G.T
            return s, P_s

        x_out, z_out = keep["x"], keep["z"]
        if p["smoother"] == "rts-standardized":
            z_out, _ = rts(keep["z"])
        elif p["smoother"] == "rts-state":
            x_out, _ = rts(keep["x"])
            z_out = [keep["W"][t] * keep["whitening"][t] * x_out[t] for t in range(T)]
        elif p["smoother"] == "rts-smoothed-weights":  # Sigma_t = A Sigma_{t-1} A^T + Q
            (x_out, P_s), z_out, Sigma = rts(keep["x"]), [], P0
            for t in range(T):
                Sigma = A * Sigma * A.T + Q
                root = _mp_inverse_sqrt(mp, Sigma)
                W = _mp_weight_matrix(mp, root * (Sigma - P_s[t]) * root, alpha, block)
                z_out.append(W * root * x_out[t])

        def array(sequence):
            return np.array([[float(v[i]) for i in range(n)] for v in sequence]).T

        return dict(
            z=array(z_out),
            z_filtered=array(keep["z"]),
            x=array(x_out),
            x_filtered=array(keep["x"]),
            weights=array(keep["weights"]),
            log_likelihood=float(log_likelihood),
        )


def _weight_matrix(Psi, alpha, block):
    """``W = blockdiag_i B_i ** -alpha``, ``B_i`` the diagonal blocks of ``Psi`` (eigh)."""
    W = np.zeros_like(Psi)
    for i in range(0, len(Psi), block):
        values, vectors = np.linalg.eigh(Psi[i : i + block, i : i + block])
        W[i : i + block, i : i + block] = (vectors * values**-alpha) @ vectors.T
    return W


def variant(case, *, inverse=False, joseph=False, sqrtm=False, dtype=np.float64):
    """The SKF written another way: ``inv(S)``, Joseph's form, ``inv(sqrtm(P))``, float32."""
    p, block = case.inputs, _block(case)
    alpha = dtype(p["exponent"])
    L, Y, R, A, Q = (np.asarray(v, dtype=dtype) for v in _matrices(case))
    n, T = L.shape[1], Y.shape[1]
    P = np.asarray(p["theta0"] * np.eye(n) if np.ndim(p["theta0"]) == 0 else p["theta0"], dtype)
    x, log_likelihood = np.zeros(n, dtype), 0.0
    P0 = P
    keep = {key: [] for key in ("x", "z", "W", "P", "P_pred", "whitening")}
    for t in range(T):
        x_pred, P_pred = A @ x, A @ P @ A.T + Q
        S = L @ P_pred @ L.T + R
        K = P_pred @ L.T @ np.linalg.inv(S) if inverse else np.linalg.solve(S, L @ P_pred).T
        e = Y[:, t] - L @ x_pred
        x = x_pred + K @ e
        if joseph:
            I_KL = np.eye(n, dtype=dtype) - K @ L
            P = I_KL @ P_pred @ I_KL.T + K @ R @ K.T
        else:
            P = P_pred - K @ S @ K.T
        log_likelihood -= 0.5 * (
            len(e) * np.log(2 * np.pi) + np.linalg.slogdet(S)[1] + e @ np.linalg.solve(S, e)
        )
        whitening = _inverse_sqrt(P_pred, sqrtm, dtype)
        W = _weight_matrix(whitening @ K @ S @ K.T @ whitening, alpha, block)
        step = dict(x=x, z=W @ (whitening @ x), W=W, P=P, P_pred=P_pred, whitening=whitening)
        for key, value in step.items():
            keep[key].append(value)
    x_f, z_f = np.array(keep["x"]), np.array(keep["z"])
    x_out, z_out = _smoothed(p["smoother"], keep, x_f, z_f, (A, Q, P0), alpha, block, sqrtm)
    return dict(
        z=z_out.T,
        z_filtered=z_f.T,
        x=x_out.T,
        x_filtered=x_f.T,
        weights=np.array([np.diag(W) for W in keep["W"]]).T,
        log_likelihood=log_likelihood,
    )


def _inverse_sqrt(P, sqrtm, dtype):
    if sqrtm:
        return np.linalg.inv(np.real(linalg.sqrtm(P))).astype(dtype)
    values, vectors = np.linalg.eigh(P)
    return (vectors / np.sqrt(values)) @ vectors.T


def _smoothed(smoother, keep, x_f, z_f, matrices, alpha, block, sqrtm):
    """``x`` and ``z`` (time-major) of :func:`variant` after its smoother."""
    if smoother is None:
        return x_f, z_f
    A, Q, P0 = matrices
    means = z_f if smoother == "rts-standardized" else x_f
    s, P_s = means.copy(), list(keep["P"])
    for t in range(len(s) - 2, -1, -1):
        G = np.linalg.solve(keep["P_pred"][t + 1], A @ keep["P"][t]).T
        s[t] = means[t] + G @ (s[t + 1] - A @ means[t])
        P_s[t] = keep["P"][t] + G @ (P_s[t + 1] - keep["P_pred"][t + 1]) @ G.T
    if smoother == "rts-standardized":
        return x_f, s
    if smoother == "rts-state":
        return s, np.einsum("tij,tjk,tk->ti", keep["W"], keep["whitening"], s)
    z, Sigma = np.empty_like(s), P0  # rts-smoothed-weights: Sigma_t = A Sigma_{t-1} A^T + Q
    for t in range(len(s)):
        Sigma = A @ Sigma @ A.T + Q
        root = _inverse_sqrt(Sigma, sqrtm, s.dtype.type)
        z[t] = _weight_matrix(root @ (Sigma - P_s[t]) @ root, alpha, block) @ root @ s[t]
    return s, z


def _difference(theirs, expected):
    """The suite's measure: the largest, over the outputs, of max|difference| / max|expected|."""
    return max(
        float(
            np.max(np.abs(np.asarray(theirs[k], dtype=float) - expected[k]))
            / np.max(np.abs(expected[k]))
        )
        for k in OUTPUTS
    )


def precision_table():
    """Every pinned case: each computation's distance from the 50-digit reference.

    Returns
    -------
    rows : list of dict
    holds : bool
        Whether every double-precision computation is within ``DOUBLE_BOUND`` of it.
    """
    from skf_ref.conformance import cases

    rows, holds = [], True
    for case in cases():
        ref = reference(case)
        computed = {"pinned": case.expected}
        for method in ("dense", "filterpy", "spectral"):
            if method != "spectral" or np.ndim(case.inputs["transition"]) == 0:
                rec = case.reconstruct(method)
                computed[method] = {k: getattr(rec, k) for k in OUTPUTS}
        computed["inv(S)"] = variant(case, inverse=True)
        computed["Joseph"] = variant(case, joseph=True)
        computed["sqrtm"] = variant(case, sqrtm=True)
        row = {"case": case.name, "tolerance": case.tolerance}
        row |= {name: _difference(outputs, ref) for name, outputs in computed.items()}
        holds &= max(v for k, v in row.items() if k not in ("case", "tolerance")) <= DOUBLE_BOUND
        with np.errstate(all="ignore"):
            row["float32"] = _difference(variant(case, dtype=np.float32), ref)
        rows.append(row)
    return rows, holds


def _cell(value):
    return value if isinstance(value, str) else f"{value:.1e}"


def _markdown(rows):
    keys = list(dict.fromkeys(key for row in rows for key in row))
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for row in rows:
        cells = [_cell(row.get(k, "-")) for k in keys]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _float32_runs(case):
    """Each float32 SKF's outputs on the case, by algorithm."""
    from .skf_from_the_docs import SKF, case_matrices, run_case
    from .skf_independent import CORRECT

    arguments, _ = case_matrices(case, SKF())
    n = case.shape[0]
    for key, name in (("P0", "theta0"), ("Q", "q")):
        value = case.inputs[name]
        arguments[key] = value * np.eye(n) if np.ndim(value) == 0 else value
    yield "package (solve, eigh)", variant(case, dtype=np.float32)
    yield "covariance form", run_case(case, SKF(np.float32))
    labels = {"joseph": "Joseph form", "one_based": "1-based, inv", "information": "information"}
    for name, skf in CORRECT.items():
        yield labels[name], skf(**arguments, dtype=np.float32)


def float32_table():
    """Every pinned case: how far each float32 SKF is from it, in compare's measure.

    Arrays: ``max|difference| / max|expected|``; the log-likelihood over the sum of its
    terms' sizes. The largest over the six outputs.

    Returns
    -------
    rows : list of dict
    ranges : dict
        Per algorithm, the smallest and largest over the well-conditioned cases, and the
        value on ``ill_conditioned``.
    """
    from skf_ref.conformance import cases
    from skf_ref.conformance._expected import expected_intermediates, scales

    rows = []
    for case in cases():
        expected = {**case.expected, **expected_intermediates(case)}
        scale = scales(case, expected)
        row = {"case": case.name}
        with np.errstate(all="ignore"):
            for name, outputs in _float32_runs(case):
                row[name] = max(
                    float(np.max(np.abs(np.asarray(outputs[k], dtype=float) - expected[k])))
                    / scale[k]
                    for k in OUTPUTS
                )
        rows.append(row)
    ranges = {}
    for name in rows[0]:
        if name != "case":
            good = [row[name] for row in rows if row["case"] != "ill_conditioned"]
            ill = next(row[name] for row in rows if row["case"] == "ill_conditioned")
            ranges[name] = (min(good), max(good), ill)
    return rows, ranges


def runners_table(octave="octave"):
    """Export the suite, run both runners, compare every case.

    Returns
    -------
    rows : list of dict
        One per case: the largest difference of the Octave runner's and the Python runner's
        outputs (None when Octave is missing).
    holds : bool
    """
    from skf_ref import compare
    from skf_ref.conformance import cases, export

    rows, holds = [], True
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        export(folder / "cases")
        have_octave = shutil.which(octave) is not None
        if have_octave:
            script = (
                f"addpath('{HERE / 'octave'}'); addpath('{folder / 'cases'}'); "
                f"run_cases('{folder / 'cases'}', '{folder / 'octave'}', @skf_plain)"
            )
            subprocess.run(
                [octave, "--no-gui", "--quiet", "--eval", script], check=True, timeout=600
            )
        command = [
            sys.executable,
            str(folder / "cases" / "run_cases.py"),
            str(folder / "cases"),
            str(folder / "python"),
        ]
        python = subprocess.run(command, capture_output=True, text=True, timeout=600)
        if python.returncode:
            print(python.stdout, python.stderr, file=sys.stderr)
            holds = False
        for case in cases():
            row = {"case": case.name}
            for runner in ("octave", "python"):
                suffix = ".mat" if runner == "octave" else ".npz"
                if runner == "octave" and not have_octave:
                    row[runner] = "no octave"
                    holds = False
                    continue
                result = compare(
                    folder / "cases" / f"{case.name}{suffix}",
                    folder / runner / f"{case.name}{suffix}",
                )
                row[runner] = max(r["largest_difference"] for r in result.rows)
                holds &= result.agrees
            rows.append(row)
    return rows, holds


def main(argv=None):
    """The command line; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("what", choices=("precision", "float32", "runners", "all"))
    parser.add_argument("--write", action="store_true", help=f"write {RESULTS.name}")
    args = parser.parse_args(argv)
    sections, status = [], 0
    if args.what in ("precision", "all"):
        rows, holds = precision_table()
        sections.append(
            f"## Distance from the case computed with {DIGITS} significant digits\n\n"
            "`pinned`: the suite's expected outputs; then the package's paths, three other ways "
            "to write the filter in double precision, and float32. The suite's measure: the "
            "largest over the outputs of max|difference| / max|expected|.\n\n" + _markdown(rows)
        )
        status |= not holds
    if args.what in ("float32", "all"):
        rows, ranges = float32_table()
        lines = [
            f"| {name} | {low:.1e} to {high:.1e} | {ill:.1e} |"
            for name, (low, high, ill) in ranges.items()
        ]
        sections.append(
            "## Single precision, by algorithm\n\nCorrect SKFs computing in float32 against "
            "each pinned case, in `compare`'s measure (arrays over `max|expected|`, the "
            "log-likelihood over the sum of its terms' sizes), the largest over the six "
            "outputs.\n\n" + _markdown(rows) + f"\n\nRanges over the {len(rows) - 1} "
            "well-conditioned cases, and `ill_conditioned`:\n\n| algorithm | "
            "well-conditioned | ill_conditioned |\n|---|---|---|\n" + "\n".join(lines)
        )
    if args.what in ("runners", "all"):
        rows, holds = runners_table()
        sections.append(
            "## The runners\n\n`run_cases.m` in GNU Octave on `validation/octave/skf_plain.m`, "
            "`run_cases.py` on skf_ref's own SKF: the largest difference over the outputs, as "
            "`skf-ref compare` reports it.\n\n" + _markdown(rows)
        )
        status |= not holds
    text = "# The conformance suite, checked from outside\n\n" + "\n\n".join(sections) + "\n"
    print(text)
    if args.write:
        RESULTS.write_text(text, encoding="utf-8")
    return int(status)


if __name__ == "__main__":
    sys.exit(main())
