-- A colorimeter's and a luminance meter's measurements (issue 33).
--
-- A sample from an instrument that gives no spectrum keeps the X, Y, Z it
-- reported (a JSON array, cd/m², in the observer its measurement names); a
-- spectroradiometer's own XYZ (the CS-2000's) is kept the same way. NULL
-- when the instrument sent none.
--
-- A complete measurement needed a mean spectrum; now it needs a luminance
-- only (a luminance meter gives nothing else; a colorimeter adds XYZ and
-- x, y). SQLite cannot alter a CHECK constraint, so `measurements` is
-- rebuilt as in 0012: every column (0018's hold columns included), row and
-- id; every index on it; and 0014's count triggers, recreated after the
-- rows are back so the counts are not counted twice. Foreign keys are
-- deferred to the commit, and `samples` (ON DELETE CASCADE) is set aside
-- and restored with its ids.
ALTER TABLE samples ADD COLUMN xyz_json TEXT;

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
    -- The average, written only when the measurement is complete; the
    -- spectrum's columns stay NULL for an instrument that gives none.
    wavelength_json    TEXT,            -- native grid, nm
    radiance_json      TEXT,            -- mean, W/(sr·m²·nm)
    radiance_sd_json   TEXT,            -- per-wavelength standard deviation, W/(sr·m²·nm)
    luminance_cd_m2    REAL,
    x                  REAL,
    y                  REAL,
    luminance_cv       REAL,
    observer           TEXT,            -- 0006: x, y, XYZ below are in this observer
    xyz_x              REAL,
    xyz_y              REAL,
    xyz_z              REAL,
    booth              TEXT NOT NULL DEFAULT 'default',       -- 0009
    daemon_id          INTEGER REFERENCES daemons (id),       -- 0010
    hold_id            INTEGER,                               -- 0018
    hold_purpose       TEXT,                                  -- 0018
    CHECK (state <> 'complete' OR luminance_cd_m2 IS NOT NULL)
);
INSERT INTO measurements (id, session_id, instrument_id, scene, target, samples_requested, settings_json, state,
                          error, note, created_at, started_at, finished_at, wavelength_json, radiance_json,
                          radiance_sd_json, luminance_cd_m2, x, y, luminance_cv, observer, xyz_x, xyz_y, xyz_z,
                          booth, daemon_id, hold_id, hold_purpose)
    SELECT id, session_id, instrument_id, scene, target, samples_requested, settings_json, state,
           error, note, created_at, started_at, finished_at, wavelength_json, radiance_json,
           radiance_sd_json, luminance_cd_m2, x, y, luminance_cv, observer, xyz_x, xyz_y, xyz_z,
           booth, daemon_id, hold_id, hold_purpose FROM measurements_keep;
INSERT INTO samples SELECT * FROM samples_keep WHERE NOT EXISTS (SELECT 1 FROM samples s WHERE s.id = samples_keep.id);
DROP TABLE measurements_keep;
DROP TABLE samples_keep;
CREATE INDEX measurements_scene ON measurements (scene, target);
CREATE INDEX measurements_state ON measurements (state);
CREATE INDEX measurements_newest ON measurements (id);
CREATE INDEX measurements_by_scene ON measurements (scene);
CREATE INDEX measurements_booth ON measurements (booth, id);
CREATE INDEX measurements_daemon ON measurements (daemon_id, state);

CREATE TRIGGER measurements_count_insert AFTER INSERT ON measurements BEGIN
    INSERT INTO booth_measurement_counts (booth, measurements, last_measurement_at)
        VALUES (NEW.booth, 1, NEW.created_at)
        ON CONFLICT (booth) DO UPDATE SET
            measurements = measurements + 1,
            last_measurement_at = MAX(COALESCE(last_measurement_at, excluded.last_measurement_at),
                                      excluded.last_measurement_at);
END;

-- Measurements are never deleted by lightbooth; a hand-made DELETE (or a
-- booth renamed by hand) still leaves the counts exact.
CREATE TRIGGER measurements_count_delete AFTER DELETE ON measurements BEGIN
    UPDATE booth_measurement_counts SET
        measurements = measurements - 1,
        last_measurement_at = (SELECT MAX(created_at) FROM measurements WHERE booth = OLD.booth)
        WHERE booth = OLD.booth;
END;

CREATE TRIGGER measurements_count_move AFTER UPDATE OF booth, created_at ON measurements BEGIN
    UPDATE booth_measurement_counts SET
        measurements = measurements - 1,
        last_measurement_at = (SELECT MAX(created_at) FROM measurements WHERE booth = OLD.booth)
        WHERE booth = OLD.booth;
    INSERT INTO booth_measurement_counts (booth, measurements, last_measurement_at)
        VALUES (NEW.booth, 1, NEW.created_at)
        ON CONFLICT (booth) DO UPDATE SET
            measurements = measurements + 1,
            last_measurement_at = (SELECT MAX(created_at) FROM measurements WHERE booth = NEW.booth);
END;
