-- Each booth's measurement count and newest request time, kept by triggers
-- (issue 14's scale test): `/api/booths` and the total of an unfiltered or
-- booth-filtered listing read them instead of counting every measurement
-- on each request (a 100 000-row lab answered /api/booths in 0.7 s on
-- PostgreSQL; `cargo bench --bench api_load -- --postgres`). Same table
-- and counts as migrations/postgres/0014 (which counts inserts per
-- statement; SQLite updates a row in place, so per row costs nothing more).
CREATE TABLE booth_measurement_counts (
    booth                TEXT PRIMARY KEY NOT NULL,
    measurements         INTEGER NOT NULL CHECK (measurements >= 0),
    last_measurement_at  REAL
);
INSERT INTO booth_measurement_counts (booth, measurements, last_measurement_at)
    SELECT booth, COUNT(*), MAX(created_at) FROM measurements GROUP BY booth;

CREATE TRIGGER measurements_count_insert AFTER INSERT ON measurements BEGIN
    INSERT INTO booth_measurement_counts (booth, measurements, last_measurement_at)
        VALUES (NEW.booth, 1, NEW.created_at)
        ON CONFLICT (booth) DO UPDATE SET
            measurements = measurements + 1,
            last_measurement_at = MAX(COALESCE(last_measurement_at, excluded.last_measurement_at),
                                      excluded.last_measurement_at);
END;

-- Measurements are never deleted by lightbooth; a hand-made DELETE (or a
-- booth renamed by hand) still leaves the counts exact.
CREATE TRIGGER measurements_count_delete AFTER DELETE ON measurements BEGIN
    UPDATE booth_measurement_counts SET
        measurements = measurements - 1,
        last_measurement_at = (SELECT MAX(created_at) FROM measurements WHERE booth = OLD.booth)
        WHERE booth = OLD.booth;
END;

CREATE TRIGGER measurements_count_move AFTER UPDATE OF booth, created_at ON measurements BEGIN
    UPDATE booth_measurement_counts SET
        measurements = measurements - 1,
        last_measurement_at = (SELECT MAX(created_at) FROM measurements WHERE booth = OLD.booth)
        WHERE booth = OLD.booth;
    INSERT INTO booth_measurement_counts (booth, measurements, last_measurement_at)
        VALUES (NEW.booth, 1, NEW.created_at)
        ON CONFLICT (booth) DO UPDATE SET
            measurements = measurements + 1,
            last_measurement_at = (SELECT MAX(created_at) FROM measurements WHERE booth = NEW.booth);
END;
