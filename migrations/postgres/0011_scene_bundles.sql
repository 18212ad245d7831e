-- Scene bundles (issue 14): a scene's TOML and every file it references,
-- stored so a render worker without the scenes folder can unpack them
-- (src/render/bundle.rs). `hash` is the bundle's SHA-256 (hex) over its
-- files' relative paths and bytes; `scene_hash` is the render key
-- (render::scene_hash, the renders table's scene_hash) of the same bytes;
-- `scene_file` the scene TOML's path among the files. A bundle is written
-- in one transaction with all its files, never in part.
CREATE TABLE scene_bundles (
    hash TEXT PRIMARY KEY,
    scene_id TEXT NOT NULL,
    scene_file TEXT NOT NULL,
    scene_hash TEXT NOT NULL,
    created_at DOUBLE PRECISION NOT NULL,
    total_bytes BIGINT NOT NULL
);
CREATE INDEX scene_bundles_scene_hash ON scene_bundles (scene_hash);
CREATE TABLE scene_bundle_files (
    hash TEXT NOT NULL REFERENCES scene_bundles (hash) ON DELETE CASCADE,
    path TEXT NOT NULL,
    content BYTEA NOT NULL,
    PRIMARY KEY (hash, path)
);
