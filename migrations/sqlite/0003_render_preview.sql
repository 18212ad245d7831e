-- The scene's camera view of a render (tone-mapped sRGB PNG), for the dashboard.
ALTER TABLE renders ADD COLUMN preview_png BLOB;
