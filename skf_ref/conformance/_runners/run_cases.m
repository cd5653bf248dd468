function run_cases(case_dir, out_dir, skf)
%RUN_CASES Run an SKF on every conformance case and save its outputs for skf-ref compare.
%
%   run_cases('skf-cases', 'mine', @my_skf)
%
%   CASE_DIR is a folder `skf-ref conformance export` wrote. For each case file
%   CASE_DIR/<case>.mat this loads the case, makes the model's matrices (a scalar
%   noise_cov, theta0, q or transition is that number times the identity; noise_cov is
%   a variance), calls
%
%       [z, z_filtered, x, x_filtered, weights, log_likelihood] = ...
%           skf(L, Y, R, A, Q, P0, exponent, smoother)
%
%   (a case that standardizes each position as a whole, suite version 3, also passes
%   standardize = 'position' and n_orient = 3 as two more inputs; a function of eight
%   inputs skips it) and saves the outputs to OUT_DIR/<case>.mat (MATLAB version 7, which Octave writes
%   with -v7 and scipy reads). Every array is n_sources x n_times, as in the case file;
%   smoother is 'none', 'rts-standardized', 'rts-state' or 'rts-smoothed-weights'. An
%   output returned empty ([]) is not saved, and not compared. A function with a seventh
%   output returns there a struct of the intermediate quantities it computes (P_pred, S,
%   K, ...: docs/conformance.md, time on the last axis); they are saved with the outputs,
%   and compare names the first of them that goes wrong. Then, in a shell:
%
%       for f in skf-cases/*.mat; do skf-ref compare "$f" "mine/$(basename "$f")"; done
%
%   Runs in MATLAB and in GNU Octave. Copy it into your project and adapt it.

if ~exist(out_dir, 'dir')
    mkdir(out_dir);
end
names = {'z', 'z_filtered', 'x', 'x_filtered', 'weights', 'log_likelihood'};
files = dir(fullfile(case_dir, '*.mat'));
for k = 1:numel(files)
    c = load(fullfile(case_dir, files(k).name));
    [m, n] = size(c.L);
    R = identity_times(c.noise_cov, m);
    A = identity_times(c.transition, n);
    Q = identity_times(c.q, n);
    P0 = identity_times(c.theta0, n);
    inputs = {c.L, c.Y, R, A, Q, P0, c.exponent, c.smoother};
    if isfield(c, 'standardize') && ~strcmp(c.standardize, 'column')
        if nargin(skf) >= 0 && nargin(skf) < 10
            fprintf('%-24s skipped: standardize %s, n_orient %d: give the function two more inputs\n', ...
                    c.case, c.standardize, double(c.n_orient));
            continue
        end
        inputs = [inputs, {c.standardize, double(c.n_orient)}];
    end
    values = cell(1, numel(names) + (nargout(skf) > numel(names)));
    [values{:}] = skf(inputs{:});
    outputs = struct();
    for i = 1:numel(names)
        if ~isempty(values{i})
            outputs.(names{i}) = values{i};
        end
    end
    if numel(values) > numel(names) && isstruct(values{end})  % the intermediates
        extra = fieldnames(values{end});
        for i = 1:numel(extra)
            outputs.(extra{i}) = values{end}.(extra{i});
        end
    end
    save(fullfile(out_dir, files(k).name), '-struct', 'outputs', '-v7');
    fprintf('%-24s %d channels x %d sources x %d steps\n', c.case, m, n, size(c.Y, 2));
end
end

function M = identity_times(value, k)
% A scalar c means c times the k x k identity; a matrix means itself.
if isscalar(value)
    M = value * eye(k);
else
    M = value;
end
end
