-- One observer, stated everywhere; the white each comparison used; the
-- measurement's standard error for the beyond-noise test (migrations/sqlite/0006).
ALTER TABLE comparisons ADD COLUMN observer TEXT NOT NULL DEFAULT 'judd-vos-1978';
ALTER TABLE comparisons ADD COLUMN measured_y_se DOUBLE PRECISION;

ALTER TABLE measurements ADD COLUMN observer TEXT;
ALTER TABLE measurements ADD COLUMN xyz_x DOUBLE PRECISION;
ALTER TABLE measurements ADD COLUMN xyz_y DOUBLE PRECISION;
ALTER TABLE measurements ADD COLUMN xyz_z DOUBLE PRECISION;
