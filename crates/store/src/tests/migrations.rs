//! Migrations keep a lab's data: databases made by older lightbooths
//! (SQLite) open with every row, and both engines' migration sets make the
//! same tables and columns.

use super::*;

/// An SQLite database at `dir/old.sqlite` migrated only up to (not
/// including) migration `before`, with `rows` inserted: a lab's database
/// from an older lightbooth. Returns its URL.
pub(super) async fn sqlite_database_before_migration(dir: &std::path::Path, before: &str, rows: &[&str]) -> String {
    let old = dir.join("migrations");
    std::fs::create_dir(&old).unwrap();
    let all = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../migrations/sqlite");
    for entry in std::fs::read_dir(&all).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        if name.as_str() < before {
            std::fs::copy(&path, old.join(&name)).unwrap();
        }
    }
    let url = format!("sqlite://{}", dir.join("old.sqlite").display());
    let options = SqliteConnectOptions::from_str(&url)
        .unwrap()
        .create_if_missing(true)
        .foreign_keys(true);
    let pool = SqlitePool::connect_with(options).await.unwrap();
    sqlx::migrate::Migrator::new(old.as_path())
        .await
        .unwrap()
        .run(&pool)
        .await
        .unwrap();
    for sql in rows {
        sqlx::query(sql).execute(&pool).await.unwrap();
    }
    pool.close().await;
    url
}

/// Migration 0005 rebuilds `renders` and `studies` (wider state checks):
/// every row, the comparisons that reference renders, and every study file
/// must survive it.
#[tokio::test]
pub(super) async fn job_state_migration_keeps_renders_comparisons_and_study_files() {
    let dir = tempfile::tempdir().unwrap();
    let url = sqlite_database_before_migration(
        dir.path(),
        "0005",
        &[
            "INSERT INTO measurements (id, samples_requested, settings_json, state, created_at) \
             VALUES (1, 5, '{}', 'failed', 0)",
            "INSERT INTO renders (id, scene, scene_hash, settings_json, codings, seed, state, created_at, result_json, preview_png) \
             VALUES (7, 'white', 'h', '{}', 'rgb', 1, 'complete', 0, '{}', x'89504e47')",
            "INSERT INTO renders (id, scene, scene_hash, settings_json, codings, seed, state, created_at) \
             VALUES (8, 'white', 'h', '{}', 'rgb', 1, 'running', 0)",
            "INSERT INTO comparisons (measurement_id, render_id, scene, target, coding, white_source, white_x, white_y, \
             white_z, measured_x, measured_y, measured_z, rendered_x, rendered_y, rendered_z, rendered_y_se, y_ratio, \
             xy_distance, de76, de00, created_at) VALUES (1, 7, 'white', 'patch', 'rgb', 'w', 1, 1, 1, 1, 1, 1, 1, 1, 1, \
             0, 1, 0, 0, 0, 0)",
            "INSERT INTO studies (id, request_json, state, created_at, result_json) VALUES (3, '{}', 'complete', 0, '{}')",
            "INSERT INTO study_files (study_id, name, content) VALUES (3, 'index.html', x'3c68746d6c3e')",
        ],
    )
    .await;
    // Opened as the daemon opens it (only the daemon recovers, issue 32).
    let store = Store::open_recovering(&url).await.unwrap();
    let kept = store.get_render(7).await.unwrap().unwrap();
    assert_eq!(kept.state, "complete");
    assert_eq!(store.render_preview(7).await.unwrap().unwrap(), b"\x89PNG".to_vec());
    assert_eq!(store.get_render(8).await.unwrap().unwrap().state, "interrupted");
    assert_eq!(store.comparisons_for_measurement(1).await.unwrap().len(), 1);
    let study = store.get_study(3).await.unwrap().unwrap();
    assert_eq!(study.files, vec!["index.html".to_string()]);
    assert_eq!(
        store.study_file(3, "index.html").await.unwrap().unwrap(),
        b"<html>".to_vec()
    );
    let violations = sqlx::query("PRAGMA foreign_key_check")
        .fetch_all(store.sqlite_pool().unwrap())
        .await
        .unwrap();
    assert!(violations.is_empty(), "no dangling references after the rebuild");
}

/// Migration 0012 rebuilds `measurements` on SQLite (a CHECK cannot be
/// altered): every measurement with its booth, daemon and XYZ, its samples
/// (ON DELETE CASCADE: dropped with the old table unless set aside), the
/// comparisons, reflectances and illuminants that reference it, and its
/// indexes must survive, with no dangling reference.
#[tokio::test]
pub(super) async fn sample_limit_migration_keeps_measurements_samples_and_comparisons() {
    let dir = tempfile::tempdir().unwrap();
    let url = sqlite_database_before_migration(
        dir.path(),
        "0012",
        &[
            "INSERT INTO daemons (id, booth, host, pid, lease_seconds, started_at, heartbeat_at, stopped_at) \
             VALUES (2, 'north', 'pc1', 77, 15, 0, 0, 1)",
            "INSERT INTO measurements (id, samples_requested, settings_json, state, created_at, radiance_json, \
             luminance_cd_m2, xyz_x, xyz_y, xyz_z, observer, booth, daemon_id) \
             VALUES (1, 5, '{}', 'complete', 0, '[0.01,0.02,0.03]', 34, 30, 34, 20, 'judd-vos-1978', 'north', 2)",
            "INSERT INTO measurements (id, samples_requested, settings_json, state, created_at, error) \
             VALUES (4, 99, '{}', 'interrupted', 0, 'gone')",
            "INSERT INTO samples (id, measurement_id, idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2) \
             VALUES (10, 1, 0, 0, 0, 'ok', 1, '[0.01,0.02,0.03]', 34)",
            "INSERT INTO samples (id, measurement_id, idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2) \
             VALUES (11, 1, 1, 0, 18, 'stale', 0, NULL, NULL)",
            "INSERT INTO samples (id, measurement_id, idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2) \
             VALUES (12, 4, 0, 0, 0, 'ok', 1, '[0.01,0.02,0.03]', 33)",
            "INSERT INTO renders (id, scene, scene_hash, settings_json, codings, seed, state, created_at, result_json) \
             VALUES (7, 'white', 'h', '{}', 'rgb', 1, 'complete', 0, '{}')",
            "INSERT INTO comparisons (measurement_id, render_id, scene, target, coding, white_source, white_x, white_y, \
             white_z, measured_x, measured_y, measured_z, rendered_x, rendered_y, rendered_z, rendered_y_se, y_ratio, \
             xy_distance, de76, de00, created_at) VALUES (1, 7, 'white', 'patch', 'rgb', 'w', 1, 1, 1, 1, 1, 1, 1, 1, 1, \
             0, 1, 0, 0, 0, 0)",
            "INSERT INTO illuminants (id, name, measurement_id, standard_file, standard_sha256, \
             standard_uncertainty_stated, created_at, wavelength_json, spd_json, uncertainty_json, luminance_cd_m2) \
             VALUES (3, 'booth lamp', 1, 'std.csv', 'ab', 1, 0, '[]', '[]', '[]', 34)",
        ],
    )
    .await;
    let store = Store::open(&url).await.unwrap();
    let m = store.get_measurement(1).await.unwrap().unwrap();
    assert_eq!(m.summary.state, MeasurementState::Complete);
    assert_eq!((m.summary.booth.as_str(), m.summary.samples_requested), ("north", 5));
    assert_eq!(
        m.summary.observer,
        Some(lightbooth_science::colorimetry::Observer::JuddVos)
    );
    assert_eq!(
        m.samples.len(),
        2,
        "the samples are kept, not cascaded away with the old table"
    );
    assert!(m.samples[0].usable && !m.samples[1].usable);
    let interrupted = store.get_measurement(4).await.unwrap().unwrap();
    assert_eq!(interrupted.summary.error.as_deref(), Some("gone"));
    assert_eq!(interrupted.samples.len(), 1);
    assert_eq!(store.comparisons_for_measurement(1).await.unwrap().len(), 1);
    let pool = store.sqlite_pool().unwrap();
    let (daemon, illuminant): (Option<i64>, i64) = sqlx::query_as(
        "SELECT (SELECT daemon_id FROM measurements WHERE id = 1), (SELECT measurement_id FROM illuminants WHERE id = 3)",
    )
    .fetch_one(pool)
    .await
    .unwrap();
    assert_eq!((daemon, illuminant), (Some(2), 1));
    let violations = sqlx::query("PRAGMA foreign_key_check").fetch_all(pool).await.unwrap();
    assert!(violations.is_empty(), "no dangling references after the rebuild");
    let mut indexes: Vec<String> = sqlx::query_scalar(
        "SELECT name FROM sqlite_master WHERE type = 'index' AND tbl_name = 'measurements' AND sql IS NOT NULL",
    )
    .fetch_all(pool)
    .await
    .unwrap();
    indexes.sort();
    assert_eq!(
        indexes,
        [
            "measurements_booth",
            "measurements_by_scene",
            "measurements_daemon",
            "measurements_newest",
            "measurements_scene",
            "measurements_state"
        ]
    );
    // And the new limit holds on the migrated table too.
    let id = store
        .create_measurement(&NewMeasurement {
            samples: 150,
            ..new_measurement()
        })
        .await
        .unwrap();
    assert!(id > 4, "ids continue after the kept rows");
}

/// A database from before booths (migrations up to 0008) keeps its
/// measurements and instruments, now in the `default` booth: the one booth a
/// daemon without `--booth` serves, so a one-booth lab sees no change.
#[tokio::test]
pub(super) async fn migrations_before_booths_leave_rows_in_the_default_booth() {
    let dir = tempfile::tempdir().unwrap();
    let url = sqlite_database_before_migration(
        dir.path(),
        "0009",
        &[
            "INSERT INTO instruments (id, model, serial, port, first_seen, last_seen) \
             VALUES (4, 'PR-650', '60931502', '/dev/ttyUSB0', 0, 0)",
            "INSERT INTO measurements (id, instrument_id, samples_requested, settings_json, state, created_at) \
             VALUES (1, 4, 5, '{}', 'failed', 0)",
        ],
    )
    .await;
    let store = Store::open(&url).await.unwrap();
    let m = store.get_measurement(1).await.unwrap().unwrap();
    assert_eq!(m.summary.booth, DEFAULT_BOOTH);
    assert_eq!(store.list_instruments().await.unwrap()[0].booth, DEFAULT_BOOTH);
    let default_only = MeasurementFilter {
        booth: Some(Booth::default()),
        ..Default::default()
    };
    assert_eq!(store.list_measurements(&default_only).await.unwrap().total, 1);
}

pub(super) fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A lab's existing SQLite file — migrated by lightbooth before PostgreSQL
/// came, its `_sqlx_migrations` holding those files' checksums — must open
/// with its data, not fail with "migration was previously applied but has
/// been modified".
#[tokio::test]
pub(super) async fn a_sqlite_database_migrated_before_migrations_moved_to_migrations_sqlite_opens_with_its_data() {
    let dir = tempfile::tempdir().unwrap();
    let url = format!("sqlite://{}", dir.path().join("lab.sqlite").display());
    {
        let options = SqliteConnectOptions::from_str(&url)
            .unwrap()
            .create_if_missing(true)
            .foreign_keys(true);
        let pool = SqlitePool::connect_with(options).await.unwrap();
        let sources = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../migrations/sqlite");
        sqlx::migrate::Migrator::new(sources.as_path())
            .await
            .unwrap()
            .run(&pool)
            .await
            .unwrap();
        // What the old binary left behind: its own checksums, whatever the
        // files say today.
        for (version, checksum) in CHECKSUMS_BEFORE_THE_MOVE {
            let bytes: Vec<u8> = (0..checksum.len())
                .step_by(2)
                .map(|i| u8::from_str_radix(&checksum[i..i + 2], 16).unwrap())
                .collect();
            sqlx::query("UPDATE _sqlx_migrations SET checksum = $1 WHERE version = $2")
                .bind(bytes)
                .bind(version)
                .execute(&pool)
                .await
                .unwrap();
        }
        sqlx::query(
            "INSERT INTO measurements (id, samples_requested, settings_json, state, created_at) \
             VALUES (41, 5, '{}', 'running', 0)",
        )
        .execute(&pool)
        .await
        .unwrap();
        pool.close().await;
    }
    let embedded: Vec<(i64, String)> = engine::SQLITE_MIGRATIONS
        .iter()
        .filter(|m| m.version <= 8)
        .map(|m| (m.version, hex(&m.checksum)))
        .collect();
    let before: Vec<(i64, String)> = CHECKSUMS_BEFORE_THE_MOVE
        .iter()
        .map(|(v, c)| (*v, c.to_string()))
        .collect();
    assert_eq!(embedded, before, "an applied SQLite migration was edited");
    // Opened as the daemon opens it (only the daemon recovers, issue 32).
    let store = Store::open_recovering(&url).await.expect("the old database opens");
    let m = store.get_measurement(41).await.unwrap().unwrap();
    assert_eq!(
        m.summary.state,
        MeasurementState::Interrupted,
        "and is recovered as before"
    );
}

/// A column as the schema comparison sees it: the coarse type class both
/// engines must agree on, and whether it may be NULL.
pub(super) type Columns = std::collections::BTreeMap<(String, String), (String, bool)>;

pub(super) async fn sqlite_schema(url: &str) -> Columns {
    let store = Store::open(url).await.unwrap();
    let pool = store.sqlite_pool().unwrap();
    let tables: Vec<String> = sqlx::query_scalar(
        "SELECT name FROM sqlite_master WHERE type = 'table' AND name NOT LIKE 'sqlite_%' \
         AND name <> '_sqlx_migrations'",
    )
    .fetch_all(pool)
    .await
    .unwrap();
    let mut columns = Columns::new();
    for table in tables {
        let rows: Vec<(String, String, bool, i64)> = sqlx::query_as(&format!(
            "SELECT name, type, \"notnull\", pk FROM pragma_table_info('{table}')"
        ))
        .fetch_all(pool)
        .await
        .unwrap();
        for (name, declared, not_null, pk) in rows {
            let class = match declared.as_str() {
                "INTEGER" => "integer",
                "REAL" => "real",
                "TEXT" => "text",
                "BLOB" => "blob",
                other => panic!("{table}.{name}: SQLite type {other} is none of INTEGER, REAL, TEXT, BLOB"),
            };
            // An INTEGER PRIMARY KEY is the rowid: never NULL, though not declared so.
            columns.insert((table.clone(), name), (class.into(), !(not_null || pk > 0)));
        }
    }
    columns
}

pub(super) async fn postgres_schema(url: &str) -> Columns {
    let store = Store::open(url).await.unwrap();
    let rows: Vec<(String, String, String, String)> = with_pool!(store, |pool| sqlx::query_as(
        "SELECT table_name::text, column_name::text, data_type::text, is_nullable::text \
         FROM information_schema.columns WHERE table_schema = 'public' AND table_name <> '_sqlx_migrations'",
    )
    .fetch_all(pool)
    .await
    .unwrap());
    rows.into_iter()
        .map(|(table, name, data_type, nullable)| {
            let class = match data_type.as_str() {
                // SQLite has no boolean: its flags are 0/1 INTEGER.
                "bigint" | "boolean" => "integer",
                "double precision" => "real",
                "text" => "text",
                "bytea" => "blob",
                other => panic!(
                    "{table}.{name}: PostgreSQL type {other} is none of BIGINT, BOOLEAN, DOUBLE PRECISION \
                     (REAL is only float4), TEXT, BYTEA"
                ),
            };
            ((table, name), (class.to_string(), nullable == "YES"))
        })
        .collect()
}

/// The two migration sets stay in step: the same versions, and the same
/// tables with the same columns (type class and nullability) once applied.
#[tokio::test]
pub(super) async fn both_engines_migrations_make_the_same_tables_and_columns() {
    let versions = |m: &sqlx::migrate::Migrator| {
        m.iter()
            .map(|m| (m.version, m.description.to_string()))
            .collect::<Vec<_>>()
    };
    assert_eq!(
        versions(&engine::SQLITE_MIGRATIONS),
        versions(&engine::POSTGRES_MIGRATIONS),
        "every migration exists for both engines, with the same version and name"
    );
    let sqlite = TestDb::new(EngineKind::Sqlite).await;
    let postgres = TestDb::new(EngineKind::Postgres).await;
    let (a, b) = (sqlite_schema(&sqlite.url).await, postgres_schema(&postgres.url).await);
    assert!(a.len() > 100, "the whole schema is read ({} columns)", a.len());
    fn only(x: &Columns, y: &Columns) -> Columns {
        x.iter()
            .filter(|(k, v)| y.get(*k) != Some(*v))
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect()
    }
    assert!(
        a == b,
        "the schemas differ:\n  SQLite only or different: {:?}\n  PostgreSQL only or different: {:?}",
        only(&a, &b),
        only(&b, &a)
    );
}

#[tokio::test]
pub(super) async fn an_unknown_database_kind_is_refused_naming_the_accepted_forms() {
    let err = Store::open("mysql://root:secret@db/lab").await.unwrap_err().to_string();
    assert!(
        err.contains("`mysql:`") && err.contains("sqlite://") && err.contains("postgres://"),
        "{err}"
    );
    assert!(!err.contains("secret"), "the URL's password is never echoed: {err}");
}
