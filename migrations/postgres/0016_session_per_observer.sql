-- One running session per observer and experiment (issue 32: two tabs
-- starting the same observer at once created two running sessions with
-- the same seed). A second start finds the running session and resumes it
-- (INSERT … ON CONFLICT DO NOTHING, then the running one is read).
--
-- Running sessions that were already duplicated are not marked complete
-- (they are not): every one but the one with the most trials (the lowest
-- id among equals) is marked superseded by it, keeps its trials (counted
-- in the analysis) and is no longer resumed or listed as running. Same
-- column and index as migrations/sqlite/0016.
ALTER TABLE experiment_sessions ADD COLUMN superseded_by BIGINT REFERENCES experiment_sessions (id);

UPDATE experiment_sessions AS s SET superseded_by = (
    SELECT k.id FROM experiment_sessions k
    WHERE k.experiment_id = s.experiment_id AND k.observer_id = s.observer_id AND k.state = 'running'
    ORDER BY (SELECT COUNT(*) FROM trials t WHERE t.session_id = k.id) DESC, k.id
    LIMIT 1
)
WHERE s.state = 'running';
UPDATE experiment_sessions SET superseded_by = NULL WHERE superseded_by = id;

-- When the session was last touched (started, its display reported, a
-- trial recorded): a running session untouched for a while is listed as
-- paused (lab::experiments::session::PAUSED_AFTER_S), resumable.
ALTER TABLE experiment_sessions ADD COLUMN touched_at DOUBLE PRECISION;
UPDATE experiment_sessions AS s SET touched_at = COALESCE(
    (SELECT MAX(t.created_at) FROM trials t WHERE t.session_id = s.id), s.created_at);

CREATE UNIQUE INDEX experiment_sessions_one_running
    ON experiment_sessions (experiment_id, observer_id)
    WHERE state = 'running' AND superseded_by IS NULL;
