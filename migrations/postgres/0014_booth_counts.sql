-- Each booth's measurement count and newest request time, kept by triggers
-- (issue 14's scale test): `/api/booths` and the total of an unfiltered or
-- booth-filtered listing read them instead of counting every measurement
-- on each request (a 100 000-row lab answered /api/booths in 0.7 s;
-- `cargo bench --bench api_load -- --postgres`). Same table and triggers
-- as migrations/sqlite/0014. The upsert locks the booth's row until the
-- inserting transaction ends: each booth's daemon inserts its own rows, one
-- at a time, so booths never wait for each other.
CREATE TABLE booth_measurement_counts (
    booth                TEXT PRIMARY KEY,
    measurements         BIGINT NOT NULL CHECK (measurements >= 0),
    last_measurement_at  DOUBLE PRECISION
);
INSERT INTO booth_measurement_counts (booth, measurements, last_measurement_at)
    SELECT booth, COUNT(*), MAX(created_at) FROM measurements GROUP BY booth;

CREATE FUNCTION measurements_count_change() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
    IF TG_OP IN ('DELETE', 'UPDATE') THEN
        UPDATE booth_measurement_counts SET
            measurements = measurements - 1,
            last_measurement_at = (SELECT MAX(created_at) FROM measurements WHERE booth = OLD.booth)
            WHERE booth = OLD.booth;
    END IF;
    IF TG_OP = 'INSERT' THEN
        INSERT INTO booth_measurement_counts (booth, measurements, last_measurement_at)
            VALUES (NEW.booth, 1, NEW.created_at)
            ON CONFLICT (booth) DO UPDATE SET
                measurements = booth_measurement_counts.measurements + 1,
                last_measurement_at = GREATEST(booth_measurement_counts.last_measurement_at,
                                               excluded.last_measurement_at);
    ELSIF TG_OP = 'UPDATE' THEN
        INSERT INTO booth_measurement_counts (booth, measurements, last_measurement_at)
            VALUES (NEW.booth, 1, NEW.created_at)
            ON CONFLICT (booth) DO UPDATE SET
                measurements = booth_measurement_counts.measurements + 1,
                last_measurement_at = (SELECT MAX(created_at) FROM measurements WHERE booth = NEW.booth);
    END IF;
    RETURN NULL;
END;
$$;
-- Measurements are never deleted by lightbooth; a hand-made DELETE (or a
-- booth renamed by hand) still leaves the counts exact.
CREATE TRIGGER measurements_count_insert AFTER INSERT OR DELETE ON measurements
    FOR EACH ROW EXECUTE FUNCTION measurements_count_change();
CREATE TRIGGER measurements_count_move AFTER UPDATE OF booth, created_at ON measurements
    FOR EACH ROW EXECUTE FUNCTION measurements_count_change();
