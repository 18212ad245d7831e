% Start a five-sample measurement of a scene target and poll until it ends.
% Writes need the daemon's token (printed when it starts; or set LIGHTBOOTH_TOKEN).
base  = 'http://127.0.0.1:8650';
token = strtrim(fileread('lightbooth.token'));
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
