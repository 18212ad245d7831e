-- A colorimeter's and a luminance meter's measurements (issue 33).
--
-- A sample from an instrument that gives no spectrum keeps the X, Y, Z it
-- reported (a JSON array, cd/m², in the observer its measurement names); a
-- spectroradiometer's own XYZ (the CS-2000's) is kept the same way. NULL
-- when the instrument sent none.
ALTER TABLE samples ADD COLUMN xyz_json TEXT;
-- A complete measurement needed a mean spectrum; now it needs a luminance
-- only (a luminance meter gives nothing else; a colorimeter adds XYZ and
-- x, y). The unnamed table constraint of 0001 is `measurements_check`.
ALTER TABLE measurements DROP CONSTRAINT measurements_check;
ALTER TABLE measurements ADD CONSTRAINT measurements_complete_has_luminance
    CHECK (state <> 'complete' OR luminance_cd_m2 IS NOT NULL);
