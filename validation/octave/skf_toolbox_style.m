function [z, z_filtered, x, x_filtered, weights, log_likelihood, intermediates] = ...
        skf_toolbox_style(L, Y, R, A, Q, P0, exponent, smoother)
%SKF_TOOLBOX_STYLE skf_plain with the prediction step of the reference toolbox.
%   The toolbox's prediction skips A (x_{t|t-1} = x_{t-1|t-1}, P_{t|t-1} = P_{t-1|t-1} + Q)
%   when A is diagonal and at least one of its diagonal entries is exactly 1 (its test,
%   written "isdiag(A) && all(diag(A) - 1) < eps", compares the logical all(...) with eps,
%   and all(diag(A) - 1) is false exactly when some diag(A) - 1 is 0). Otherwise it
%   predicts with A. docs/conformance.md states the condition; the cases
%   diagonal_transition (an entry 1: A ignored) and diagonal_transition_below_one (none:
%   A used) of suite version 3 show both sides of it.
if isdiag(A) && any(diag(A) == 1)
    A = eye(size(A));
end
[z, z_filtered, x, x_filtered, weights, log_likelihood, intermediates] = ...
    skf_plain(L, Y, R, A, Q, P0, exponent, smoother);
end
