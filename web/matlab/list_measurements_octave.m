% GNU Octave (6 or later; tested with 7.3) version of list_measurements.m:
% the newest complete measurements of a scene, and one booth's only.
% Octave's webread returns the body as text (jsondecode makes it a struct),
% takes query values as strings, and has no table type (printf instead).
% The daemon's address: $LIGHTBOOTH_URL, else serve's default --bind.
base = getenv('LIGHTBOOTH_URL');
if isempty(base), base = 'http://127.0.0.1:8650'; end
page = jsondecode(webread([base '/api/measurements'], 'scene', 'cylinder', 'state', 'complete', 'limit', '50'));
printf('%d complete measurements of the cylinder\n', page.total);
for k = 1:numel(page.items)
  m = page.items(k);   % jsondecode gives a struct array, or a cell array when items differ
  if iscell(page.items), m = page.items{k}; end
  printf('%6d %-8s %-8s %-10s Y = %9.4f cd/m^2\n', m.id, m.booth, m.instrument_model, m.target, m.Y);
end

% Several booths sharing one database: list them, then one booth's data only.
booths = jsondecode(webread([base '/api/booths']));
printf('%d booth(s)\n', numel(booths.booths));
north = jsondecode(webread([base '/api/measurements'], 'booth', 'north', 'state', 'complete', 'limit', '1000'));
printf('%d complete measurements in booth north\n', north.total);
