-- Renders and studies are jobs like measurements: queued, cancellable, and
-- left `interrupted` by a crash or shutdown (migrations/sqlite/0005, which
-- has to rebuild both tables; PostgreSQL alters the constraints in place).
ALTER TABLE renders
    DROP CONSTRAINT renders_state_check,
    ADD CONSTRAINT renders_state_check
        CHECK (state IN ('queued', 'running', 'complete', 'failed', 'interrupted', 'cancelled')),
    ADD CHECK (state <> 'complete' OR result_json IS NOT NULL);

ALTER TABLE studies
    DROP CONSTRAINT studies_state_check,
    ADD CONSTRAINT studies_state_check
        CHECK (state IN ('queued', 'running', 'complete', 'failed', 'interrupted', 'cancelled'));
