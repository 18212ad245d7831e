-- A colorimeter's reading (issue 33): a sample from an instrument that
-- gives no spectrum keeps the X, Y, Z it reported (a JSON array, cd/m²,
-- in the observer its measurement names); a spectroradiometer's own XYZ
-- (the CS-2000's) is kept the same way. NULL when the instrument sent none.
ALTER TABLE samples ADD COLUMN xyz_json TEXT;
