-- The number of samples a measurement may request is the instrument's
-- limit, stated by its driver (the PR-650's 1–99 lives in src/instrument),
-- not the schema's: other instruments average more. The schema keeps only
-- what holds for every instrument: at least one sample.
--
-- SQLite cannot alter a CHECK constraint, so `measurements` is rebuilt with
-- every column (those added by 0006, 0009 and 0010 included), row and id,
-- and every index on it (0001, 0002, 0009, 0010) is recreated. As in 0005,
-- foreign keys are deferred to the commit: `comparisons`, `reflectances`
-- and `illuminants` reference measurements and are left pointing at ids
-- that the re-insert restores. `samples` (ON DELETE CASCADE) would lose
-- every row when the old table is dropped, so its rows are set aside and
-- restored with their ids.
PRAGMA defer_foreign_keys = ON;

CREATE TEMP TABLE measurements_keep AS SELECT * FROM measurements;
CREATE TEMP TABLE samples_keep AS SELECT * FROM samples;
DROP TABLE measurements;
CREATE TABLE measurements (
    id                 INTEGER PRIMARY KEY,
    session_id         INTEGER REFERENCES sessions (id),
    instrument_id      INTEGER REFERENCES instruments (id),
    scene              TEXT,            -- scene id (file stem under scenes/), NULL for a free measurement
    target             TEXT,            -- target id within the scene
    samples_requested  INTEGER NOT NULL CHECK (samples_requested >= 1),  -- the driver limits it further
    settings_json      TEXT NOT NULL,   -- instrument settings in force (timeouts, retries, port)
    state              TEXT NOT NULL CHECK (state IN ('queued', 'running', 'complete', 'failed', 'interrupted', 'cancelled')),
    error              TEXT,            -- why it failed or was interrupted
    note               TEXT NOT NULL DEFAULT '',
    created_at         REAL NOT NULL,
    started_at         REAL,
    finished_at        REAL,
    -- The average, written only when the measurement is complete.
    wavelength_json    TEXT,            -- native grid, nm
    radiance_json      TEXT,            -- mean, W/(sr·m²·nm)
    radiance_sd_json   TEXT,            -- per-wavelength standard deviation, W/(sr·m²·nm)
    luminance_cd_m2    REAL,
    x                  REAL,
    y                  REAL,
    luminance_cv       REAL,
    observer           TEXT,            -- 0006: x, y, XYZ below computed by lightbooth with this observer
    xyz_x              REAL,
    xyz_y              REAL,
    xyz_z              REAL,
    booth              TEXT NOT NULL DEFAULT 'default',       -- 0009
    daemon_id          INTEGER REFERENCES daemons (id),       -- 0010
    CHECK (state <> 'complete' OR (radiance_json IS NOT NULL AND luminance_cd_m2 IS NOT NULL))
);
INSERT INTO measurements (id, session_id, instrument_id, scene, target, samples_requested, settings_json, state,
                          error, note, created_at, started_at, finished_at, wavelength_json, radiance_json,
                          radiance_sd_json, luminance_cd_m2, x, y, luminance_cv, observer, xyz_x, xyz_y, xyz_z,
                          booth, daemon_id)
    SELECT id, session_id, instrument_id, scene, target, samples_requested, settings_json, state,
           error, note, created_at, started_at, finished_at, wavelength_json, radiance_json,
           radiance_sd_json, luminance_cd_m2, x, y, luminance_cv, observer, xyz_x, xyz_y, xyz_z,
           booth, daemon_id FROM measurements_keep;
INSERT INTO samples (id, measurement_id, idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2)
    SELECT id, measurement_id, idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2 FROM samples_keep;
DROP TABLE measurements_keep;
DROP TABLE samples_keep;
CREATE INDEX measurements_scene ON measurements (scene, target);
CREATE INDEX measurements_state ON measurements (state);
CREATE INDEX measurements_newest ON measurements (id);
CREATE INDEX measurements_by_scene ON measurements (scene);
CREATE INDEX measurements_booth ON measurements (booth, id);
CREATE INDEX measurements_daemon ON measurements (daemon_id, state);
