-- Image stimulus sets (issue 48): the codings of one rendered image
-- converted through a stored display profile with one gamut policy, for an
-- output method: what the display will be asked to show. Made from the
-- camera images a daemon keeps (`source` 'render': the render, its scene
-- and the images' settings in `provenance_json`) or from an uploaded
-- layered OpenEXR (`source` 'upload': its SHA-256, size, layers and the
-- uploader's stated provenance). Never changed once stored.
CREATE TABLE stimulus_sets (
    id INTEGER PRIMARY KEY,
    booth TEXT NOT NULL,
    created_at REAL NOT NULL,
    source TEXT NOT NULL CHECK (source IN ('render', 'upload')),
    render_id INTEGER REFERENCES renders (id),
    scene TEXT,
    provenance_json TEXT NOT NULL,
    profile_id INTEGER NOT NULL REFERENCES display_profiles (id),
    policy TEXT NOT NULL,
    output TEXT NOT NULL,
    width INTEGER NOT NULL,
    height INTEGER NOT NULL,
    codings_json TEXT NOT NULL,
    reference TEXT NOT NULL,
    observer TEXT NOT NULL,
    -- `lightbooth_science::display::image_set::ImageSet` as JSON.
    report_json TEXT NOT NULL,
    -- Per coding (codings_json's order), per pixel (rows top to bottom):
    -- linear R, G, B after the gamut policy, f32 little-endian.
    linear BLOB NOT NULL,
    -- Per coding, per pixel: ΔE00 between what the display shows of the
    -- coding and of the reference at `output`, f32 little-endian.
    shown_delta_e BLOB NOT NULL
);
-- A set's coding shown on the display and measured at the scene's targets
-- projected into the image (`lab::records::image_verification`): the
-- request (which measurement at which target, the screen's geometry) and
-- the result per target, as JSON. Never changed once stored.
CREATE TABLE stimulus_set_verifications (
    id INTEGER PRIMARY KEY,
    set_id INTEGER NOT NULL REFERENCES stimulus_sets (id),
    created_at REAL NOT NULL,
    coding TEXT NOT NULL,
    client TEXT NOT NULL,
    request_json TEXT NOT NULL,
    result_json TEXT NOT NULL
);
CREATE INDEX stimulus_set_verifications_set ON stimulus_set_verifications (set_id, id);
