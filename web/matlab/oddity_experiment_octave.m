% GNU Octave (6 or later; tested with 7.3) version of oddity_experiment.m:
% set up the study's oddity experiment from a compared measurement, read its
% display check and verification, and fetch the analysis (percent correct
% and d' under both oddity models) as text and as a MAT-file.
% Writes need the daemon's token: $LIGHTBOOTH_TOKEN, else the file serve
% writes beside its database (lightbooth.token).
% The daemon's address: $LIGHTBOOTH_URL, else serve's default --bind.
base = getenv('LIGHTBOOTH_URL');
if isempty(base), base = 'http://127.0.0.1:8650'; end
token = getenv('LIGHTBOOTH_TOKEN');
if isempty(token), token = strtrim(fileread('lightbooth.token')); end

% A complete measurement with its comparisons, and a display profile
% (calibrate the display first: /calibrate in the dashboard).
page = jsondecode(webread([base '/api/measurements'], 'scene', 'white', 'state', 'complete', 'limit', '1'));
profiles = jsondecode(webread([base '/api/display-profiles']));
if iscell(profiles), profiles = profiles{1}; end
request = struct('measurement_id', page.items(1).id, ...
                 'display_profile_id', profiles(1).id, ...
                 'approximations', {{'nstep3', 'nstep9', 'nstep27', 'nstep81'}}, ...
                 'output', 'noisy_bit');
% Octave's webwrite sends key/value pairs form-encoded and nothing else (a
% text argument is dropped: Octave 7.3 posts an empty body), and a form has
% no lists: the request, with its list of approximations, goes as JSON
% through curl.
body = tempname();
fid = fopen(body, 'w'); fputs(fid, jsonencode(request)); fclose(fid);
[status, answer] = system(sprintf(['curl -sS --fail-with-body -H "Authorization: Bearer %s" ' ...
    '-H "Content-Type: application/json" --data-binary @%s %s/api/experiments'], token, body, base));
delete(body);
if status ~= 0, error('POST /api/experiments: %s', answer); end
e = jsondecode(answer);
printf('experiment %d: %s\n', e.id, strjoin(cellstr(e.check.summary), '; '));

% Run observers on the stimulus display: /experiment/<id>/run (verify the
% display there first). Then:
v = jsondecode(webread(sprintf('%s/api/experiments/%d/verifications', base, e.id)));
if isempty(v)
  disp('not verified yet: press "verify the display" on the session page');
end
a = jsondecode(webread(sprintf('%s/api/experiments/%d/analysis', base, e.id)));
for k = 1:numel(a.rows)
  r = a.rows(k);
  if iscell(a.rows), r = a.rows{k}; end
  printf('%-6s %-8s %2d/%2d correct, d'' = %.2f (differencing)\n', ...
         r.observer, r.approximation, r.correct, r.trials, r.differencing.d_prime);
end
urlwrite(sprintf('%s/api/experiments/%d/analysis.mat', base, e.id), 'analysis.mat');
s = load('analysis.mat');
printf('analysis.mat: %d rows\n', numel(s.proportion_correct));
