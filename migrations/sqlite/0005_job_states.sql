-- Renders and studies are jobs like measurements: they wait in a bounded
-- queue, can be cancelled, and a crash or shutdown leaves them `interrupted`
-- (never `running` forever). SQLite cannot alter a CHECK constraint, so both
-- tables are rebuilt with the wider state set, keeping every row and id.
--
-- sqlx runs this in one transaction, where `PRAGMA foreign_keys = OFF` has no
-- effect; instead foreign keys are deferred to the commit: dropping `renders`
-- orphans the comparisons' references for a moment, and re-inserting the
-- same ids into the new table resolves them before the commit checks.
-- `study_files` (ON DELETE CASCADE) is set aside and restored, so dropping
-- `studies` deletes nothing.
PRAGMA defer_foreign_keys = ON;

CREATE TEMP TABLE renders_keep AS SELECT * FROM renders;
DROP TABLE renders;
CREATE TABLE renders (
    id             INTEGER PRIMARY KEY,
    scene          TEXT NOT NULL,
    scene_hash     TEXT NOT NULL,        -- hash of the scene file and everything it references
    settings_json  TEXT NOT NULL,        -- samples, bounces, seed, codings
    codings        TEXT NOT NULL,        -- comma-separated
    seed           INTEGER NOT NULL,
    state          TEXT NOT NULL CHECK (state IN ('queued', 'running', 'complete', 'failed', 'interrupted', 'cancelled')),
    error          TEXT,                 -- why it failed, was interrupted or cancelled
    created_at     REAL NOT NULL,
    finished_at    REAL,
    wall_seconds   REAL,
    result_json    TEXT,                 -- per target and coding: XYZ, Y, Y_se, x, y, spectrum
    preview_png    BLOB,
    CHECK (state <> 'complete' OR result_json IS NOT NULL)
);
INSERT INTO renders (id, scene, scene_hash, settings_json, codings, seed, state, error, created_at,
                     finished_at, wall_seconds, result_json, preview_png)
    SELECT id, scene, scene_hash, settings_json, codings, seed, state, error, created_at,
           finished_at, wall_seconds, result_json, preview_png FROM renders_keep;
DROP TABLE renders_keep;
CREATE INDEX renders_scene ON renders (scene);

CREATE TEMP TABLE studies_keep AS SELECT * FROM studies;
CREATE TEMP TABLE study_files_keep AS SELECT * FROM study_files;
DROP TABLE study_files;
DROP TABLE studies;
CREATE TABLE studies (
    id            INTEGER PRIMARY KEY,
    request_json  TEXT NOT NULL,
    state         TEXT NOT NULL CHECK (state IN ('queued', 'running', 'complete', 'failed', 'interrupted', 'cancelled')),
    error         TEXT,
    created_at    REAL NOT NULL,
    finished_at   REAL,
    wall_seconds  REAL,
    result_json   TEXT,
    CHECK (state <> 'complete' OR result_json IS NOT NULL)
);
CREATE TABLE study_files (
    study_id  INTEGER NOT NULL REFERENCES studies (id) ON DELETE CASCADE,
    name      TEXT NOT NULL,      -- index.html, cylinder_speed.svg, figures.csv, …
    content   BLOB NOT NULL,
    PRIMARY KEY (study_id, name)
);
INSERT INTO studies (id, request_json, state, error, created_at, finished_at, wall_seconds, result_json)
    SELECT id, request_json, state, error, created_at, finished_at, wall_seconds, result_json FROM studies_keep;
INSERT INTO study_files (study_id, name, content) SELECT study_id, name, content FROM study_files_keep;
DROP TABLE studies_keep;
DROP TABLE study_files_keep;
