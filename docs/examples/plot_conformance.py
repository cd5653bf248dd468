"""
Checking your own implementation
================================

You have written the SKF in another language, or on a GPU, and want to know whether it
computes what ``skf_ref`` computes, and if not, where and why (:doc:`/conformance`). Here
"yours" is a small numpy SKF written from :doc:`/model` alone, run on the pinned
conformance suite as any outside program runs it: export the suite, run your SKF on every
case with the exported runner, and let :func:`skf_ref.compare` judge. Then the same SKF in
single precision, which ``compare`` recognizes as float32 rounding, and with a classic
mistake, which ``compare`` names.
"""

import functools
import importlib.util
import re
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from scipy import linalg

import skf_ref
from skf_ref import conformance

# %%
# The pinned suite
# ----------------
# Versions 2 and 3 of the suite ship with the package: small fixed problems whose expected
# outputs were computed once, each as ``.npz`` and MATLAB ``.mat``, with the sha256 of
# every file in ``manifest.json``. :func:`~skf_ref.conformance.export` copies them
# byte for byte, whatever ``skf_ref`` is installed, with two runners, ``run_cases.m`` and
# ``run_cases.py`` (``skf-ref conformance export DIR`` on the command line), and
# :func:`~skf_ref.conformance.verify` names any file that is not the suite's. This
# example runs version 2 (``suite=2``): the SKF below has neither the standardization per
# position nor the smoother standardized by its own variance, which version 3 adds.

folder = Path(tempfile.mkdtemp())
case_dir = folder / "skf-cases"
written = conformance.export(case_dir, formats=["npz"], suite=2)
manifest = conformance.manifest(suite=2)
print(
    f"suite version {manifest['conformance_version']}, expected outputs computed by "
    f"skf_ref {manifest['skf_ref_version']}"
)
print("exported besides the cases:", ", ".join(p.name for p in written if p.suffix != ".npz"))
print("files that differ from the manifest's sha256:", conformance.verify(case_dir, suite=2))
for entry in manifest["cases"]:
    sizes = f"{entry['n_channels']} x {entry['n_sources']} x {entry['n_times']}"
    about = re.split(r": |\. (?=[A-Z])", entry["description"])[0].rstrip(".")
    print(f"{entry['name']:23s} {sizes:11s} {about}")

# %%
# An SKF of your own
# ------------------
# The filter of :doc:`/model` §2 and both smoothers of §3, for full matrices, with the
# runner's signature: ``my_skf(L, Y, R, A, Q, P0, exponent, smoother)`` returns a mapping
# of the outputs. The runner makes the matrices from a case file (a scalar ``noise_cov``,
# ``theta0``, ``q`` or ``transition`` is that number times the identity; ``noise_cov`` is
# a variance). ``weights_from`` is there to make the classic mistake below. Everything is
# computed in the precision of the inputs.


def inverse_sqrt(P):
    eigenvalues, vectors = linalg.eigh(P)
    return (vectors / np.sqrt(eigenvalues)) @ vectors.T


def my_skf(L, Y, R, A, Q, P0, exponent, smoother, weights_from="predicted"):
    x, P = np.zeros(L.shape[1], dtype=L.dtype), P0
    steps = []  # per step: x_{t|t}, P_{t|t}, P_{t|t-1}, diag W_t, P_{t|t-1}^{-1/2}
    log_likelihood = 0.0
    for y in Y.T:
        x_pred, P_pred = A @ x, A @ P @ A.T + Q
        S = L @ P_pred @ L.T + R
        factor = linalg.cho_factor(S)
        K = linalg.cho_solve(factor, L @ P_pred).T
        e = y - L @ x_pred
        x, P = x_pred + K @ e, P_pred - K @ S @ K.T
        B = inverse_sqrt(P_pred)
        C = B if weights_from == "predicted" else inverse_sqrt(P)  # the mistake: P_{t|t}
        W = np.diag(C @ K @ S @ K.T @ C) ** -exponent  # §2.2 eq. (7)
        steps.append((x, P, P_pred, W, B))
        log_det = 2 * np.log(np.diag(factor[0])).sum()
        log_likelihood -= 0.5 * (len(y) * np.log(2 * np.pi) + log_det)
        log_likelihood -= 0.5 * e @ linalg.cho_solve(factor, e)
    x_f, P_f, P_p, W, B = (np.array(a) for a in zip(*steps, strict=True))

    def standardize(x):  # §2.2 eq. (6), at every step
        return W * np.einsum("tij,tj->ti", B, x)

    def rts(sequence):  # §2.3 eq. (4), with the filter's gains
        s = sequence.copy()
        for t in range(len(s) - 2, -1, -1):
            G = linalg.solve(P_p[t + 1], A @ P_f[t], assume_a="pos").T
            s[t] = sequence[t] + G @ (s[t + 1] - A @ sequence[t])
        return s

    z_f = standardize(x_f)
    x, z = x_f, z_f
    if smoother == "rts-standardized":
        z = rts(z_f)
    elif smoother == "rts-state":
        x = rts(x_f)
        z = standardize(x)
    arrays = dict(z=z, z_filtered=z_f, x=x, x_filtered=x_f, weights=W)
    return {name: a.T for name, a in arrays.items()} | {"log_likelihood": log_likelihood}


# %%
# Every case, run and compared
# ----------------------------
# The exported ``run_cases.py`` needs numpy only; on the command line it is
# ``python skf-cases/run_cases.py skf-cases mine --skf mymodule:my_skf``. Here its ``run``
# is called with ``my_skf`` directly: it reads each case file, calls the function and
# saves its outputs to ``mine/<case>.npz``. :func:`skf_ref.compare` (``skf-ref compare
# CASE MINE``) then checks each of the six outputs against the case's tolerance, 1e-6
# relative for every case of version 2.

spec = importlib.util.spec_from_file_location("run_cases", case_dir / "run_cases.py")
runner = importlib.util.module_from_spec(spec)
spec.loader.exec_module(runner)


def largest_differences(done, **options):
    """Each case's largest relative difference over the six outputs, and its comparison."""
    largest, results = {}, {}
    for case_file, mine in done:
        result = results[case_file.stem] = skf_ref.compare(case_file, mine, **options)
        largest[case_file.stem] = max(row["largest_difference"] for row in result.rows)
    return largest, results


largest, results = largest_differences(runner.run(case_dir, folder / "mine", my_skf))
for name, result in results.items():
    print(f"{name:24s} {'agrees' if result.agrees else 'DISAGREES'}")

# %%
# The same SKF in single precision
# --------------------------------
# GPU implementations often compute in float32, whose rounding (eps 1.2e-7) grows through
# the recursion. The same ``my_skf``, given float32 matrices, computes in float32.

float32_dir = folder / "mine-float32"


def my_skf_float32(L, Y, R, A, Q, P0, exponent, smoother):
    single = (m.astype(np.float32) for m in (L, Y, R, A, Q, P0))
    return my_skf(*single, exponent, smoother)


largest32, results32 = largest_differences(runner.run(case_dir, float32_dir, my_skf_float32))

# %%
# At 1e-6, twelve of the thirteen cases disagree. ``compare`` sees that every value given
# is a float32 number and that the differences are what float32 rounding leaves, and says
# which tolerance to use:

print("disagree at 1e-6:", sum(not result.agrees for result in results32.values()))
print(results32["priors_toolbox_clamped"].report())

# %%
# At ``--tolerance 1e-4`` (``tolerance=`` in Python), the tolerance for a float32
# implementation, every case agrees but ``ill_conditioned``: its weights span seven orders
# of magnitude, and single precision cannot compute them (:doc:`/conformance`).

at_float32 = {
    case_file.stem: skf_ref.compare(case_file, float32_dir / case_file.name, tolerance=1e-4)
    for case_file in sorted(case_dir.glob("*.npz"))
}
print("disagree at 1e-4:", [name for name, result in at_float32.items() if not result.agrees])

# %%
# The largest relative difference of any output, per case, in double and in single
# precision, against the two tolerances.

fig, ax = plt.subplots(figsize=(6.5, 5), layout="constrained")
rows = np.arange(len(largest))
ax.barh(rows - 0.2, [max(v, 1e-17) for v in largest.values()], 0.4, label="float64")
ax.barh(rows + 0.2, [largest32[name] for name in largest], 0.4, label="float32")
ax.axvline(1e-6, color="tab:red", label="tolerance, 1e-6")
ax.axvline(1e-4, color="tab:red", linestyle="--", label="float32 tolerance, 1e-4")
ax.set_yticks(rows, list(largest))
ax.set(xscale="log", xlabel="largest relative difference", title="my_skf against the suite")
fig.legend(loc="outside lower center", ncols=2, fontsize="small")
ax.invert_yaxis()

# %%
# A classic mistake, named
# ------------------------
# The raw weights of §2.2 eq. (7) from the *updated* covariance ``P_{t|t}`` instead of the
# predicted ``P_{t|t-1}``: the numbers look plausible, and only a comparison finds it.
# ``compare`` computes the case again with each known mistake that can happen in it (17 in
# all, listed on :doc:`/conformance`) and names the one that reproduces yours.

mistaken = functools.partial(my_skf, weights_from="updated")
case_file = case_dir / "original_skf.npz"
np.savez(folder / "mistaken.npz", **mistaken(**runner.read_case(case_file)))
print(skf_ref.compare(case_file, folder / "mistaken.npz").report())
