//! Stored scene bundles (`migrations/0011`): a scene's files as the render
//! workers fetch them ([`lightbooth_render::bundle`]), keyed by the bundle's
//! SHA-256, with the render key of the same bytes (`scene_hash`) so a render
//! row leads to the files it was rendered from. A bundle is stored whole,
//! in one transaction, or not at all; storing one already there is a no-op.

use super::{now, Store, StoreError};
use crate::BoxFuture;
use lightbooth_render::bundle::{BundleFile, SceneBundle};

/// A stored bundle and what the store knows of it.
#[derive(Clone, Debug)]
pub struct StoredSceneBundle {
    /// SHA-256 of the bundle, hex (checked against the files on reading).
    pub hash: String,
    /// The daemon's scene id it was stored for (`cylinder`, …).
    pub scene_id: String,
    /// [`lightbooth_render::scene_hash`] of its files: the renders' key.
    pub scene_hash: String,
    /// POSIX seconds, UTC.
    pub created_at: f64,
    pub total_bytes: i64,
    pub bundle: SceneBundle,
}

#[derive(sqlx::FromRow)]
struct BundleRecord {
    hash: String,
    scene_id: String,
    scene_file: String,
    scene_hash: String,
    created_at: f64,
    total_bytes: i64,
}

#[derive(sqlx::FromRow)]
struct FileRecord {
    path: String,
    content: Vec<u8>,
}

impl Store {
    /// Stores `bundle` for the scene `scene_id` with its render key
    /// `scene_hash`. All its files or nothing (one transaction); a bundle of
    /// the same hash already stored is left as it is. Returns whether it was
    /// new.
    pub fn put_scene_bundle<'a>(
        &'a self,
        scene_id: &'a str,
        scene_hash: &'a str,
        bundle: &'a SceneBundle,
    ) -> BoxFuture<'a, Result<bool, StoreError>> {
        Box::pin(async move {
            let hash = bundle.hash();
            let total = i64::try_from(bundle.total_bytes())
                .map_err(|_| StoreError::Conflict(format!("scene bundle {hash} is too large to store")))?;
            with_pool!(self, |pool| {
                let mut tx = pool.begin().await?;
                let inserted = sqlx::query(
                    "INSERT INTO scene_bundles (hash, scene_id, scene_file, scene_hash, created_at, total_bytes) \
                     VALUES ($1, $2, $3, $4, $5, $6) ON CONFLICT (hash) DO NOTHING",
                )
                .bind(&hash)
                .bind(scene_id)
                .bind(bundle.scene_file())
                .bind(scene_hash)
                .bind(now())
                .bind(total)
                .execute(&mut *tx)
                .await?
                .rows_affected();
                if inserted == 0 {
                    return Ok(false);
                }
                for f in bundle.files() {
                    sqlx::query("INSERT INTO scene_bundle_files (hash, path, content) VALUES ($1, $2, $3)")
                        .bind(&hash)
                        .bind(&f.path)
                        .bind(&f.content)
                        .execute(&mut *tx)
                        .await?;
                }
                tx.commit().await?;
            });
            Ok(true)
        })
    }

    /// The bundle of `hash` with its files, checked: files that do not hash
    /// to `hash` are a corrupt store, never handed out.
    pub fn scene_bundle<'a>(&'a self, hash: &'a str) -> BoxFuture<'a, Result<Option<StoredSceneBundle>, StoreError>> {
        Box::pin(async move {
            let (record, files) = with_pool!(self, |pool| {
                let Some(record) = sqlx::query_as::<_, BundleRecord>("SELECT * FROM scene_bundles WHERE hash = $1")
                    .bind(hash)
                    .fetch_optional(pool)
                    .await?
                else {
                    return Ok(None);
                };
                let files = sqlx::query_as::<_, FileRecord>(
                    "SELECT path, content FROM scene_bundle_files WHERE hash = $1 ORDER BY path",
                )
                .bind(hash)
                .fetch_all(pool)
                .await?;
                (record, files)
            });
            let corrupt = |err: String| StoreError::Corrupt {
                what: format!("scene bundle {hash}"),
                err,
            };
            let bundle = SceneBundle::from_parts(
                record.scene_file,
                files
                    .into_iter()
                    .map(|f| BundleFile {
                        path: f.path,
                        content: f.content,
                    })
                    .collect(),
            )
            .map_err(|e| corrupt(e.to_string()))?;
            let actual = bundle.hash();
            if actual != record.hash {
                return Err(corrupt(format!("its files hash to {actual}")));
            }
            Ok(Some(StoredSceneBundle {
                hash: record.hash,
                scene_id: record.scene_id,
                scene_hash: record.scene_hash,
                created_at: record.created_at,
                total_bytes: record.total_bytes,
                bundle,
            }))
        })
    }

    /// Whether the bundle of `hash` is stored.
    pub fn has_scene_bundle<'a>(&'a self, hash: &'a str) -> BoxFuture<'a, Result<bool, StoreError>> {
        Box::pin(async move {
            let found: Option<i32> = with_pool!(self, |pool| sqlx::query_scalar(
                "SELECT 1 FROM scene_bundles WHERE hash = $1"
            )
            .bind(hash)
            .fetch_optional(pool)
            .await?);
            Ok(found.is_some())
        })
    }

    /// The hash of the newest bundle whose files have the render key
    /// `scene_hash` (a render row's `scene_hash`), if one is stored.
    pub fn scene_bundle_for_render_key<'a>(
        &'a self,
        scene_hash: &'a str,
    ) -> BoxFuture<'a, Result<Option<String>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "SELECT hash FROM scene_bundles WHERE scene_hash = $1 ORDER BY created_at DESC, hash LIMIT 1"
            )
            .bind(scene_hash)
            .fetch_optional(pool)
            .await?))
        })
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::super::test_db::{on_both_engines, TestDb};
    use super::*;
    use crate::engine::EngineKind;
    use lightbooth_render::{load_scene, scene_hash};

    on_both_engines!(
        a_scene_bundle_round_trips_byte_exact_and_a_second_put_changes_nothing,
        a_bundle_from_the_store_unpacked_far_from_scenes_loads_as_the_same_scene,
        a_bundle_whose_file_insert_fails_leaves_no_bundle_and_no_files,
    );

    fn cylinder() -> lightbooth_render::bundle::CollectedScene {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
        SceneBundle::collect(&root, &root.join("cylinder.toml")).unwrap()
    }

    async fn a_scene_bundle_round_trips_byte_exact_and_a_second_put_changes_nothing(engine: EngineKind) {
        let db = TestDb::new(engine).await;
        let store = Store::open(&db.url).await.unwrap();
        let c = cylinder();
        let hash = c.bundle.hash();
        assert!(!store.has_scene_bundle(&hash).await.unwrap());
        assert!(store.scene_bundle(&hash).await.unwrap().is_none());
        assert!(store
            .put_scene_bundle("cylinder", &c.scene_hash, &c.bundle)
            .await
            .unwrap());
        assert!(store.has_scene_bundle(&hash).await.unwrap());
        let got = store.scene_bundle(&hash).await.unwrap().unwrap();
        assert_eq!(got.bundle, c.bundle);
        assert_eq!(got.hash, hash);
        assert_eq!(got.scene_id, "cylinder");
        assert_eq!(got.scene_hash, c.scene_hash);
        assert_eq!(got.total_bytes as u64, c.bundle.total_bytes());
        // The stored bytes are the files' bytes on disk, one by one.
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
        for f in got.bundle.files() {
            assert_eq!(f.content, std::fs::read(root.join(&f.path)).unwrap(), "{}", f.path);
        }
        // Idempotent: the same bundle again is no new row and no error.
        assert!(!store
            .put_scene_bundle("cylinder", &c.scene_hash, &c.bundle)
            .await
            .unwrap());
        let again = store.scene_bundle(&hash).await.unwrap().unwrap();
        assert_eq!(again.bundle, c.bundle);
        assert_eq!(again.created_at, got.created_at);
        assert_eq!(
            store.scene_bundle_for_render_key(&c.scene_hash).await.unwrap(),
            Some(hash.clone())
        );
        assert_eq!(store.scene_bundle_for_render_key("0000").await.unwrap(), None);
    }

    async fn a_bundle_from_the_store_unpacked_far_from_scenes_loads_as_the_same_scene(engine: EngineKind) {
        let db = TestDb::new(engine).await;
        let store = Store::open(&db.url).await.unwrap();
        let c = cylinder();
        store
            .put_scene_bundle("cylinder", &c.scene_hash, &c.bundle)
            .await
            .unwrap();
        let got = store.scene_bundle(&c.bundle.hash()).await.unwrap().unwrap();
        let cache = tempfile::tempdir().unwrap();
        let toml = got.bundle.unpack(cache.path()).unwrap();
        let unpacked = load_scene(&toml).unwrap();
        assert_eq!(scene_hash(&unpacked).unwrap(), got.scene_hash);
        assert_eq!(unpacked.targets(), c.scene.targets());
        assert_eq!(
            format!("{:?}", unpacked.primitives),
            format!("{:?}", c.scene.primitives)
        );
        assert_eq!(format!("{:?}", unpacked.lights), format!("{:?}", c.scene.lights));
        assert_eq!(format!("{:?}", unpacked.materials), format!("{:?}", c.scene.materials));
    }

    /// A trigger refuses the IES file, the second of CYLINDER's files
    /// (sorted): without one transaction the TOML's row would remain.
    async fn a_bundle_whose_file_insert_fails_leaves_no_bundle_and_no_files(engine: EngineKind) {
        let db = TestDb::new(engine).await;
        let store = Store::open(&db.url).await.unwrap();
        let c = cylinder();
        assert_eq!(c.bundle.files()[1].path, "luminaires/mr16_ctb.ies");
        let count = "SELECT COUNT(*) FROM scene_bundle_files";
        let files: i64 = match engine {
            EngineKind::Sqlite => {
                let pool = sqlx::SqlitePool::connect(&db.url).await.unwrap();
                sqlx::query(
                    "CREATE TRIGGER refuse_ies BEFORE INSERT ON scene_bundle_files WHEN NEW.path LIKE '%.ies' \
                     BEGIN SELECT RAISE(ABORT, 'refused by the test'); END",
                )
                .execute(&pool)
                .await
                .unwrap();
                let e = store
                    .put_scene_bundle("cylinder", &c.scene_hash, &c.bundle)
                    .await
                    .unwrap_err();
                assert!(e.to_string().contains("refused by the test"), "{e}");
                sqlx::query_scalar(count).fetch_one(&pool).await.unwrap()
            }
            EngineKind::Postgres => {
                let pool = sqlx::PgPool::connect(&db.url).await.unwrap();
                sqlx::query(
                    "CREATE FUNCTION refuse_ies() RETURNS trigger LANGUAGE plpgsql AS $$ BEGIN \
                     IF NEW.path LIKE '%.ies' THEN RAISE EXCEPTION 'refused by the test'; END IF; RETURN NEW; END $$",
                )
                .execute(&pool)
                .await
                .unwrap();
                sqlx::query(
                    "CREATE TRIGGER refuse_ies BEFORE INSERT ON scene_bundle_files \
                     FOR EACH ROW EXECUTE FUNCTION refuse_ies()",
                )
                .execute(&pool)
                .await
                .unwrap();
                let e = store
                    .put_scene_bundle("cylinder", &c.scene_hash, &c.bundle)
                    .await
                    .unwrap_err();
                assert!(e.to_string().contains("refused by the test"), "{e}");
                let n = sqlx::query_scalar(count).fetch_one(&pool).await.unwrap();
                pool.close().await;
                n
            }
        };
        assert_eq!(files, 0, "a failed put left files");
        assert!(!store.has_scene_bundle(&c.bundle.hash()).await.unwrap());
        assert!(store.scene_bundle(&c.bundle.hash()).await.unwrap().is_none());
    }
}
