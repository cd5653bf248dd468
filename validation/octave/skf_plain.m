function [z, z_filtered, x, x_filtered, weights, log_likelihood] = ...
        skf_plain(L, Y, R, A, Q, P0, exponent, smoother)
%SKF_PLAIN The SKF of docs/model.md sections 2-3 in plain MATLAB/Octave.
%   The subject run_cases.m is validated with (python -m validation.conformance_suite
%   runners): written from docs/model.md, one equation a line.
[m, n] = size(L);
T = size(Y, 2);
x_filtered = zeros(n, T);
z_filtered = zeros(n, T);
weights = zeros(n, T);
P_filt = zeros(n, n, T);
P_pred = zeros(n, n, T);
whitening = zeros(n, n, T);
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
    weights(:, t) = w .^ (-exponent);
    z_filtered(:, t) = weights(:, t) .* (W * xt);  % eq. (6)
    x_filtered(:, t) = xt;
    P_filt(:, :, t) = P;
    P_pred(:, :, t) = Pp;
    whitening(:, :, t) = W;
end
z = z_filtered;
x = x_filtered;
if strcmp(smoother, 'rts-standardized')
    z = rts(z_filtered, P_filt, P_pred, A);
elseif strcmp(smoother, 'rts-state')
    x = rts(x_filtered, P_filt, P_pred, A);
    for t = 1:T
        z(:, t) = weights(:, t) .* (whitening(:, :, t) * x(:, t));
    end
end
end

function s = rts(means, P_filt, P_pred, A)
% section 2.3 eq. (4): s_t = m_t + G_t (s_{t+1} - A m_t), G_t = P_{t|t} A' P_{t+1|t}^{-1}
s = means;
for t = size(means, 2) - 1:-1:1
    G = (P_pred(:, :, t + 1) \ (A * P_filt(:, :, t)))';
    s(:, t) = means(:, t) + G * (s(:, t + 1) - A * means(:, t));
end
end
