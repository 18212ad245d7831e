-- Study runs: the request, the state, every figure (JSON) and the report's
-- files (HTML, SVG charts, CSVs), so a study can be audited and shown later.
CREATE TABLE studies (
    id            INTEGER PRIMARY KEY,
    request_json  TEXT NOT NULL,
    state         TEXT NOT NULL CHECK (state IN ('running', 'complete', 'failed', 'interrupted')),
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
