% GNU Octave (6 or later; tested with 7.3) version of fetch_comparison.m:
% the comparison of every colour coding with the measurements of a scene.
% The daemon's address: $LIGHTBOOTH_URL, else serve's default --bind.
base = getenv('LIGHTBOOTH_URL');
if isempty(base), base = 'http://127.0.0.1:8650'; end
c = jsondecode(webread([base '/api/scenes/white/comparisons']));
for k = 1:numel(c.codings)
  r = c.codings(k);
  if iscell(c.codings), r = c.codings{k}; end
  printf('%-10s rms_rel = %.4f  mean dE00 = %.3f\n', r.coding, r.rms_rel, r.mean_dE00);
end
% Or as a MAT-file: one row per target and coding.
urlwrite([base '/api/scenes/white/comparisons.mat'], 'comparisons_white.mat');
s = load('comparisons_white.mat');
printf('%d rows in comparisons_white.mat\n', numel(s.dE00));
