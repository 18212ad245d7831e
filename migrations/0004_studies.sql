-- Study runs: the settings and every figure (JSON), so a study can be
-- audited and its charts redrawn later.
CREATE TABLE studies (
    id            INTEGER PRIMARY KEY,
    created_at    REAL NOT NULL,
    wall_seconds  REAL NOT NULL,
    result_json   TEXT NOT NULL
);
