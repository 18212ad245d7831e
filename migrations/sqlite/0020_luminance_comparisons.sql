-- A luminance meter's measurement compared with every coding (issue 33).
--
-- A luminance meter (the LS-100) gives Y and nothing else: no x, y, no
-- CIELAB, no ΔE. Its comparison with a coding is the luminance ratio alone
-- (and so the relative luminance error of the study), kept apart from
-- `comparisons`, whose every row has both sides' XYZ and ΔE. `observer`
-- is the one whose ȳ both luminances are weighted by (the meter's V(λ) is
-- CIE 1931's ȳ; the daemon compares only in that observer).
CREATE TABLE luminance_comparisons (
    id               INTEGER PRIMARY KEY,
    measurement_id   INTEGER NOT NULL REFERENCES measurements (id),
    render_id        INTEGER NOT NULL REFERENCES renders (id),
    scene            TEXT NOT NULL,
    target           TEXT NOT NULL,
    coding           TEXT NOT NULL,
    observer         TEXT NOT NULL,
    measured_y       REAL NOT NULL,      -- cd/m²
    measured_y_se    REAL NOT NULL,      -- standard error of the measured Y (samples' SD/√n)
    rendered_y       REAL NOT NULL,      -- cd/m²
    rendered_y_se    REAL NOT NULL,      -- Monte Carlo standard error of the rendered Y
    y_ratio          REAL NOT NULL,      -- rendered Y / measured Y
    created_at       REAL NOT NULL,
    UNIQUE (measurement_id, render_id, coding)
);
CREATE INDEX luminance_comparisons_scene ON luminance_comparisons (scene, coding);
