-- Each booth's measurement count and newest request time, kept by triggers
-- (issue 14's scale test): `/api/booths` and the total of an unfiltered or
-- booth-filtered listing read them instead of counting every measurement
-- on each request (a 100 000-row lab answered /api/booths in 0.7 s;
-- `cargo bench --bench api_load -- --postgres`). Same table as
-- migrations/sqlite/0014, with the same counts.
--
-- Inserts and deletes are counted per statement (transition tables): one
-- upsert per booth and statement, since a booth's row updated once per
-- inserted row within one transaction (a COPY, a bulk INSERT) leaves a
-- chain of versions each later update walks, quadratic in the rows. The
-- upsert locks the booth's row until the transaction ends: each booth's
-- daemon inserts its own rows, so booths never wait for each other.
CREATE TABLE booth_measurement_counts (
    booth                TEXT PRIMARY KEY,
    measurements         BIGINT NOT NULL CHECK (measurements >= 0),
    last_measurement_at  DOUBLE PRECISION
);
INSERT INTO booth_measurement_counts (booth, measurements, last_measurement_at)
    SELECT booth, COUNT(*), MAX(created_at) FROM measurements GROUP BY booth;

CREATE FUNCTION measurements_count_inserted() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
    INSERT INTO booth_measurement_counts (booth, measurements, last_measurement_at)
        SELECT booth, COUNT(*), MAX(created_at) FROM inserted_rows GROUP BY booth
        ON CONFLICT (booth) DO UPDATE SET
            measurements = booth_measurement_counts.measurements + excluded.measurements,
            last_measurement_at = GREATEST(booth_measurement_counts.last_measurement_at,
                                           excluded.last_measurement_at);
    RETURN NULL;
END;
$$;
CREATE TRIGGER measurements_count_insert AFTER INSERT ON measurements
    REFERENCING NEW TABLE AS inserted_rows
    FOR EACH STATEMENT EXECUTE FUNCTION measurements_count_inserted();

-- Measurements are never deleted by lightbooth; a hand-made DELETE (or a
-- booth renamed by hand) still leaves the counts exact.
CREATE FUNCTION measurements_count_deleted() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
    UPDATE booth_measurement_counts c SET
        measurements = c.measurements - d.n,
        last_measurement_at = (SELECT MAX(created_at) FROM measurements m WHERE m.booth = c.booth)
        FROM (SELECT booth, COUNT(*) AS n FROM deleted_rows GROUP BY booth) d
        WHERE c.booth = d.booth;
    RETURN NULL;
END;
$$;
CREATE TRIGGER measurements_count_delete AFTER DELETE ON measurements
    REFERENCING OLD TABLE AS deleted_rows
    FOR EACH STATEMENT EXECUTE FUNCTION measurements_count_deleted();

-- A row moved to another booth (or its time changed): per row, as only a
-- hand-made UPDATE does it.
CREATE FUNCTION measurements_count_moved() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
    UPDATE booth_measurement_counts SET
        measurements = measurements - 1,
        last_measurement_at = (SELECT MAX(created_at) FROM measurements WHERE booth = OLD.booth)
        WHERE booth = OLD.booth;
    INSERT INTO booth_measurement_counts (booth, measurements, last_measurement_at)
        VALUES (NEW.booth, 1, NEW.created_at)
        ON CONFLICT (booth) DO UPDATE SET
            measurements = booth_measurement_counts.measurements + 1,
            last_measurement_at = (SELECT MAX(created_at) FROM measurements WHERE booth = NEW.booth);
    RETURN NULL;
END;
$$;
CREATE TRIGGER measurements_count_move AFTER UPDATE OF booth, created_at ON measurements
    FOR EACH ROW EXECUTE FUNCTION measurements_count_moved();
