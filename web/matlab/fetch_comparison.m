% Fetch the comparison of every colour coding with the measurements of a scene.
base = 'http://127.0.0.1:8650';
c = webread([base '/api/scenes/cylinder/comparisons']);
summary = struct2table(c.codings);   % per coding: rms_rel, mean_dE76, sd_dE76, mean_dE00, ...
disp(summary);
rows = struct2table(c.rows);          % per target and coding
% Or as a MAT-file:
websave('comparisons_cylinder.mat', [base '/api/scenes/cylinder/comparisons.mat']);
s = load('comparisons_cylinder.mat');
t = table(cellstr(s.target), cellstr(s.coding), s.dE00, s.Y_ratio, ...
          'VariableNames', {'target', 'coding', 'dE00', 'Y_ratio'});
