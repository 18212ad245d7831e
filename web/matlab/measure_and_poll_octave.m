% GNU Octave (6 or later; tested with 7.3) version of measure_and_poll.m:
% start a five-sample measurement of a scene target and poll until it ends.
% Writes need the daemon's token: $LIGHTBOOTH_TOKEN, else the file serve
% writes beside its database (lightbooth.token).
% The daemon's address: $LIGHTBOOTH_URL, else serve's default --bind.
base = getenv('LIGHTBOOTH_URL');
if isempty(base), base = 'http://127.0.0.1:8650'; end
token = getenv('LIGHTBOOTH_TOKEN');
if isempty(token), token = strtrim(fileread('lightbooth.token')); end
opts = weboptions('HeaderFields', {'Authorization', ['Bearer ' token]}, 'Timeout', 10);

% Key/value pairs are sent form-encoded (values as strings); the daemon
% accepts them as well as JSON.
job = jsondecode(webwrite([base '/api/measurements'], 'scene', 'white', 'target', 'patch', 'samples', '5', opts));
printf('measurement %d queued\n', job.id);

m = jsondecode(webread([base job.url]));
while any(strcmp(m.state, {'queued', 'running'}))
  pause(0.2);
  m = jsondecode(webread([base job.url]));
end
printf('state %s: Y = %.3f cd/m^2, x = %.4f, y = %.4f\n', m.state, m.Y, m.x, m.y);
% The spectrum as a MAT-file (Octave has no websave; urlwrite fetches it;
% reading needs no token on loopback).
urlwrite([base job.url '/spectrum.mat'], 'spectrum.mat');
s = load('spectrum.mat');
printf('%d wavelengths, %g-%g nm\n', numel(s.wavelength_nm), s.wavelength_nm(1), s.wavelength_nm(end));
