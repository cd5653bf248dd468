"""
The SKF by hand, step by step
=============================

The worked example of :doc:`/model` §8 (two sources, three sensors, three steps), computed
here with nothing but numpy and scipy, one equation a line, then beside the package's three
paths. Every symbol is that of :doc:`/model`: ``P_pred`` is ``P_{t|t-1}``, ``x_filt`` is
``x_{t|t}``, ``w`` the raw weights ``w_t`` and ``z`` the standardized estimate ``z_{t|t}``.
"""

import matplotlib.pyplot as plt
import numpy as np
from scipy import linalg

import skf_ref

# %%
# The problem
# -----------
# Column 0 of the lead field is seen well by the sensors (a "superficial" source), column 1
# weakly (a "deep" one). The deep source is active alone at ``t = 1``, both at ``t = 2``,
# the superficial alone at ``t = 3``. The priors ``theta0 = q = 0.5`` make
# ``P_{1|0} = I``.

L = np.array([[3.0, 1.0], [2.0, 1.0], [0.0, 1.0]])
X_true = np.array([[0.0, 1.0, 1.0], [1.0, 1.0, 0.0]])
Y = L @ X_true  # noise free, to keep the numbers short; the model still assumes R = I
sigma, theta0, q, exponent = 1.0, 0.5, 0.5, 0.5
R, A, Q, P0 = sigma**2 * np.eye(3), np.eye(2), q * np.eye(2), theta0 * np.eye(2)
print("Y =\n", Y)


# %%
# The filter, one line per equation
# ---------------------------------
# Predict (§2.2 eq. 4), update (eq. 5), weights (eq. 7) and the standardized estimate
# (eq. 6). ``P^{-1/2}`` is the symmetric inverse square root, from ``eigh``; ``S_t`` is
# never inverted: Cholesky solves.


def inverse_sqrt(P):
    """The symmetric inverse square root of a positive definite matrix."""
    eigenvalues, vectors = linalg.eigh(P)
    return (vectors / np.sqrt(eigenvalues)) @ vectors.T


def skf_by_hand(L, Y, R, A, Q, P0, exponent):
    x, P = np.zeros(L.shape[1]), P0
    out = {key: [] for key in ("P_pred", "x_filt", "P_filt", "w", "z")}
    for y in Y.T:
        x_pred, P_pred = A @ x, A @ P @ A.T + Q  # predict
        S = L @ P_pred @ L.T + R  # update
        K = linalg.cho_solve(linalg.cho_factor(S), L @ P_pred).T  # P_pred L^T S^-1
        x = x_pred + K @ (y - L @ x_pred)
        P = P_pred - K @ S @ K.T
        P_pred_inv_sqrt = inverse_sqrt(P_pred)  # weights
        w = np.diag(P_pred_inv_sqrt @ K @ S @ K.T @ P_pred_inv_sqrt)
        z = w ** (-exponent) * (P_pred_inv_sqrt @ x)  # standardized estimate
        for key, value in zip(out, (P_pred, x, P, w, z), strict=True):
            out[key].append(value)
    return {key: np.array(value) for key, value in out.items()}  # time-major


hand = skf_by_hand(L, Y, R, A, Q, P0, exponent)
for t in range(3):
    print(f"t = {t + 1}: x_t|t = {hand['x_filt'][t].round(4)}, w_t = {hand['w'][t].round(4)},")
    print(f"        z_t|t = {hand['z'][t].round(4)}")

# %%
# At ``t = 1`` the plain estimate ``x_{1|1}`` gives the active deep source 0.55 and the idle
# superficial one 0.16; the standardization raises the deep one more (its raw weight is the
# smaller, 0.55 against 0.87, because the sensors see it less). With ``P_{1|0} = I`` step 1
# is sLORETA (:doc:`/model` §2): ``z_i = x_i / sqrt([P L^T S^-1 L P]_ii)``.

S1 = L @ L.T + R
resolution = np.diag(L.T @ linalg.solve(S1, L, assume_a="pos"))
print("sLORETA at t = 1:", (hand["x_filt"][0] / np.sqrt(resolution)).round(4))

# %%
# The paper's smoother, by hand
# -----------------------------
# ``"rts-standardized"`` runs the RTS recursion (§2.3 eq. 4) backwards over the
# standardized sequence, with the gains ``G_t = P_{t|t} A^T P_{t+1|t}^{-1}`` of the filter
# (:doc:`/model` §3).

s = hand["z"].copy()
for t in range(Y.shape[1] - 2, -1, -1):
    G = linalg.solve(hand["P_pred"][t + 1], A @ hand["P_filt"][t], assume_a="pos").T
    s[t] = hand["z"][t] + G @ (s[t + 1] - A @ hand["z"][t])
print("rts-standardized:\n", s.round(4))

# %%
# Beside the package
# ------------------
# :func:`skf_ref.reconstruct` returns (n_sources, n_times) arrays, hence the transposes.
# All three paths agree with the lines above to rounding.

setting = dict(noise_std=sigma, theta0=theta0, q=q, exponent=exponent)
for method in ("dense", "filterpy", "spectral"):
    rec = skf_ref.reconstruct(L, Y, **setting, path=method)
    smoothed = skf_ref.reconstruct(L, Y, **setting, path=method, smoother="rts-standardized")
    difference = max(np.abs(rec.z.T - hand["z"]).max(), np.abs(smoothed.z.T - s).max())
    print(f"{method:8s} largest difference from the lines above: {difference:.1e}")

# %%
# The filtered and the smoothed estimate of both sources, by hand (markers) and by the
# package (lines):

fig, ax = plt.subplots(figsize=(6, 3.2), layout="constrained")
steps = np.arange(1, 4)
for k, (name, colour) in enumerate((("superficial", "tab:red"), ("deep", "tab:green"))):
    ax.plot(steps, rec.z[k], "-", color=colour, label=f"{name}, filtered (package)")
    ax.plot(steps, hand["z"][:, k], "o", color=colour)
    ax.plot(steps, smoothed.z[k], "--", color=colour, label=f"{name}, rts-standardized")
    ax.plot(steps, s[:, k], "s", color=colour, mfc="none")
ax.set(xlabel="step t", ylabel="z", xticks=steps, title="Markers: by hand; lines: skf_ref")
ax.legend(fontsize="small")
