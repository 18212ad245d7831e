% Set up the study's oddity experiment from a compared measurement, read its
% display check and verification, and fetch the analysis (percent correct
% and d' under both oddity models) as a table and as a MAT-file.
% Writes need the daemon's token (printed when it starts, in lightbooth.token).
% Needs MATLAB R2016b or later: webread, webwrite, websave and weboptions
% (R2014b), weboptions' HeaderFields for the token (R2016b), struct2table and
% table (R2013b). In GNU Octave (6 or later) run oddity_experiment_octave.m instead.
% The daemon's address: $LIGHTBOOTH_URL, else serve's default --bind.
base = getenv('LIGHTBOOTH_URL');
if isempty(base), base = 'http://127.0.0.1:8650'; end
token = getenv('LIGHTBOOTH_TOKEN');   % or the file serve writes beside its database
if isempty(token), token = strtrim(fileread('lightbooth.token')); end
opts  = weboptions('HeaderFields', {'Authorization', ['Bearer ' token]}, ...
                   'MediaType', 'application/json', 'Timeout', 30);

% A complete measurement with its comparisons, and a display profile
% (calibrate the display first: /calibrate in the dashboard).
page = webread([base '/api/measurements'], 'scene', 'white', 'state', 'complete', 'limit', 1, opts);
profiles = webread([base '/api/display-profiles'], opts);
request = struct('measurement_id', page.items(1).id, ...
                 'display_profile_id', profiles(1).id, ...
                 'approximations', {{'nstep3', 'nstep9', 'nstep27', 'nstep81'}}, ...
                 'output', 'noisy_bit');
e = webwrite([base '/api/experiments'], request, opts);
fprintf('experiment %d: %s\n', e.id, strjoin(e.check.summary, '; '));

% Run observers on the stimulus display: /experiment/<id>/run (verify the
% display there first). Then:
v = webread(sprintf('%s/api/experiments/%d/verifications', base, e.id), opts);
if isempty(v)
    disp('not verified yet: press "verify the display" on the session page');
end
a = webread(sprintf('%s/api/experiments/%d/analysis', base, e.id), opts);
for k = 1:numel(a.rows)
    r = a.rows(k);
    fprintf('%-6s %-8s %2d/%2d correct, d'' = %.2f (differencing)\n', ...
            r.observer, r.approximation, r.correct, r.trials, r.differencing.d_prime);
end
websave('analysis.mat', sprintf('%s/api/experiments/%d/analysis.mat', base, e.id), opts);
s = load('analysis.mat');
t = table(cellstr(s.observer), cellstr(s.approximation), s.proportion_correct, s.dprime_differencing, ...
          'VariableNames', {'observer', 'approximation', 'pc', 'dprime'});
