-- Camera images on render workers (issue 48): a daemon leaving its renders
-- to workers splits an image's paths into batches, each a worker job of
-- kind `image` whose subject is a row here. The worker renders its batch
-- (its own first path index, so the batches together are the paths one
-- machine would trace) and leaves the batch's moments here; the daemon
-- merges them into the image it keeps in memory and deletes the row.
-- (Workers share PostgreSQL; the SQLite schema keeps the same shape.)
-- SQLite cannot change a CHECK in place: `worker_jobs` is rebuilt.
CREATE TABLE worker_jobs_new (
    id INTEGER PRIMARY KEY,
    kind TEXT NOT NULL CHECK (kind IN ('comparison', 'render', 'study', 'image')),
    subject_id INTEGER NOT NULL,
    scene TEXT NOT NULL DEFAULT '',
    requested_by INTEGER NOT NULL REFERENCES daemons (id),
    payload_json TEXT NOT NULL,
    state TEXT NOT NULL CHECK (state IN ('queued', 'running', 'done', 'failed', 'cancelled')),
    worker_id INTEGER REFERENCES daemons (id),
    attempts INTEGER NOT NULL DEFAULT 0,
    cancel_requested INTEGER NOT NULL DEFAULT 0 CHECK (cancel_requested IN (0, 1)),
    error TEXT,
    created_at REAL NOT NULL,
    started_at REAL,
    finished_at REAL,
    UNIQUE (kind, subject_id)
);
INSERT INTO worker_jobs_new (id, kind, subject_id, scene, requested_by, payload_json, state, worker_id,
    attempts, cancel_requested, error, created_at, started_at, finished_at)
SELECT id, kind, subject_id, scene, requested_by, payload_json, state, worker_id,
    attempts, cancel_requested, error, created_at, started_at, finished_at FROM worker_jobs;
DROP TABLE worker_jobs;
ALTER TABLE worker_jobs_new RENAME TO worker_jobs;
CREATE INDEX worker_jobs_queue ON worker_jobs (state, id);
CREATE INDEX worker_jobs_worker ON worker_jobs (worker_id, state);
CREATE INDEX worker_jobs_requester ON worker_jobs (requested_by, finished_at);
CREATE TABLE image_batches (
    id INTEGER PRIMARY KEY,
    requested_by INTEGER NOT NULL REFERENCES daemons (id),
    moments BLOB,
    created_at REAL NOT NULL
);
CREATE INDEX image_batches_requester ON image_batches (requested_by);
