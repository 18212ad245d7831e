-- Render workers (issue 14): comparison, render and study jobs that any
-- `lightbooth worker` sharing the database may claim. A daemon started with
-- `--renders workers` queues its jobs here instead of running them itself;
-- a worker claims the oldest queued job (on PostgreSQL with
-- `FOR UPDATE SKIP LOCKED`), holds it under its own lease in `daemons`, and
-- a job whose worker is gone is queued again for another (`attempts`
-- counts the claims).
--
-- `subject_id` is the row the job is about: the measurement a comparison
-- compares, the render or study row it runs. `payload_json` carries what
-- the worker needs beyond that row (a comparison's measured XYZ).
CREATE TABLE worker_jobs (
    id INTEGER PRIMARY KEY,
    kind TEXT NOT NULL CHECK (kind IN ('comparison', 'render', 'study')),
    subject_id INTEGER NOT NULL,
    -- The scene a comparison or render is of ('' for a study): a worker
    -- prefers a job whose scene no running comparison is rendering.
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
CREATE INDEX worker_jobs_queue ON worker_jobs (state, id);
CREATE INDEX worker_jobs_worker ON worker_jobs (worker_id, state);
CREATE INDEX worker_jobs_requester ON worker_jobs (requested_by, finished_at);
-- What a registered process is: a booth's daemon, a render worker, or a
-- one-shot tool. A daemon leaving its renders to workers publishes what a
-- worker needs to render for it (its scenes' bundles, codings, samples,
-- observer) in `render_config_json`.
ALTER TABLE daemons ADD COLUMN role TEXT NOT NULL DEFAULT 'daemon' CHECK (role IN ('daemon', 'worker', 'tool'));
ALTER TABLE daemons ADD COLUMN render_config_json TEXT;
