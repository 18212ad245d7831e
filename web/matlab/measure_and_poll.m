% Start a five-sample measurement of a scene target and poll until it ends.
% Writes need the daemon's token (printed when it starts; or set LIGHTBOOTH_TOKEN).
% Needs MATLAB R2016b or later: webread, webwrite, websave and weboptions
% (R2014b), weboptions' HeaderFields for the token (R2016b), struct2table and
% table (R2013b). In GNU Octave (6 or later) run measure_and_poll_octave.m instead.
% The daemon's address: $LIGHTBOOTH_URL, else serve's default --bind.
base = getenv('LIGHTBOOTH_URL');
if isempty(base), base = 'http://127.0.0.1:8650'; end
token = getenv('LIGHTBOOTH_TOKEN');   % or the file serve writes beside its database
if isempty(token), token = strtrim(fileread('lightbooth.token')); end
opts  = weboptions('HeaderFields', {'Authorization', ['Bearer ' token]}, 'Timeout', 10);

% webwrite sends form-encoded data; the daemon accepts it as well as JSON.
job = webwrite([base '/api/measurements'], struct('scene', 'white', 'target', 'patch', 'samples', 5), opts);
fprintf('measurement %d queued\n', job.id);

m = webread([base job.url]);
while any(strcmp(m.state, {'queued', 'running'}))
    pause(1);
    m = webread([base job.url]);
end
fprintf('state %s: Y = %.3f cd/m^2, x = %.4f, y = %.4f\n', m.state, m.Y, m.x, m.y);
plot(m.wavelength_nm, m.radiance); xlabel('wavelength (nm)'); ylabel('radiance W/(sr m^2 nm)');
