"""Three correct SKFs, each written from docs/model.md alone and in a style of its own.

- :func:`joseph`: numpy, the covariance update in Joseph's form
  ``(I - K L) P (I - K L)^T + K R K^T``, the weights by the identity
  ``w_t = diag(B^T S_t^{-1} B)`` with ``B = L P_{t|t-1}^{1/2}`` (docs/model.md §2);
- :func:`one_based`: a MATLAB-style loop, every index counting from 1 (column 1 of each
  array is ``t = 0``), the weights summed entry by entry;
- :func:`information`: the information form: ``P_{t|t}^{-1} = P_{t|t-1}^{-1} + L^T R^{-1} L``,
  the gain ``K_t = P_{t|t} L^T R^{-1}``, the whitening ``P_{t|t-1}^{-1/2}`` as the square
  root of the information matrix, every inverse by a Cholesky solve.

Each takes the runner's matrices (``L, Y, R, A, Q, P0, exponent, smoother``, and
``standardize``, ``n_orient``), computes in ``dtype``, and returns the six outputs and every
intermediate of docs/conformance.md with time on the last axis. They must agree with every
case, and with one another (validation/conformance_mistakes.py checks it).
"""

import numpy as np
from scipy import linalg


def _power(M, p):
    values, vectors = np.linalg.eigh((M + M.T) / 2)
    return (vectors * values**p) @ vectors.T


def _blocks(n, standardize, n_orient):
    if standardize != "position":
        return None
    return [slice(i, i + n_orient) for i in range(0, n, n_orient)]


def _weight_matrix(Psi, exponent, blocks):
    if blocks is None:
        return np.diag(np.diag(Psi) ** -exponent)
    W = np.zeros_like(Psi)
    for b in blocks:
        W[b, b] = _power(Psi[b, b], -exponent)
    return W


def _time_last(found):
    return {k: v if np.ndim(v) == 0 else np.moveaxis(np.array(v), 0, -1) for k, v in found.items()}


def joseph(L, Y, R, A, Q, P0, exponent, smoother, standardize="column", n_orient=1, dtype=float):
    """Numpy, Joseph's form, the weights as diag(B^T S^{-1} B)."""
    L, Y, R, A, Q, P0 = (np.asarray(v, dtype=dtype) for v in (L, Y, R, A, Q, P0))
    m, n = L.shape
    blocks = _blocks(n, standardize, n_orient)
    identity = np.eye(n, dtype=dtype)
    x, P, ll = np.zeros(n, dtype), P0, 0.0
    keep = {k: [] for k in ("x_pred", "P_pred", "S", "K", "x_filtered", "P_filt", "w")}
    keep |= {"weights": [], "z_filtered": [], "Wh": []}
    for y in Y.T:
        x_pred, P_pred = A @ x, A @ P @ A.T + Q
        S = L @ P_pred @ L.T + R
        K = linalg.solve(S, L @ P_pred, assume_a="pos").T
        e = y - L @ x_pred
        x = x_pred + K @ e
        IKL = identity - K @ L
        P = IKL @ P_pred @ IKL.T + K @ R @ K.T
        B = L @ _power(P_pred, 0.5)
        Psi = B.T @ linalg.solve(S, B, assume_a="pos")
        Wm = _weight_matrix(Psi, dtype(exponent), blocks)
        Wh = Wm @ _power(P_pred, -0.5)
        ll -= 0.5 * (m * np.log(2 * np.pi) + np.linalg.slogdet(S)[1] + e @ linalg.solve(S, e))
        step = dict(x_pred=x_pred, P_pred=P_pred, S=S, K=K, x_filtered=x, P_filt=P)
        step |= dict(w=np.diag(Psi), weights=np.diag(Wm))
        step |= dict(z_filtered=Wh @ x, Wh=Wh)
        for k, v in step.items():
            keep[k].append(v)
    Wh = keep.pop("Wh")
    out = dict(keep, x=keep["x_filtered"], z=keep["z_filtered"], log_likelihood=ll)
    if smoother not in (None, "none"):
        T = Y.shape[1]
        Pf, Pp = keep["P_filt"], keep["P_pred"]
        G = [linalg.solve(Pp[t + 1], A @ Pf[t], assume_a="pos").T for t in range(T - 1)]
        Ps, means = (
            list(Pf),
            keep["z_filtered" if smoother == "rts-standardized" else "x_filtered"],
        )
        s = list(means)
        for t in range(T - 2, -1, -1):
            s[t] = means[t] + G[t] @ (s[t + 1] - A @ means[t])
            Ps[t] = Pf[t] + G[t] @ (Ps[t + 1] - Pp[t + 1]) @ G[t].T
        out |= {"G": G, "P_smooth": Ps}
        if smoother == "rts-standardized":
            out["z"] = s
        elif smoother == "rts-state":
            out |= {"x": s, "z": [Wh[t] @ s[t] for t in range(T)]}
        else:
            Sigma, Sig = [], P0
            for _ in range(T):
                Sig = A @ Sig @ A.T + Q
                Sigma.append(Sig)
            psis = [
                _power(Sg, -0.5) @ (Sg - Pst) @ _power(Sg, -0.5)
                for Sg, Pst in zip(Sigma, Ps, strict=True)
            ]
            z = [
                _weight_matrix(psi, dtype(exponent), blocks) @ _power(Sg, -0.5) @ st
                for psi, Sg, st in zip(psis, Sigma, s, strict=True)
            ]
            out |= {"x": s, "z": z, "Sigma": Sigma, "w_smooth": [np.diag(p) for p in psis]}
    return _time_last(out)


def one_based(
    L, Y, R, A, Q, P0, exponent, smoother, standardize="column", n_orient=1, dtype=float
):
    """A MATLAB-style loop: x(:, 1) is x_{0|0}, x(:, t + 1) is x_{t|t}."""
    L, Y, R, A, Q, P0 = (np.asarray(v, dtype=dtype) for v in (L, Y, R, A, Q, P0))
    m, n = L.shape
    T = Y.shape[1]
    alpha = dtype(exponent)
    xf = np.zeros((n, T + 1), dtype)
    Pf = np.zeros((n, n, T + 1), dtype)
    Pf[:, :, 0] = P0
    xp, Pp = np.zeros((n, T + 1), dtype), np.zeros((n, n, T + 1), dtype)
    Sx, Kx = np.zeros((m, m, T + 1), dtype), np.zeros((n, m, T + 1), dtype)
    w = np.zeros((n, T + 1), dtype)
    Wt, Mt = np.zeros((n, n, T + 1), dtype), np.zeros((n, n, T + 1), dtype)
    zf = np.zeros((n, T + 1), dtype)
    ll = 0.0
    blocks = _blocks(n, standardize, n_orient)
    for t in range(1, T + 1):
        xp[:, t] = A @ xf[:, t - 1]
        Pp[:, :, t] = A @ Pf[:, :, t - 1] @ A.T + Q
        Sx[:, :, t] = L @ Pp[:, :, t] @ L.T + R
        Kx[:, :, t] = Pp[:, :, t] @ L.T @ linalg.inv(Sx[:, :, t])
        e = Y[:, t - 1] - L @ xp[:, t]
        xf[:, t] = xp[:, t] + Kx[:, :, t] @ e
        Pf[:, :, t] = Pp[:, :, t] - Kx[:, :, t] @ Sx[:, :, t] @ Kx[:, :, t].T
        Mt[:, :, t] = _power(Pp[:, :, t], -0.5)
        C = Mt[:, :, t] @ Kx[:, :, t]
        for i in range(n):  # w(i) = sum_j sum_k C(i, j) S(j, k) C(i, k)
            w[i, t] = sum(C[i, j] * Sx[j, k, t] * C[i, k] for j in range(m) for k in range(m))
        Psi = C @ Sx[:, :, t] @ C.T
        if blocks is not None:
            Wt[:, :, t] = _weight_matrix(Psi, alpha, blocks)
        else:
            Wt[:, :, t] = np.diag(w[:, t] ** -alpha)
        zf[:, t] = Wt[:, :, t] @ Mt[:, :, t] @ xf[:, t]
        sign, logdet = np.linalg.slogdet(Sx[:, :, t])
        ll = ll - (m * np.log(2 * np.pi) + logdet + e @ linalg.inv(Sx[:, :, t]) @ e) / 2
    out = dict(
        x_pred=xp[:, 1:],
        P_pred=Pp[:, :, 1:],
        S=Sx[:, :, 1:],
        K=Kx[:, :, 1:],
        x_filtered=xf[:, 1:],
        P_filt=Pf[:, :, 1:],
        w=w[:, 1:],
        weights=np.array([np.diag(Wt[:, :, t]) for t in range(1, T + 1)]).T,
        z_filtered=zf[:, 1:],
        log_likelihood=ll,
    )
    out["x"], out["z"] = out["x_filtered"], out["z_filtered"]
    if smoother in (None, "none"):
        return out
    G = np.zeros((n, n, T), dtype)  # G(:, :, t) for t = 1 .. T - 1
    Ps = Pf.copy()
    m_ = zf if smoother == "rts-standardized" else xf
    s = m_.copy()
    for t in range(T - 1, 0, -1):
        G[:, :, t] = Pf[:, :, t] @ A.T @ linalg.inv(Pp[:, :, t + 1])
        s[:, t] = m_[:, t] + G[:, :, t] @ (s[:, t + 1] - A @ m_[:, t])
        Ps[:, :, t] = Pf[:, :, t] + G[:, :, t] @ (Ps[:, :, t + 1] - Pp[:, :, t + 1]) @ G[:, :, t].T
    out |= {"G": G[:, :, 1:T], "P_smooth": Ps[:, :, 1:]}
    if smoother == "rts-standardized":
        out["z"] = s[:, 1:]
        return out
    out["x"] = s[:, 1:]
    if smoother == "rts-state":
        out["z"] = np.stack([Wt[:, :, t] @ Mt[:, :, t] @ s[:, t] for t in range(1, T + 1)], 1)
        return out
    Sg = np.zeros((n, n, T + 1), dtype)
    Sg[:, :, 0] = P0
    ws, zs = np.zeros((n, T + 1), dtype), np.zeros((n, T + 1), dtype)
    for t in range(1, T + 1):
        Sg[:, :, t] = A @ Sg[:, :, t - 1] @ A.T + Q
        root = _power(Sg[:, :, t], -0.5)
        Psi = root @ (Sg[:, :, t] - Ps[:, :, t]) @ root
        ws[:, t] = np.diag(Psi)
        zs[:, t] = _weight_matrix(Psi, alpha, blocks) @ root @ s[:, t]
    out |= {"z": zs[:, 1:], "Sigma": Sg[:, :, 1:], "w_smooth": ws[:, 1:]}
    return out


def _cho_inv(M):
    factor = linalg.cho_factor(M, lower=True)
    return linalg.cho_solve(factor, np.eye(len(M), dtype=M.dtype))


def information(
    L, Y, R, A, Q, P0, exponent, smoother, standardize="column", n_orient=1, dtype=float
):
    """The information form: P_{t|t}^{-1} = P_{t|t-1}^{-1} + L^T R^{-1} L."""
    L, Y, R, A, Q, P0 = (np.asarray(v, dtype=dtype) for v in (L, Y, R, A, Q, P0))
    m, n = L.shape
    R_inv = _cho_inv(R)
    LtRL = L.T @ R_inv @ L
    blocks = _blocks(n, standardize, n_orient)
    x, P, ll = np.zeros(n, dtype), P0, 0.0
    keep = {k: [] for k in ("x_pred", "P_pred", "S", "K", "x_filtered", "P_filt", "w")}
    keep |= {"weights": [], "z_filtered": [], "white": [], "Wm": []}
    for y in Y.T:
        x_pred, P_pred = A @ x, A @ P @ A.T + Q
        info_pred = _cho_inv(P_pred)
        P = _cho_inv(info_pred + LtRL)
        K = P @ L.T @ R_inv
        e = y - L @ x_pred
        x = x_pred + K @ e
        S = L @ P_pred @ L.T + R
        white = _power(info_pred, 0.5)  # (P^{-1})^{1/2} = P^{-1/2}
        Psi = white @ (P_pred - P) @ white
        Wm = _weight_matrix(Psi, dtype(exponent), blocks)
        chol = linalg.cholesky(S, lower=True)
        v = linalg.solve_triangular(chol, e, lower=True)
        ll -= 0.5 * (m * np.log(2 * np.pi) + 2 * np.sum(np.log(np.diag(chol))) + v @ v)
        step = dict(x_pred=x_pred, P_pred=P_pred, S=S, K=K, x_filtered=x, P_filt=P)
        step |= dict(w=np.diag(Psi), weights=np.diag(Wm), z_filtered=Wm @ white @ x)
        for k, val in (step | dict(white=white, Wm=Wm)).items():
            keep[k].append(val)
    white, Wm = keep.pop("white"), keep.pop("Wm")
    out = dict(keep, x=keep["x_filtered"], z=keep["z_filtered"], log_likelihood=ll)
    if smoother not in (None, "none"):
        T = Y.shape[1]
        Pf, Pp = keep["P_filt"], keep["P_pred"]
        G = [Pf[t] @ A.T @ _cho_inv(Pp[t + 1]) for t in range(T - 1)]
        means = keep["z_filtered" if smoother == "rts-standardized" else "x_filtered"]
        s, Ps = list(means), list(Pf)
        for t in reversed(range(T - 1)):
            s[t] = means[t] + G[t] @ (s[t + 1] - A @ means[t])
            Ps[t] = Pf[t] + G[t] @ (Ps[t + 1] - Pp[t + 1]) @ G[t].T
        out |= {"G": G, "P_smooth": Ps}
        if smoother == "rts-standardized":
            out["z"] = s
        elif smoother == "rts-state":
            out |= {"x": s, "z": [Wm[t] @ white[t] @ s[t] for t in range(T)]}
        else:
            Sigma, Sg, ws, zs = [], P0, [], []
            for t in range(T):
                Sg = A @ Sg @ A.T + Q
                root = _power(_cho_inv(Sg), 0.5)
                Psi = root @ (Sg - Ps[t]) @ root
                Sigma.append(Sg)
                ws.append(np.diag(Psi))
                zs.append(_weight_matrix(Psi, dtype(exponent), blocks) @ root @ s[t])
            out |= {"x": s, "z": zs, "Sigma": Sigma, "w_smooth": ws}
    return _time_last(out)


#: The three, by name.
CORRECT = {"joseph": joseph, "one_based": one_based, "information": information}
