-- Listing measurements newest first, with or without a scene filter
-- (migrations/sqlite/0002). PostgreSQL's primary-key index already orders by
-- id, so only the scene index is needed; it carries id for the ordering.
CREATE INDEX measurements_by_scene ON measurements (scene, id);
