-- One retry per render or study (issue 32): two simultaneous
-- `POST /api/renders/{id}/retry` each queued a render, and ten queued eight.
-- A retry records the job it retries; the unique index lets exactly one row
-- name it (NULLs, the jobs that are no retry, are distinct), so the second
-- retry fails in the INSERT and answers 409 with the first retry's id.
ALTER TABLE renders ADD COLUMN retry_of BIGINT REFERENCES renders (id);
CREATE UNIQUE INDEX renders_retry_of ON renders (retry_of);
ALTER TABLE studies ADD COLUMN retry_of BIGINT REFERENCES studies (id);
CREATE UNIQUE INDEX studies_retry_of ON studies (retry_of);
