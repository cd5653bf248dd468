function [z, z_filtered, x, x_filtered, weights, log_likelihood, intermediates] = ...
        skf_plain(L, Y, R, A, Q, P0, exponent, smoother, standardize, n_orient)
%SKF_PLAIN The SKF of docs/model.md sections 2-3 in plain MATLAB/Octave.
%   The subject run_cases.m is validated with (python -m validation.conformance_suite
%   runners): written from docs/model.md, one equation a line. The seventh output is a
%   struct of the intermediate quantities of docs/conformance.md (x_pred, P_pred, S, K,
%   P_filt, w; G and P_smooth with a smoother), time on the last axis. standardize
%   'position' standardizes the n_orient columns of each position by their block.
[m, n] = size(L);
block = 1;
if nargin > 8 && strcmp(standardize, 'position')
    block = n_orient;
end
T = size(Y, 2);
Wfull = zeros(n, n, T);
x_filtered = zeros(n, T);
z_filtered = zeros(n, T);
weights = zeros(n, T);
P_filt = zeros(n, n, T);
P_pred = zeros(n, n, T);
whitening = zeros(n, n, T);
x_pred = zeros(n, T);
S_all = zeros(m, m, T);
K_all = zeros(n, m, T);
w_all = zeros(n, T);
xt = zeros(n, 1);
P = P0;
log_likelihood = 0;
for t = 1:T
    xp = A * xt;                                   % section 2.2 eq. (4)
    Pp = A * P * A' + Q;
    S = L * Pp * L' + R;                           % section 2.2 eq. (5)
    K = (S \ (L * Pp))';
    e = Y(:, t) - L * xp;
    xt = xp + K * e;
    P = Pp - K * S * K';
    C = chol(S, 'lower');                          % S = C C'
    v = C \ e;
    log_likelihood = log_likelihood - (m * log(2 * pi) + 2 * sum(log(diag(C))) + v' * v) / 2;
    [V, D] = eig((Pp + Pp') / 2);
    W = V * diag(1 ./ sqrt(diag(D))) * V';         % P_{t|t-1}^{-1/2}, symmetric
    M = W * K;
    w = sum((M * S) .* M, 2);                      % diag(W K S K' W), eq. (7)
    Wfull(:, :, t) = weight_matrix(M * S * M', exponent, block);  % eq. (7), by blocks
    weights(:, t) = diag(Wfull(:, :, t));
    x_pred(:, t) = xp;
    S_all(:, :, t) = S;
    K_all(:, :, t) = K;
    w_all(:, t) = w;
    z_filtered(:, t) = Wfull(:, :, t) * (W * xt);  % eq. (6)
    x_filtered(:, t) = xt;
    P_filt(:, :, t) = P;
    P_pred(:, :, t) = Pp;
    whitening(:, :, t) = W;
end
z = z_filtered;
x = x_filtered;
intermediates = struct('x_pred', x_pred, 'P_pred', P_pred, 'S', S_all, 'K', K_all, ...
                       'P_filt', P_filt, 'w', w_all);
if strcmp(smoother, 'rts-standardized')
    [z, G, P_smooth] = rts(z_filtered, P_filt, P_pred, A);
elseif strcmp(smoother, 'rts-state')
    [x, G, P_smooth] = rts(x_filtered, P_filt, P_pred, A);
    for t = 1:T
        z(:, t) = Wfull(:, :, t) * (whitening(:, :, t) * x(:, t));
    end
elseif strcmp(smoother, 'rts-smoothed-weights')      % section 3: over its own variance
    [x, G, P_smooth] = rts(x_filtered, P_filt, P_pred, A);
    Sigma = P0;
    for t = 1:T
        Sigma = A * Sigma * A' + Q;
        [V, D] = eig((Sigma + Sigma') / 2);
        root = V * diag(1 ./ sqrt(diag(D))) * V';
        z(:, t) = weight_matrix(root * (Sigma - P_smooth(:, :, t)) * root, exponent, block) ...
                  * (root * x(:, t));
    end
end
if ~strcmp(smoother, 'none')
    intermediates.G = G;
    intermediates.P_smooth = P_smooth;
end
end

function W = weight_matrix(Psi, exponent, block)
% blockdiag_i B_i^(-exponent), B_i the block x block diagonal blocks of Psi (1 x 1: w_i)
n = size(Psi, 1);
W = zeros(n);
for i = 1:block:n
    k = i:i + block - 1;
    [V, D] = eig((Psi(k, k) + Psi(k, k)') / 2);
    W(k, k) = V * diag(diag(D) .^ (-exponent)) * V';
end
end

function [s, G, P_smooth] = rts(means, P_filt, P_pred, A)
% section 2.3 eq. (4): s_t = m_t + G_t (s_{t+1} - A m_t), G_t = P_{t|t} A' P_{t+1|t}^{-1},
% P^s_t = P_{t|t} + G_t (P^s_{t+1} - P_{t+1|t}) G_t'
s = means;
T = size(means, 2);
G = zeros(size(P_filt, 1), size(P_filt, 2), T - 1);
P_smooth = P_filt;
for t = T - 1:-1:1
    G(:, :, t) = (P_pred(:, :, t + 1) \ (A * P_filt(:, :, t)))';
    s(:, t) = means(:, t) + G(:, :, t) * (s(:, t + 1) - A * means(:, t));
    P_smooth(:, :, t) = P_filt(:, :, t) + ...
        G(:, :, t) * (P_smooth(:, :, t + 1) - P_pred(:, :, t + 1)) * G(:, :, t)';
end
end
