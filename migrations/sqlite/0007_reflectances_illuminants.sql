-- Reflectances and lamp spectra measured in the booth against a white
-- standard (src/calibration), each with its provenance: the measurements it
-- came from, the standard's calibration file by name and SHA-256, and when.
-- Spectra are JSON arrays on the instrument's grid (wavelength_json).

CREATE TABLE reflectances (
    id                       INTEGER PRIMARY KEY,
    name                     TEXT NOT NULL,       -- the column name of its scene CSV
    sample_measurement_id    INTEGER NOT NULL REFERENCES measurements (id),
    standard_measurement_id  INTEGER NOT NULL REFERENCES measurements (id),
    standard_file            TEXT NOT NULL,       -- the calibration's file name (or shipped standard's)
    standard_sha256          TEXT NOT NULL,       -- SHA-256 of the calibration file's bytes
    standard_uncertainty_stated INTEGER NOT NULL CHECK (standard_uncertainty_stated IN (0, 1)),
    created_at               REAL NOT NULL,
    wavelength_json          TEXT NOT NULL,       -- nm
    reflectance_json         TEXT NOT NULL,       -- as computed: never clipped
    uncertainty_json         TEXT NOT NULL,       -- standard uncertainty (k = 1)
    above_one_json           TEXT NOT NULL,       -- nm where reflectance > 1
    below_zero_json          TEXT NOT NULL,       -- nm where reflectance < 0
    max_reflectance          REAL NOT NULL,
    min_reflectance          REAL NOT NULL,
    note                     TEXT NOT NULL DEFAULT ''
);

CREATE TABLE illuminants (
    id                       INTEGER PRIMARY KEY,
    name                     TEXT NOT NULL,
    measurement_id           INTEGER NOT NULL REFERENCES measurements (id),
    standard_file            TEXT NOT NULL,
    standard_sha256          TEXT NOT NULL,
    standard_uncertainty_stated INTEGER NOT NULL CHECK (standard_uncertainty_stated IN (0, 1)),
    created_at               REAL NOT NULL,
    wavelength_json          TEXT NOT NULL,
    spd_json                 TEXT NOT NULL,       -- relative, 100 at 560 nm
    uncertainty_json         TEXT NOT NULL,
    luminance_cd_m2          REAL NOT NULL,       -- the white standard's measured luminance
    note                     TEXT NOT NULL DEFAULT ''
);
