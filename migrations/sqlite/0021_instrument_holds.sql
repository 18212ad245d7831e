-- Instrument holds (issue 46): a hold's id is drawn here, so ids never
-- repeat: not after a daemon restart (a calibration page left open across
-- one posted into another client's new hold 1) and not between the
-- daemons of one PostgreSQL database (measurements keep `hold_id`). One
-- row per hold taken, never deleted; AUTOINCREMENT so an id is never
-- reused even if one were.
CREATE TABLE instrument_holds (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    booth TEXT NOT NULL,
    purpose TEXT NOT NULL,
    taken_at REAL NOT NULL,
    daemon_id INTEGER REFERENCES daemons (id)
);
