-- A daemon owns only its own work (issue 14): every daemon registers a row
-- here at start and renews `heartbeat_at` every few seconds; a daemon whose
-- heartbeat is older than its `lease_seconds`, or that has `stopped_at`, no
-- longer owns anything, and whoever notices marks its unfinished
-- measurements, renders and studies interrupted. Times are POSIX seconds
-- from the database's own clock, so booth PCs need not agree on the time.
CREATE TABLE daemons (
    id INTEGER PRIMARY KEY,
    booth TEXT NOT NULL,
    host TEXT NOT NULL,
    pid INTEGER NOT NULL,
    lease_seconds REAL NOT NULL CHECK (lease_seconds > 0),
    started_at REAL NOT NULL,
    heartbeat_at REAL NOT NULL,
    stopped_at REAL
);
-- The daemon that created or runs each row; NULL for rows from before
-- leases (and rows a one-shot tool writes).
ALTER TABLE measurements ADD COLUMN daemon_id INTEGER REFERENCES daemons (id);
ALTER TABLE renders ADD COLUMN daemon_id INTEGER REFERENCES daemons (id);
ALTER TABLE studies ADD COLUMN daemon_id INTEGER REFERENCES daemons (id);
CREATE INDEX measurements_daemon ON measurements (daemon_id, state);
CREATE INDEX renders_daemon ON renders (daemon_id, state);
CREATE INDEX studies_daemon ON studies (daemon_id, state);
