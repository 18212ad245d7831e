-- The number of samples a measurement may request is the instrument's
-- limit, stated by its driver (the PR-650's 1–99 lives in src/instrument),
-- not the schema's: other instruments average more. The schema keeps only
-- what holds for every instrument: at least one sample.
ALTER TABLE measurements DROP CONSTRAINT measurements_samples_requested_check;
ALTER TABLE measurements ADD CONSTRAINT measurements_samples_requested_check CHECK (samples_requested >= 1);
