% List the newest measurements of a scene from a running lightbooth daemon.
% Reading needs no token on loopback.
% Needs MATLAB R2016b or later: webread, webwrite, websave and weboptions
% (R2014b), weboptions' HeaderFields for the token (R2016b), struct2table and
% table (R2013b). In GNU Octave (6 or later) run list_measurements_octave.m instead.
% The daemon's address: $LIGHTBOOTH_URL, else serve's default --bind.
base = getenv('LIGHTBOOTH_URL');
if isempty(base), base = 'http://127.0.0.1:8650'; end
page = webread([base '/api/measurements'], 'scene', 'cylinder', 'state', 'complete', 'limit', 50);
fprintf('%d complete measurements of the cylinder\n', page.total);
t = struct2table(page.items);           % one row per measurement
disp(t(:, {'id', 'booth', 'instrument_model', 'target', 'Y', 'x', 'y', 'luminance_cv'}));

% Several booths sharing one database: list them, then one booth's data only
% (any booth's daemon answers for the whole lab).
booths = webread([base '/api/booths']);
disp(struct2table(booths.booths));
north = webread([base '/api/measurements'], 'booth', 'north', 'state', 'complete', 'limit', 1000);
fprintf('%d complete measurements in booth north\n', north.total);
