"""
Checking your own implementation
================================

You have written the SKF in another language, or on a GPU, and want to know whether it
computes what ``skf_ref`` computes, and if not, where and why (:doc:`/conformance`). Here
"yours" is a small numpy SKF written from :doc:`/model` alone, run on the exported
conformance cases as any outside program would run them: read a case file, compute, save
the outputs, and let :func:`skf_ref.compare` judge. Then the same with a classic mistake,
which ``compare`` names.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from scipy import linalg

import skf_ref
from skf_ref.conformance import export

# %%
# The cases
# ---------
# Small fixed problems with this package's answers, as ``.npz`` and MATLAB ``.mat`` files
# (``skf-ref conformance export DIR`` on the command line).

folder = Path(tempfile.mkdtemp())
written = export(folder / "skf-cases", formats=["npz"])
case_files = [path for path in written if path.suffix == ".npz"]
for path in case_files:
    with np.load(path) as case:
        print(f"{path.stem:24s} {str(case['exercises'])}")

# %%
# An SKF of your own
# ------------------
# The filter of :doc:`/model` §2 and both smoothers of §3, for full matrices. A scalar
# ``noise_cov``, ``theta0``, ``q`` or ``transition`` in a case file means that number times
# the identity. ``weights_from`` is there to make the classic mistake below.


def inverse_sqrt(P):
    eigenvalues, vectors = linalg.eigh(P)
    return (vectors / np.sqrt(eigenvalues)) @ vectors.T


def my_skf(L, Y, R, A, Q, P0, exponent, smoother, weights_from="predicted"):
    x, P = np.zeros(L.shape[1]), P0
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


def run_on_case(path, out, **mistake):
    """Read a case file, run my_skf, save its outputs as .npz: what an outside program does."""
    with np.load(path) as case:
        m, n = case["L"].shape

        def matrix(name, size):  # a scalar c means c I
            value = case[name]
            return value * np.eye(size) if value.ndim == 0 else value

        R, A = matrix("noise_cov", m), matrix("transition", n)
        Q, P0 = matrix("q", n), matrix("theta0", n)
        exponent, smoother = float(case["exponent"]), str(case["smoother"])
        outputs = my_skf(case["L"], case["Y"], R, A, Q, P0, exponent, smoother, **mistake)
    np.savez(out, **outputs)
    return out


# %%
# Every case, compared
# --------------------
# :func:`skf_ref.compare` takes the case file and yours (``skf-ref compare CASE MINE`` on
# the command line); each of the six outputs must agree to 1e-6 relative.

largest = {}
for path in case_files:
    mine = run_on_case(path, folder / f"mine-{path.stem}.npz")
    result = skf_ref.compare(path, mine)
    largest[path.stem] = max(row["largest_difference"] for row in result.rows)
    print(f"{path.stem:24s} {'agrees' if result.agrees else 'DISAGREES'}")

# %%
# The largest relative difference of any output, per case: rounding, far below the
# tolerance.

fig, ax = plt.subplots(figsize=(6, 3), layout="constrained")
ax.barh(list(largest), [max(value, 1e-17) for value in largest.values()])
ax.axvline(1e-6, color="tab:red", label="tolerance")
ax.set(xscale="log", xlabel="largest relative difference", title="my_skf against the cases")
ax.legend(loc="lower right")
ax.invert_yaxis()

# %%
# A classic mistake, named
# ------------------------
# The raw weights of §2.2 eq. (7) from the *updated* covariance ``P_{t|t}`` instead of the
# predicted ``P_{t|t-1}``: the numbers look plausible, and only a comparison finds it.
# ``compare`` tries every known mistake on the case and names the one that reproduces
# yours.

path = folder / "skf-cases" / "original_skf.npz"
mine = run_on_case(path, folder / "mistaken.npz", weights_from="updated")
print(skf_ref.compare(path, mine).report())
