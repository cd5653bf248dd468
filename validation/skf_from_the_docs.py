"""An SKF written from docs/model.md alone, one method per equation: the mistakes' template.

Nothing here uses ``skf_ref``'s computations. :class:`SKF` states the filter of docs/model.md
§2 (with "Standardizing a position as a whole"), the smoothers of §3 (with "A smoother
standardized by its own variance") and the priors of §4, each equation in a method of its
own, so that a mistaken SKF (validation/skf_mistaken.py) is this one with one method
replaced. It returns the six outputs and every intermediate quantity of docs/conformance.md
("Intermediate outputs"), with time on the last axis, in the precision ``dtype``.
"""

import numpy as np

OUTPUTS = ("z", "z_filtered", "x", "x_filtered", "weights", "log_likelihood")


def symmetric_power(M, power):
    """``M ** power`` of a symmetric positive definite matrix, through ``eigh``."""
    values, vectors = np.linalg.eigh((M + M.T) / 2)
    return (vectors * values**power) @ vectors.T


class SKF:
    """The SKF of docs/model.md, one equation a method; call it on the case's matrices.

    Attributes
    ----------
    quantity : str or None
        For a mistaken SKF, the quantity of docs/conformance.md its mistake changes first
        (declared with the mistake, before any comparison).
    """

    quantity = None

    def __init__(self, dtype=np.float64):
        self.dtype = dtype

    # --- §4: the priors ------------------------------------------------------------------

    def priors(self, L, noise_std, pm_snr_db, ep_snr_db, n_times, convention):
        """theta0 and q from the SNRs (docs/model.md §4), with the toolbox's clamp."""
        norms = np.linalg.norm(L, axis=0)
        if convention == "gain":
            amplitude = np.sqrt(L.shape[0]) / np.sqrt(np.mean(norms**2))
        else:
            amplitude = np.mean(norms**-0.5)
            pm_snr_db = min(pm_snr_db, -20 * np.log10(noise_std) - 1)
        theta0 = 10 ** (pm_snr_db / 10) * noise_std**2 * amplitude**2 / L.shape[1]
        return theta0, self.evolution(theta0, ep_snr_db, n_times)

    def evolution(self, theta0, ep_snr_db, n_times):
        """q = kappa**2 theta0 / K with kappa**2 = 10**(EP/10) (§3.1 eqs. (9)-(10))."""
        return 10 ** (ep_snr_db / 10) * theta0 / n_times

    # --- §2: the filter --------------------------------------------------------------------

    def initial_state(self, L, Y):
        """x_{0|0} = 0."""
        return np.zeros(L.shape[1], self.dtype)

    def predict(self, x, P, A, Q):
        """§2.2 eq. (4)."""
        return A @ x, A @ P @ A.T + Q

    def innovation_covariance(self, P_pred, P_prev, L, R):
        """S_t = L P_{t|t-1} L^T + R."""
        return L @ P_pred @ L.T + R

    def gain(self, P_pred, P_prev, S, L, R):
        """K_t = P_{t|t-1} L^T S_t^{-1}, by a solve."""
        return np.linalg.solve(S, L @ P_pred).T

    def data(self, Y, t):
        """y_t."""
        return Y[:, t]

    def update_state(self, x_pred, x_prev, K, y, L):
        """x_{t|t} = x_{t|t-1} + K_t (y_t - L x_{t|t-1})."""
        return x_pred + K @ (y - L @ x_pred)

    def update_covariance(self, P_pred, K, S, L, R):
        """P_{t|t} = P_{t|t-1} - K_t S_t K_t^T."""
        return P_pred - K @ S @ K.T

    def whitening(self, P_pred):
        """P_{t|t-1}^{-1/2}, symmetric."""
        return symmetric_power(P_pred, -0.5)

    def psi(self, whitening, P_pred, P, K, S, L):
        """P_{t|t-1}^{-1/2} K_t S_t K_t^T P_{t|t-1}^{-1/2}, whose diagonal is w_t (eq. (7))."""
        return whitening @ K @ S @ K.T @ whitening

    def raw_weights(self, Psi, P_pred, P):
        """w_t = diag(Psi_t)."""
        return np.diag(Psi).copy()

    def weight_matrix(self, w, Psi, exponent, blocks):
        """W_t^(alpha): Diag(w_t ** -alpha), or the blocks' powers (position)."""
        if blocks is None:
            return np.diag(w**-exponent)
        W = np.zeros_like(Psi)
        for c in blocks:
            W[np.ix_(c, c)] = symmetric_power(Psi[np.ix_(c, c)], -exponent)
        return W

    def standardized(self, W, whitening, x, x_pred):
        """§2.2 eq. (6): z_{t|t} = W_t^(alpha) P_{t|t-1}^{-1/2} x_{t|t}."""
        return W @ (whitening @ x)

    def log_likelihood(self, y, L, x_pred, x, S):
        """log N(y_t - L x_{t|t-1}; 0, S_t)."""
        e = y - L @ x_pred
        log_det = np.linalg.slogdet(S)[1]
        return -0.5 * (len(y) * np.log(2 * np.pi) + log_det + e @ np.linalg.solve(S, e))

    # --- §3: the smoothers -----------------------------------------------------------------

    def backward_steps(self, T):
        """t = T - 1, ..., 1 (counting from 0 here)."""
        return range(T - 2, -1, -1)

    def smoother_gain(self, P_filt, P_pred, A, t):
        """G_t = P_{t|t} A^T P_{t+1|t}^{-1}."""
        return np.linalg.solve(P_pred[t + 1], A @ P_filt[t]).T

    def smooth_step(self, m, s_next, G, A):
        """s_t = m_t + G_t (s_{t+1} - A m_t)."""
        return m + G @ (s_next - A @ m)

    def smooth_covariance(self, P_filt, P_next_smooth, P_pred_next, G):
        """P^s_t = P_{t|t} + G_t (P^s_{t+1} - P_{t+1|t}) G_t^T."""
        return P_filt + G @ (P_next_smooth - P_pred_next) @ G.T

    def restandardized(self, keep, x_s, t):
        """z^s_t = W_t^(alpha) P_{t|t-1}^{-1/2} x^s_t ("rts-state")."""
        return keep["W"][t] @ keep["whitening"][t] @ x_s[t]

    def prior_covariances(self, P0, A, Q, T):
        """Sigma_t = A Sigma_{t-1} A^T + Q, Sigma_0 = P_0, for t = 1, ..., T."""
        Sigma, found = P0, []
        for _ in range(T):
            Sigma = A @ Sigma @ A.T + Q
            found.append(Sigma)
        return found

    def smoothed_psi(self, Sigma, P_smooth):
        """Sigma_t^{-1/2} (Sigma_t - P^s_t) Sigma_t^{-1/2}; its diagonal is w^s_t."""
        root = symmetric_power(Sigma, -0.5)
        return root, root @ (Sigma - P_smooth) @ root

    # --- the loops -------------------------------------------------------------------------

    def __call__(self, L, Y, R, A, Q, P0, exponent, smoother, standardize="column", n_orient=1):
        """Outputs and intermediates, each (..., n_times), on one case's matrices."""
        dt = self.dtype
        L, Y, R, A, Q, P0 = (np.asarray(v, dtype=dt) for v in (L, Y, R, A, Q, P0))
        exponent = dt(exponent)
        n = L.shape[1]
        blocks = None
        if standardize == "position":
            blocks = [list(range(i, i + n_orient)) for i in range(0, n, n_orient)]
        keep = self.filter(L, Y, R, A, Q, P0, exponent, blocks)
        out = {
            "z_filtered": keep["z"],
            "x_filtered": keep["x"],
            "weights": [np.diag(W) for W in keep["W"]],
            "x_pred": keep["x_pred"],
            "P_pred": keep["P_pred"],
            "S": keep["S"],
            "K": keep["K"],
            "P_filt": keep["P"],
            "w": keep["w"],
        }
        out["x"], out["z"] = keep["x"], keep["z"]
        if smoother not in (None, "none"):
            out |= self.smooth(keep, smoother, P0, A, Q, exponent, blocks)
        found = {k: np.moveaxis(np.array(v), 0, -1) for k, v in out.items()}
        return found | {"log_likelihood": keep["log_likelihood"]}

    def filter(self, L, Y, R, A, Q, P0, exponent, blocks):
        """The forward pass; every quantity kept, time-major."""
        names = ("x_pred", "P_pred", "S", "K", "x", "P", "w", "W", "whitening", "z")
        keep = {key: [] for key in names}
        x, P, total = self.initial_state(L, Y), P0, 0.0
        for t in range(Y.shape[1]):
            x_prev, P_prev = x, P
            x_pred, P_pred = self.predict(x, P, A, Q)
            S = self.innovation_covariance(P_pred, P_prev, L, R)
            K = self.gain(P_pred, P_prev, S, L, R)
            y = self.data(Y, t)
            x = self.update_state(x_pred, x_prev, K, y, L)
            P = self.update_covariance(P_pred, K, S, L, R)
            whitening = self.whitening(P_pred)
            Psi = self.psi(whitening, P_pred, P, K, S, L)
            w = self.raw_weights(Psi, P_pred, P)
            W = self.weight_matrix(w, Psi, exponent, blocks)
            z = self.standardized(W, whitening, x, x_pred)
            total += self.log_likelihood(y, L, x_pred, x, S)
            step = dict(x_pred=x_pred, P_pred=P_pred, S=S, K=K, x=x, P=P, w=w, W=W, z=z)
            for key, value in (step | {"whitening": whitening}).items():
                keep[key].append(value)
        keep["log_likelihood"] = float(total)
        return keep

    def smooth(self, keep, smoother, P0, A, Q, exponent, blocks):
        """The backward pass of §2.3 eq. (4) and what the smoother outputs."""
        P_filt, P_pred = keep["P"], keep["P_pred"]
        T = len(P_filt)
        G = [None] * (T - 1)
        P_s = list(P_filt)
        for t in self.backward_steps(T):
            G[t] = self.smoother_gain(P_filt, P_pred, A, t)
            P_s[t] = self.smooth_covariance(P_filt[t], P_s[t + 1], P_pred[t + 1], G[t])
        means = keep["z"] if smoother == "rts-standardized" else keep["x"]
        s = list(means)
        for t in self.backward_steps(T):
            s[t] = self.smooth_step(means[t], s[t + 1], G[t], A)
        G = [np.zeros_like(P0) if g is None else g for g in G]  # as preallocated
        out = {"G": G, "P_smooth": P_s}
        if smoother == "rts-standardized":
            return out | {"z": s}
        out["x"] = s
        if smoother == "rts-state":
            return out | {"z": [self.restandardized(keep, s, t) for t in range(T)]}
        Sigma = self.prior_covariances(P0, A, Q, T)
        z, w_s = [], []
        for t in range(T):
            root, Psi = self.smoothed_psi(Sigma[t], P_s[t])
            w_s.append(np.diag(Psi).copy())
            z.append(self.weight_matrix(w_s[-1], Psi, exponent, blocks) @ root @ s[t])
        return out | {"z": z, "Sigma": Sigma, "w_smooth": w_s}


def case_matrices(case, skf):
    """The case's inputs as the runner makes them; the priors from the SNRs when it has them.

    Returns the keyword arguments of :meth:`SKF.__call__` and the priors used.
    """
    p, e = case.inputs, case.extras
    L = np.asarray(p["L"])
    m, n = L.shape

    def full(value, k):
        return value * np.eye(k) if np.ndim(value) == 0 else np.asarray(value)

    theta0, q = p["theta0"], p["q"]
    if "ep_snr_db" in e:  # an implementation that computes its own priors (the random walk's)
        theta0, q = skf.priors(
            L, e["noise_std"], e["pm_snr_db"], e["ep_snr_db"], case.shape[1], e["convention"]
        )
    arguments = dict(
        L=L,
        Y=p["Y"],
        R=full(p["noise_cov"], m),
        A=full(p["transition"], n),
        Q=full(q, n),
        P0=full(theta0, n),
        exponent=p["exponent"],
        smoother=p["smoother"],
        standardize=p.get("standardize", "column"),
        n_orient=int(p.get("n_orient", 1)),
    )
    return arguments, {"theta0": theta0, "q": q}


def run_case(case, skf):
    """``skf`` on a case: its outputs and intermediates (the priors it used included)."""
    arguments, priors = case_matrices(case, skf)
    return skf(**arguments) | priors
