-- lightbooth's store: everything needed to audit a number later.
-- Times are POSIX seconds (REAL, UTC) so MATLAB's datetime(t,'ConvertFrom','posixtime') reads them.
-- Spectra are JSON arrays of numbers (TEXT): readable with the sqlite3 shell, exact to f64.

CREATE TABLE instruments (
    id          INTEGER PRIMARY KEY,
    model       TEXT NOT NULL,
    serial      TEXT NOT NULL DEFAULT '',  -- '' when the instrument does not say
    port        TEXT,
    first_seen  REAL NOT NULL,
    last_seen   REAL NOT NULL,
    UNIQUE (model, serial)
);

CREATE TABLE sessions (
    id          INTEGER PRIMARY KEY,
    operator    TEXT NOT NULL,
    notes       TEXT NOT NULL DEFAULT '',
    started_at  REAL NOT NULL
);

CREATE TABLE measurements (
    id                 INTEGER PRIMARY KEY,
    session_id         INTEGER REFERENCES sessions (id),
    instrument_id      INTEGER REFERENCES instruments (id),
    scene              TEXT,            -- scene id (file stem under scenes/), NULL for a free measurement
    target             TEXT,            -- target id within the scene
    samples_requested  INTEGER NOT NULL CHECK (samples_requested BETWEEN 1 AND 99),
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
    CHECK (state <> 'complete' OR (radiance_json IS NOT NULL AND luminance_cd_m2 IS NOT NULL))
);
CREATE INDEX measurements_scene ON measurements (scene, target);
CREATE INDEX measurements_state ON measurements (state);

-- Every raw sample, written when it is taken (before the next one starts).
CREATE TABLE samples (
    id               INTEGER PRIMARY KEY,
    measurement_id   INTEGER NOT NULL REFERENCES measurements (id) ON DELETE CASCADE,
    idx              INTEGER NOT NULL,   -- 0-based order within the measurement, retries included
    taken_at         REAL NOT NULL,
    code             INTEGER NOT NULL,   -- the instrument's quality code from the report (0 = OK)
    message          TEXT NOT NULL,      -- the code's meaning
    usable           INTEGER NOT NULL CHECK (usable IN (0, 1)),  -- 0: never averaged (stale buffer, error)
    radiance_json    TEXT,               -- NULL when the instrument gave no valid spectrum
    luminance_cd_m2  REAL,
    UNIQUE (measurement_id, idx)
);

CREATE TABLE renders (
    id             INTEGER PRIMARY KEY,
    scene          TEXT NOT NULL,
    scene_hash     TEXT NOT NULL,        -- hash of the scene file and everything it references
    settings_json  TEXT NOT NULL,        -- samples, bounces, seed, codings
    codings        TEXT NOT NULL,        -- comma-separated
    seed           INTEGER NOT NULL,
    state          TEXT NOT NULL CHECK (state IN ('queued', 'running', 'complete', 'failed')),
    error          TEXT,
    created_at     REAL NOT NULL,
    finished_at    REAL,
    wall_seconds   REAL,
    result_json    TEXT                  -- per target and coding: XYZ, Y, Y_se, x, y, spectrum
);
CREATE INDEX renders_scene ON renders (scene);

-- One row per (measurement, coding): how far the rendering is from the measurement.
CREATE TABLE comparisons (
    id               INTEGER PRIMARY KEY,
    measurement_id   INTEGER NOT NULL REFERENCES measurements (id),
    render_id        INTEGER NOT NULL REFERENCES renders (id),
    scene            TEXT NOT NULL,
    target           TEXT NOT NULL,
    coding           TEXT NOT NULL,
    white_source     TEXT NOT NULL,      -- which CIELAB reference white: a measurement id or a stated illuminant
    white_x          REAL NOT NULL,      -- the white's XYZ, as used
    white_y          REAL NOT NULL,
    white_z          REAL NOT NULL,
    measured_x       REAL NOT NULL,      -- measured XYZ (Y in cd/m²)
    measured_y       REAL NOT NULL,
    measured_z       REAL NOT NULL,
    rendered_x       REAL NOT NULL,
    rendered_y       REAL NOT NULL,
    rendered_z       REAL NOT NULL,
    rendered_y_se    REAL NOT NULL,      -- Monte Carlo standard error of the rendered Y
    y_ratio          REAL NOT NULL,      -- rendered Y / measured Y
    xy_distance      REAL NOT NULL,
    de76             REAL NOT NULL,
    de00             REAL NOT NULL,
    created_at       REAL NOT NULL,
    UNIQUE (measurement_id, render_id, coding)
);
CREATE INDEX comparisons_scene ON comparisons (scene, coding);
