-- Several booths share one database (issue 14): every measurement names the
-- booth it was taken in (`serve --booth NAME`), and every instrument the
-- booth it was last seen in. Rows from before booths were recorded belong to
-- the one booth a single-booth lab had: 'default', the name a daemon started
-- without --booth uses.
ALTER TABLE measurements ADD COLUMN booth TEXT NOT NULL DEFAULT 'default';
ALTER TABLE instruments ADD COLUMN booth TEXT NOT NULL DEFAULT 'default';
CREATE INDEX measurements_booth ON measurements (booth, id);
