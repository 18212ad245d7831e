-- One observer, stated everywhere; the white each comparison used; the
-- measurement's standard error for the beyond-noise test.
--
-- Every comparison names the observer of its XYZ, x,y, CIELAB and ΔE. Rows
-- written before this migration were all computed with Judd–Vos 1978 (the
-- observer was fixed in the code), so that is their value.
ALTER TABLE comparisons ADD COLUMN observer TEXT NOT NULL DEFAULT 'judd-vos-1978';
-- Standard error of the measured Y (the usable samples' SD/√n), cd/m²;
-- NULL for rows written before it was recorded.
ALTER TABLE comparisons ADD COLUMN measured_y_se REAL;

-- x, y and XYZ of a measurement computed by lightbooth from its mean
-- spectrum with the daemon's observer (named here); the x, y columns of the
-- table stay the instrument's own on-board CIE 1931 values.
ALTER TABLE measurements ADD COLUMN observer TEXT;
ALTER TABLE measurements ADD COLUMN xyz_x REAL;
ALTER TABLE measurements ADD COLUMN xyz_y REAL;
ALTER TABLE measurements ADD COLUMN xyz_z REAL;
