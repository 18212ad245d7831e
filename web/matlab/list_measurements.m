% List the newest measurements of a scene from a running lightbooth daemon.
% Reading needs no token on loopback.
base = 'http://127.0.0.1:8650';
page = webread([base '/api/measurements'], 'scene', 'cylinder', 'state', 'complete', 'limit', 50);
fprintf('%d complete measurements of the cylinder\n', page.total);
t = struct2table(page.items);           % one row per measurement
disp(t(:, {'id', 'target', 'Y', 'x', 'y', 'luminance_cv'}));
