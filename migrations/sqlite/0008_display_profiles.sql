-- Display profiles measured with the PR-650 (src/display): the whole fitted
-- profile as JSON (primaries, black level, transfer fits and tables,
-- additivity, validation), its observer, and its provenance — the ids of the
-- measurements it was fitted to.

CREATE TABLE display_profiles (
    id                    INTEGER PRIMARY KEY,
    name                  TEXT NOT NULL,
    created_at            REAL NOT NULL,
    observer              TEXT NOT NULL,   -- of every XYZ in the profile
    measurement_ids_json  TEXT NOT NULL,   -- JSON array of measurements.id
    profile_json          TEXT NOT NULL,   -- crate::display::DisplayProfile
    note                  TEXT NOT NULL DEFAULT ''
);
