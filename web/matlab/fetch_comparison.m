% Fetch the comparison of every colour coding with the measurements of a scene.
% Needs MATLAB R2016b or later: webread, webwrite, websave and weboptions
% (R2014b), weboptions' HeaderFields for the token (R2016b), struct2table and
% table (R2013b). In GNU Octave (6 or later) run fetch_comparison_octave.m instead.
% The daemon's address: $LIGHTBOOTH_URL, else serve's default --bind.
base = getenv('LIGHTBOOTH_URL');
if isempty(base), base = 'http://127.0.0.1:8650'; end
c = webread([base '/api/scenes/cylinder/comparisons']);
summary = struct2table(c.codings);   % per coding: rms_rel, mean_dE76, sd_dE76, mean_dE00, ...
disp(summary);
rows = struct2table(c.rows);          % per target and coding
% Or as a MAT-file:
websave('comparisons_cylinder.mat', [base '/api/scenes/cylinder/comparisons.mat']);
s = load('comparisons_cylinder.mat');
t = table(cellstr(s.target), cellstr(s.coding), s.dE00, s.Y_ratio, ...
          'VariableNames', {'target', 'coding', 'dE00', 'Y_ratio'});
