-- Listing measurements newest first must not walk the table itself: its rows
-- hold three spectra each, so a scan touches thousands of pages. These
-- indexes are small and ordered by id (SQLite appends the rowid), so paging
-- with or without a scene or state filter reads only index pages.
CREATE INDEX measurements_newest ON measurements (id);
CREATE INDEX measurements_by_scene ON measurements (scene);
