"""An SKF written from docs/model.md alone, as another lab would write it: the tests' outsider.

Nothing here comes from ``skf_ref``'s computations: plain numpy in one loop, with every
catalogued mistake (``skf_ref.conformance._mistakes``) available as a switch, so that the
tests can show that an implementation making a mistake fails a case and hears its name,
and with a ``dtype`` switch, so that they can show what a single-precision implementation
is told. ``run_case`` applies it to a conformance case the way docs/conformance.md tells a
user to (a scalar ``noise_cov``, ``theta0``, ``q`` or ``transition`` is that number times
the identity).
"""

import numpy as np

from skf_ref import ar1_priors, priors_from_snr

OUTPUTS = ("z", "z_filtered", "x", "x_filtered", "weights", "log_likelihood")
_POSTERIOR = (
    "posterior_in_weights",
    "posterior_in_whitening",
    "posterior_in_both",
    "posterior_weights_toolbox_form",
    "standardized_after_update",
)


def _sqrt_and_inverse(P):
    """``P^{1/2}`` and ``P^{-1/2}``, symmetric (docs/model.md §2, "The inverse square root")."""
    values, vectors = np.linalg.eigh(P)
    values = np.clip(values, 0, None)
    with np.errstate(divide="ignore", invalid="ignore"):
        return (vectors * np.sqrt(values)) @ vectors.T, (vectors / np.sqrt(values)) @ vectors.T


def _diag_quadratic(M, S):
    """``diag(M S M^T)``."""
    return np.einsum("ij,jk,ik->i", M, S, M)


def _weight_matrix(Psi, alpha, n_orient):
    """``W = blockdiag_i B_i ** -alpha``, ``B_i`` the ``n_orient`` x ``n_orient`` diagonal
    blocks of ``Psi`` (1 x 1: ``Diag(diag(Psi) ** -alpha)``), powers by eigh."""
    W = np.zeros_like(Psi)
    for i in range(0, len(Psi), n_orient):
        values, vectors = np.linalg.eigh(Psi[i : i + n_orient, i : i + n_orient])
        W[i : i + n_orient, i : i + n_orient] = (vectors * values**-alpha) @ vectors.T
    return W


def skf(
    L, Y, R, A, Q, P0, exponent, smoother, standardize="column", n_orient=1, *,
    mistake=None, dtype=np.float64,
):  # fmt: skip
    """The SKF of docs/model.md §2-§3; ``mistake`` names a catalogued mistake to make.

    Returns a dict of the six outputs, arrays (n_sources, n_times), in ``dtype``.
    """
    L, Y, R, A, Q, P0 = (np.asarray(v, dtype=dtype) for v in (L, Y, R, A, Q, P0))
    smoother = None if smoother == "none" else smoother
    alpha = {"exponent_fixed_at_half": 0.5, "exponent_dropped": 1.0}.get(mistake, exponent)
    alpha = dtype(alpha)
    if mistake == "transition_ignored":
        A = np.eye(len(A), dtype=dtype)
    if mistake == "extra_first_prediction":
        P0 = A @ P0 @ A.T + Q
    m, n, T = *L.shape, Y.shape[1]
    block = int(n_orient) if standardize == "position" else 1
    x, P, log_likelihood = np.zeros(n, dtype), P0, dtype(0)
    keep = {key: [] for key in ("x", "P", "P_pred", "whitening", "W", "weights", "z")}
    for t in range(T):
        if t == 0 and mistake == "no_first_prediction":
            x_pred, P_pred = x, P
        else:
            x_pred, P_pred = A @ x, A @ P @ A.T + Q
        S = L @ P_pred @ L.T + R
        K = np.linalg.solve(S, L @ P_pred).T
        e = Y[:, t] - L @ x_pred
        x = x_pred + K @ e
        P = P_pred - K @ S @ K.T
        log_likelihood += -0.5 * (
            m * np.log(dtype(2 * np.pi)) + np.linalg.slogdet(S)[1] + e @ np.linalg.solve(S, e)
        )
        _, whitening = _sqrt_and_inverse(P_pred)
        w = _diag_quadratic(whitening @ K, S)
        if mistake in _POSTERIOR:
            root_post, whitening_post = _sqrt_and_inverse(P)
        if mistake in ("posterior_in_weights", "posterior_in_both"):
            w = _diag_quadratic(whitening_post @ K, S)
        if mistake in ("posterior_weights_toolbox_form", "standardized_after_update"):
            B = L @ root_post  # diag(B' (B B' + R)^-1 B) with P_{t|t}
            w = np.einsum("ji,ji->i", B, np.linalg.solve(B @ B.T + R, B))
        if mistake in ("posterior_in_whitening", "posterior_in_both", "standardized_after_update"):
            whitening = whitening_post
        if mistake == "exponent_on_square_root":
            w = np.sqrt(w)
        if block > 1:  # the blocks of Psi_t = whitening K S K^T whitening
            W = _weight_matrix(whitening @ K @ S @ K.T @ whitening, alpha, block)
        else:
            W = np.diag(w**-alpha)
        z = W @ (whitening @ x)
        step = dict(x=x, P=P, P_pred=P_pred, whitening=whitening, W=W, weights=np.diag(W), z=z)
        for key, value in step.items():
            keep[key].append(value)
    x_filtered, z_filtered = np.array(keep["x"]), np.array(keep["z"])
    smoother = (
        {"rts-state": "rts-standardized", "rts-standardized": "rts-state"}.get(smoother, smoother)
        if mistake == "other_smoother"
        else smoother
    )
    x_out, z_out = x_filtered, z_filtered
    if smoother is not None:
        sequence = z_filtered if smoother == "rts-standardized" else x_filtered
        s, P_s = sequence.copy(), list(keep["P"])
        for t in range(T - 2, -1, -1):
            G = keep["P"][t] @ A.T @ np.linalg.inv(keep["P_pred"][t + 1])
            s[t] = sequence[t] + G @ (s[t + 1] - A @ sequence[t])
            P_s[t] = keep["P"][t] + G @ (P_s[t + 1] - keep["P_pred"][t + 1]) @ G.T
        if smoother == "rts-standardized":
            z_out = s
        elif smoother == "rts-state":
            x_out = s
            z_out = np.einsum("tij,tjk,tk->ti", keep["W"], keep["whitening"], s)
        else:  # over its own variance: Sigma_t = A Sigma_{t-1} A^T + Q, Sigma_0 = P_0
            x_out, z_out, Sigma = s, np.empty_like(s), P0
            for t in range(T):
                Sigma = A @ Sigma @ A.T + Q
                _, root = _sqrt_and_inverse(Sigma)
                W = _weight_matrix(root @ (Sigma - P_s[t]) @ root, alpha, block)
                z_out[t] = W @ root @ s[t]
    outputs = dict(
        z=z_out.T,
        z_filtered=z_filtered.T,
        x=x_out.T,
        x_filtered=x_filtered.T,
        weights=np.array(keep["weights"]).T,
        log_likelihood=log_likelihood,
    )
    if mistake == "transposed":
        outputs = {key: np.transpose(value) for key, value in outputs.items()}
    return outputs


def run_case(case, *, mistake=None, dtype=np.float64):
    """Run :func:`skf` on a conformance case as docs/conformance.md describes.

    The mistakes about the inputs happen here: the other prior convention, the lead field
    without its average reference, the noise standard deviation and variance confused.
    Returns None when the mistake cannot happen in this case.
    """
    p = dict(case.inputs)
    L, m, n = p["L"], *p["L"].shape
    c = p["noise_cov"]
    if mistake in ("noise_std_as_variance", "noise_variance_as_std"):
        if np.ndim(c) or c == 1:
            return None
        c = np.sqrt(c) if mistake == "noise_std_as_variance" else c**2
    R = c * np.eye(m) if np.ndim(c) == 0 else c
    A, Q, P0 = (
        p[k] * np.eye(n) if np.ndim(p[k]) == 0 else p[k] for k in ("transition", "q", "theta0")
    )
    if mistake == "other_convention":
        e = case.extras
        if "convention" not in e:
            return None
        other = "toolbox" if e["convention"] == "gain" else "gain"
        if "time_constant_ms" in e:  # the stationary AR(1) prior
            theta0, q, _ = ar1_priors(
                L, e["noise_std"], e["pm_snr_db"], e["time_constant_ms"], e["sfreq"], other
            )
        else:
            theta0, q = priors_from_snr(
                L, e["noise_std"], e["pm_snr_db"], e["ep_snr_db"], case.shape[1], other
            )
        Q, P0 = q * np.eye(n), theta0 * np.eye(n)
    if mistake == "missing_average_reference":
        if "L_unreferenced" not in case.extras:
            return None
        L = case.extras["L_unreferenced"]
    by_position = p.get("standardize", "column") == "position"
    # the stationary AR(1) prior: P_{1|0} = P_0, one prediction more or less cannot show
    stationary = np.allclose(A @ P0 @ A.T + Q, P0, rtol=1e-12, atol=0.0)
    inapplicable = {
        # mistakes of the standardization of each column on its own (the catalogue's)
        **dict.fromkeys((*_POSTERIOR, "exponent_on_square_root"), by_position),
        "no_first_prediction": by_position or stationary,
        "extra_first_prediction": stationary,
        "other_smoother": p["smoother"] in (None, "rts-smoothed-weights"),
        "transition_ignored": np.array_equal(A, np.eye(n)),
        "exponent_fixed_at_half": p["exponent"] == 0.5,
        "exponent_dropped": p["exponent"] == 1,
    }
    if inapplicable.get(mistake, False):
        return None
    options = (p.get("standardize", "column"), p.get("n_orient", 1))
    return skf(
        L, p["Y"], R, A, Q, P0, p["exponent"], p["smoother"], *options, mistake=mistake,
        dtype=dtype,
    )  # fmt: skip
