"""Mistaken SKFs outside ``skf_ref``'s catalogue: the SKF of docs/model.md with one slip each.

Each class is :class:`~validation.skf_from_the_docs.SKF` with one method replaced, and
declares (``quantity``) the quantity of docs/conformance.md its mistake changes first in the
order the equations produce them: what ``skf-ref compare`` should name as the first
divergence when the intermediates are given. The declarations were committed before any
comparison was run (validation/conformance_mistakes.md). None of these is in
``skf_ref.conformance._mistakes``; :data:`NEWCOMER` are five more, as a newcomer to the SKF
makes them.
"""

import numpy as np
from numpy import linalg

from .skf_from_the_docs import SKF, symmetric_power

# --- priors ---------------------------------------------------------------------------------


class PriorsAmplitudeNotSquared(SKF):
    """theta0 = 10**(PM/10) sigma**2 amplitude / N: the amplitude not squared."""

    quantity = "priors"

    def priors(self, L, noise_std, pm_snr_db, ep_snr_db, n_times, convention):
        theta0, q = super().priors(L, noise_std, pm_snr_db, ep_snr_db, n_times, convention)
        norms = np.linalg.norm(L, axis=0)
        amplitude = (
            np.sqrt(L.shape[0] / np.mean(norms**2))
            if convention == "gain"
            else np.mean(norms**-0.5)
        )
        theta0 = theta0 / amplitude
        return theta0, self.evolution(theta0, ep_snr_db, n_times)


class PriorsEvolutionAmplitudeDb(SKF):
    """kappa = 10**(EP/10): the EP-SNR read as a power where it is an amplitude's dB."""

    quantity = "priors"

    def evolution(self, theta0, ep_snr_db, n_times):
        return 10 ** (ep_snr_db / 5) * theta0 / n_times


# --- prediction -----------------------------------------------------------------------------


class QAddedAfterUpdate(SKF):
    """Q added to P_{t|t} after the update instead of in the prediction."""

    quantity = "prediction"

    def predict(self, x, P, A, Q):
        return A @ x, A @ P @ A.T

    def update_covariance(self, P_pred, K, S, L, R):
        return super().update_covariance(P_pred, K, S, L, R) + self._Q

    def filter(self, L, Y, R, A, Q, P0, exponent, blocks):
        self._Q = Q
        return super().filter(L, Y, R, A, Q, P0, exponent, blocks)


class CovarianceTransitionNotTransposed(SKF):
    """P_{t|t-1} = A P A + Q: the transpose of A left out."""

    quantity = "prediction"

    def predict(self, x, P, A, Q):
        return A @ x, A @ P @ A + Q


class MeanNotPropagated(SKF):
    """x_{t|t-1} = x_{t-1|t-1}: A applied to the covariance only."""

    quantity = "prediction"

    def predict(self, x, P, A, Q):
        return x, A @ P @ A.T + Q


class ProcessNoiseInsideTransition(SKF):
    """P_{t|t-1} = A (P + Q) A^T."""

    quantity = "prediction"

    def predict(self, x, P, A, Q):
        return A @ x, A @ (P + Q) @ A.T


# --- innovation covariance and gain -----------------------------------------------------------


class NoiseCovarianceDiagonalOnly(SKF):
    """S_t = L P L^T + Diag(diag R): the noise covariance's off-diagonal dropped."""

    quantity = "innovation_covariance"

    def innovation_covariance(self, P_pred, P_prev, L, R):
        return L @ P_pred @ L.T + np.diag(np.diag(R))


class InnovationFromPreviousPosterior(SKF):
    """S_t = L P_{t-1|t-1} L^T + R: the covariance before the prediction."""

    quantity = "innovation_covariance"

    def innovation_covariance(self, P_pred, P_prev, L, R):
        return L @ P_prev @ L.T + R


class GainFromPreviousPosterior(SKF):
    """K_t = P_{t-1|t-1} L^T S_t^{-1}."""

    quantity = "gain"

    def gain(self, P_pred, P_prev, S, L, R):
        return np.linalg.solve(S, L @ P_prev).T


class GainWithNoiseInverse(SKF):
    """K_t = P_{t|t-1} L^T R^{-1}: the information form's gain, with P_{t|t-1} for P_{t|t}."""

    quantity = "gain"

    def gain(self, P_pred, P_prev, S, L, R):
        return np.linalg.solve(R, L @ P_pred).T


# --- filtered state -------------------------------------------------------------------------


class InnovationFromPreviousState(SKF):
    """y_t - L x_{t-1|t-1}: the innovation before the prediction."""

    quantity = "filtered_state"

    def update_state(self, x_pred, x_prev, K, y, L):
        return x_pred + K @ (y - L @ x_prev)


class InnovationSign(SKF):
    """x_{t|t} = x_{t|t-1} - K_t (y_t - L x_{t|t-1})."""

    quantity = "filtered_state"

    def update_state(self, x_pred, x_prev, K, y, L):
        return x_pred - K @ (y - L @ x_pred)


class DataOneStepLate(SKF):
    """y_{t-1} at step t (zero at the first): the data's index off by one."""

    quantity = "filtered_state"

    def data(self, Y, t):
        return Y[:, t - 1] if t else np.zeros(len(Y), Y.dtype)


# --- posterior covariance ---------------------------------------------------------------------


class JosephWrongSign(SKF):
    """P_{t|t} = (I - K L) P (I - K L)^T - K R K^T: Joseph's form with - for +."""

    quantity = "posterior_covariance"

    def update_covariance(self, P_pred, K, S, L, R):
        I_KL = np.eye(len(P_pred), dtype=P_pred.dtype) - K @ L
        return I_KL @ P_pred @ I_KL.T - K @ R @ K.T


class PosteriorPlus(SKF):
    """P_{t|t} = P_{t|t-1} + K_t S_t K_t^T."""

    quantity = "posterior_covariance"

    def update_covariance(self, P_pred, K, S, L, R):
        return P_pred + K @ S @ K.T


class PosteriorWithNoise(SKF):
    """P_{t|t} = P_{t|t-1} - K_t R K_t^T: R for S_t."""

    quantity = "posterior_covariance"

    def update_covariance(self, P_pred, K, S, L, R):
        return P_pred - K @ R @ K.T


# --- weights --------------------------------------------------------------------------------


class WeightsFromDiagonals(SKF):
    """w_t = diag(P_{t|t-1} - P_{t|t}) / diag(P_{t|t-1}): the diagonals for the whitening."""

    quantity = "weights"

    def raw_weights(self, Psi, P_pred, P):
        return np.diag(P_pred - P) / np.diag(P_pred)


class WeightsFromPosteriorVariance(SKF):
    """w_t = diag(P_{t|t}): the weights from P_{t|t}'s diagonal."""

    quantity = "weights"

    def raw_weights(self, Psi, P_pred, P):
        return np.diag(P).copy()


class ExponentOnSquaredWeights(SKF):
    """W_t = (w_t ** 2) ** -alpha: the exponent on the weights' square."""

    quantity = "weights"

    def weight_matrix(self, w, Psi, exponent, blocks):
        return np.diag((w**2) ** -exponent)


class WeightsOfMatrixPower(SKF):
    """W_t = Diag(diag(Psi_t ** -alpha)): the power of the matrix, then its diagonal."""

    quantity = "weights"

    def weight_matrix(self, w, Psi, exponent, blocks):
        return np.diag(np.diag(symmetric_power(Psi, -exponent)))


class WeightsWithoutInnovationInverse(SKF):
    """w_t = diag(B^T B), B = L P^{1/2}: S_t^{-1} left out of diag(B^T S_t^{-1} B)."""

    quantity = "weights"

    def psi(self, whitening, P_pred, P, K, S, L):
        B = L @ symmetric_power(P_pred, 0.5)
        return B.T @ B


class ExponentSign(SKF):
    """W_t = Diag(w_t ** alpha): the exponent's sign lost."""

    quantity = "weights"

    def weight_matrix(self, w, Psi, exponent, blocks):
        return np.diag(w**exponent)


# --- standardized ---------------------------------------------------------------------------


class StandardizedPrediction(SKF):
    """z_t = W_t P_{t|t-1}^{-1/2} x_{t|t-1}: z from the predicted state."""

    quantity = "standardized"

    def standardized(self, W, whitening, x, x_pred):
        return W @ (whitening @ x_pred)


class WhiteningByCholesky(SKF):
    """z_t = W_t C^{-1} x_{t|t} with P_{t|t-1} = C C^T: a Cholesky factor in eq. (6)."""

    quantity = "standardized"

    def standardized(self, W, whitening, x, x_pred):
        P_pred = linalg.inv(whitening @ whitening)
        return W @ linalg.solve(linalg.cholesky(P_pred), x)


class WhiteningNotInverted(SKF):
    """z_t = W_t P_{t|t-1}^{1/2} x_{t|t}: the square root, not its inverse."""

    quantity = "standardized"

    def standardized(self, W, whitening, x, x_pred):
        return W @ linalg.solve(whitening, x)


class WhiteningByDiagonal(SKF):
    """z_t = W_t Diag(diag(P_{t|t-1}))^{-1/2} x_{t|t}."""

    quantity = "standardized"

    def standardized(self, W, whitening, x, x_pred):
        P_pred = linalg.inv(whitening @ whitening)
        return W @ (x / np.sqrt(np.diag(P_pred)))


# --- log-likelihood -------------------------------------------------------------------------


class LogLikelihoodWithout2Pi(SKF):
    """The log-likelihood without its n_channels log(2 pi) term."""

    quantity = "log_likelihood"

    def log_likelihood(self, y, L, x_pred, x, S):
        e = y - L @ x_pred
        return -0.5 * (np.linalg.slogdet(S)[1] + e @ np.linalg.solve(S, e))


class LogLikelihoodHalfLogDet(SKF):
    """log det S_t as the log-determinant of its Cholesky factor: half of it."""

    quantity = "log_likelihood"

    def log_likelihood(self, y, L, x_pred, x, S):
        e = y - L @ x_pred
        log_det = np.sum(np.log(np.diag(linalg.cholesky(S))))
        return -0.5 * (len(y) * np.log(2 * np.pi) + log_det + e @ np.linalg.solve(S, e))


class LogLikelihoodUpdatedResidual(SKF):
    """The residual y_t - L x_{t|t} in the log-likelihood, for the innovation."""

    quantity = "log_likelihood"

    def log_likelihood(self, y, L, x_pred, x, S):
        return super().log_likelihood(y, L, x, x, S)


class LogLikelihoodFloat32(SKF):
    """Each log-likelihood term computed and summed in float32."""

    quantity = "log_likelihood"

    def log_likelihood(self, y, L, x_pred, x, S):
        single = [np.asarray(v, dtype=np.float32) for v in (y, L, x_pred, S)]
        return np.float32(super().log_likelihood(*single[:3], x, single[3]))


# --- smoothers ------------------------------------------------------------------------------


class SmootherGainCurrentPrediction(SKF):
    """G_t = P_{t|t} A^T P_{t|t-1}^{-1}: the smoother's gain with P_{t|t-1} for P_{t+1|t}."""

    quantity = "smoother_gain"

    def smoother_gain(self, P_filt, P_pred, A, t):
        return np.linalg.solve(P_pred[t], A @ P_filt[t]).T


class SmootherStopsEarly(SKF):
    """The backward loop stops before t = 1: an off-by-one in the smoother (G_1 stays 0)."""

    quantity = "smoother_gain"

    def backward_steps(self, T):
        return range(T - 2, 0, -1)


class SmootherWithoutTransition(SKF):
    """s_t = m_t + G_t (s_{t+1} - m_t): A left out of the smoothed step."""

    quantity = "smoothed_state"

    def smooth_step(self, m, s_next, G, A):
        return m + G @ (s_next - m)


class RestandardizedOneStepLate(SKF):
    """rts-state: z^s_t = W_{t+1} P_{t+1|t}^{-1/2} x^s_t, the next step's standardization."""

    quantity = "standardized"

    def restandardized(self, keep, x_s, t):
        u = min(t + 1, len(x_s) - 1)
        return keep["W"][u] @ keep["whitening"][u] @ x_s[t]


class SmoothedCovarianceGainNotTransposed(SKF):
    """P^s_t = P_{t|t} + G_t (P^s_{t+1} - P_{t+1|t}) G_t: G_t^T written G_t."""

    quantity = "smoothed_covariance"

    def smooth_covariance(self, P_filt, P_next_smooth, P_pred_next, G):
        return P_filt + G @ (P_next_smooth - P_pred_next) @ G


class PriorCovarianceOneStepLate(SKF):
    """rts-smoothed-weights: Sigma_{t-1} at step t (Sigma_0 = P_0 at the first)."""

    quantity = "smoothed_weights"

    def prior_covariances(self, P0, A, Q, T):
        return [P0, *super().prior_covariances(P0, A, Q, T)[:-1]]


class SmoothedWeightsFromPrediction(SKF):
    """rts-smoothed-weights: P_{t|t-1} in place of the prior covariance Sigma_t."""

    quantity = "smoothed_weights"

    def filter(self, L, Y, R, A, Q, P0, exponent, blocks):
        keep = super().filter(L, Y, R, A, Q, P0, exponent, blocks)
        self._P_pred = keep["P_pred"]
        return keep

    def prior_covariances(self, P0, A, Q, T):
        return list(self._P_pred)


class BlockOfOrientationMajorOrder(SKF):
    """standardize="position": the blocks of columns i, i + n_pos, i + 2 n_pos (the
    orientation-major order) where MNE's order puts a position's columns together."""

    quantity = "weights"

    def weight_matrix(self, w, Psi, exponent, blocks):
        if blocks is None:
            return super().weight_matrix(w, Psi, exponent, blocks)
        n_pos = len(blocks)
        wrong = [list(range(i, len(Psi), n_pos)) for i in range(n_pos)]
        return super().weight_matrix(w, Psi, exponent, wrong)


class BlockPowerElementwise(SKF):
    """standardize="position": B ** -alpha taken entry by entry, not through eigh."""

    quantity = "weights"

    def weight_matrix(self, w, Psi, exponent, blocks):
        if blocks is None:
            return super().weight_matrix(w, Psi, exponent, blocks)
        W = np.zeros_like(Psi)
        for c in blocks:
            W[np.ix_(c, c)] = np.abs(Psi[np.ix_(c, c)]) ** -exponent
        return W


# --- a newcomer's ---------------------------------------------------------------------------


class NewcomerDataByRows(SKF):
    """for y in Y: the data walked by rows, as if Y were (n_times, n_channels)."""

    quantity = "filtered_state"

    def data(self, Y, t):
        return Y[t, :]


class NewcomerLeastSquaresStart(SKF):
    """x_{0|0} = the least-squares fit of y_1, to start "closer"."""

    quantity = "prediction"

    def initial_state(self, L, Y):
        return np.linalg.lstsq(L, Y[:, 0], rcond=None)[0]


class NewcomerNormalizedOutput(SKF):
    """z_{t|t} / max|z_{t|t}|: each step scaled to 1 for display, then saved."""

    quantity = "standardized"

    def standardized(self, W, whitening, x, x_pred):
        z = super().standardized(W, whitening, x, x_pred)
        return z / np.max(np.abs(z))


class NewcomerInverseDiagonalWhitening(SKF):
    """P^{-1/2} as Diag(diag(P^{-1})) ** 1/2: the inverse's diagonal, rooted."""

    quantity = "weights"

    def whitening(self, P_pred):
        return np.diag(np.sqrt(np.diag(linalg.inv(P_pred))))


class NewcomerGainFromNextPosterior(SKF):
    """G_t = P_{t|t} A^T P_{t+1|t+1}^{-1}: the next step's updated covariance."""

    quantity = "smoother_gain"

    def filter(self, L, Y, R, A, Q, P0, exponent, blocks):
        keep = super().filter(L, Y, R, A, Q, P0, exponent, blocks)
        self._P_filt = keep["P"]
        return keep

    def smoother_gain(self, P_filt, P_pred, A, t):
        return np.linalg.solve(self._P_filt[t + 1], A @ P_filt[t]).T


def _classes(first, last):
    names = list(globals())
    chosen = names[names.index(first) : names.index(last) + 1]
    return tuple(globals()[name] for name in chosen if isinstance(globals()[name], type))


#: The mistakes outside the catalogue, in the order of the equations.
MISTAKES = _classes("PriorsAmplitudeNotSquared", "BlockPowerElementwise")
#: Five more, as a newcomer makes them.
NEWCOMER = _classes("NewcomerDataByRows", "NewcomerGainFromNextPosterior")
