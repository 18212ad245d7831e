-- The study's discrimination experiment (issue 24, src/psychophysics):
-- an oddity experiment on one scene's target, its observers, their
-- sessions and every trial, written as it ends (a closed tab or a crashed
-- daemon loses at most the trial on screen; a session resumes from its
-- trials). The trial order is not stored: it follows from the session's
-- seed (psychophysics::design::session_order, SplitMix64, specified to the
-- bit), followed by a repeat of every trial with a dropped frame during
-- its pie. Same tables as migrations/postgres/0015.

CREATE TABLE experiments (
    id                  INTEGER PRIMARY KEY,
    name                TEXT NOT NULL,
    created_at          REAL NOT NULL,
    scene               TEXT NOT NULL,
    target              TEXT NOT NULL,
    booth               TEXT NOT NULL,
    measurement_id      INTEGER NOT NULL REFERENCES measurements (id),
    display_profile_id  INTEGER NOT NULL REFERENCES display_profiles (id),
    output_method       TEXT NOT NULL CHECK (output_method IN ('8bit', 'noisy_bit', '10bit')),
    seed                INTEGER NOT NULL CHECK (seed >= 0),
    request_json        TEXT NOT NULL,   -- lab::experiments::ExperimentRequest, defaults filled in
    check_json          TEXT NOT NULL    -- display::output::ColourCheck at creation
);

-- An observer is an id, no name needed.
CREATE TABLE observers (
    id          TEXT PRIMARY KEY NOT NULL CHECK (length(id) BETWEEN 1 AND 64),
    created_at  REAL NOT NULL
);

CREATE TABLE experiment_sessions (
    id             INTEGER PRIMARY KEY,
    experiment_id  INTEGER NOT NULL REFERENCES experiments (id),
    observer_id    TEXT NOT NULL REFERENCES observers (id),
    seed           INTEGER NOT NULL CHECK (seed >= 0),
    created_at     REAL NOT NULL,
    state          TEXT NOT NULL CHECK (state IN ('running', 'complete')),
    finished_at    REAL,
    -- The page's measurement of the display's refresh: median frame interval, ms.
    frame_ms       REAL,
    client         TEXT NOT NULL DEFAULT ''   -- the page's user agent and output path, as it said
);
CREATE INDEX experiment_sessions_by_experiment ON experiment_sessions (experiment_id, observer_id);

CREATE TABLE trials (
    session_id           INTEGER NOT NULL REFERENCES experiment_sessions (id),
    position             INTEGER NOT NULL CHECK (position >= 0),   -- 0, 1, … in the order shown
    approximation        TEXT NOT NULL,                             -- the coding tested against the original
    configuration        TEXT NOT NULL CHECK (length(configuration) = 3),  -- e.g. 'OON', left top right
    response             INTEGER NOT NULL CHECK (response BETWEEN 0 AND 2), -- 0 left, 1 top, 2 right
    correct              INTEGER NOT NULL CHECK (correct IN (0, 1)),
    reaction_ms          REAL NOT NULL,    -- key event's timeStamp − the pie's first frame
    stimulus_frames      INTEGER NOT NULL, -- frames the pie was on screen
    dropped_frames       INTEGER NOT NULL, -- intervals over 1.5 frames during the trial
    dropped_in_stimulus  INTEGER NOT NULL CHECK (dropped_in_stimulus IN (0, 1)),
    frame_intervals_json TEXT NOT NULL,    -- every frame interval of the trial, ms
    created_at           REAL NOT NULL,
    PRIMARY KEY (session_id, position)
);

-- Verification of an experiment's colours on its display: each colour shown
-- full-field and measured through the calibration path (measurement ids
-- kept in the result), ΔE00 to what was intended and to the booth measurement.
CREATE TABLE experiment_verifications (
    id             INTEGER PRIMARY KEY,
    experiment_id  INTEGER NOT NULL REFERENCES experiments (id),
    created_at     REAL NOT NULL,
    result_json    TEXT NOT NULL
);
