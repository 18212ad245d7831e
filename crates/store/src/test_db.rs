//! A fresh, empty database per test, on either engine: an SQLite file in a
//! temporary folder, or a new database (unique name) on the test PostgreSQL
//! server that `tests/setup.sh` starts. Tests run in parallel, each on its
//! own database; a PostgreSQL test database is dropped when the test ends.
//!
//! The server is found through `$LIGHTBOOTH_TEST_PG` (a `postgres://` URL of
//! a role that may create databases) or, without it, the URL `tests/setup.sh`
//! writes to `target/pg-url`. Without either, or when the server does not
//! answer, a PostgreSQL test fails saying to run `tests/setup.sh`; the SQLite
//! tests do not need it.

use std::str::FromStr;
use std::sync::atomic::{AtomicU64, Ordering};

use sqlx::postgres::PgConnectOptions;
use sqlx::{ConnectOptions, Connection};

use super::engine::EngineKind;

/// A test database; removed when dropped.
pub(crate) struct TestDb {
    pub url: String,
    _dir: Option<tempfile::TempDir>,
    postgres: Option<(String, String)>,
}

/// The URL of the test PostgreSQL server's maintenance database.
pub(crate) fn postgres_admin_url() -> String {
    if let Ok(url) = std::env::var("LIGHTBOOTH_TEST_PG") {
        return url;
    }
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/pg-url");
    match std::fs::read_to_string(&file) {
        Ok(url) => url.trim().to_string(),
        Err(e) => panic!(
            "no test PostgreSQL server: run tests/setup.sh (it starts one and writes {}; {e}), \
             or set LIGHTBOOTH_TEST_PG to a postgres:// URL of a role that may create databases",
            file.display()
        ),
    }
}

/// `url` with its database name replaced by `database`.
fn with_database(url: &str, database: &str) -> String {
    let (base, query) = match url.split_once('?') {
        Some((b, q)) => (b, Some(q)),
        None => (url, None),
    };
    let authority_end = base.find("://").map(|i| i + 3).unwrap_or(0);
    let root = match base[authority_end..].find('/') {
        Some(i) => &base[..authority_end + i],
        None => base,
    };
    match query {
        Some(q) => format!("{root}/{database}?{q}"),
        None => format!("{root}/{database}"),
    }
}

impl TestDb {
    pub(crate) async fn new(engine: EngineKind) -> TestDb {
        match engine {
            EngineKind::Sqlite => {
                let dir = tempfile::tempdir().unwrap();
                let url = format!("sqlite://{}", dir.path().join("t.sqlite").display());
                TestDb {
                    url,
                    _dir: Some(dir),
                    postgres: None,
                }
            }
            EngineKind::Postgres => {
                static NEXT: AtomicU64 = AtomicU64::new(0);
                let admin = postgres_admin_url();
                let name = format!(
                    "lbt_{}_{}_{}",
                    std::process::id(),
                    NEXT.fetch_add(1, Ordering::Relaxed),
                    std::time::SystemTime::now()
                        .duration_since(std::time::UNIX_EPOCH)
                        .unwrap()
                        .subsec_nanos()
                );
                let mut conn = connect_admin(&admin).await;
                sqlx::query(&format!("CREATE DATABASE {name}"))
                    .execute(&mut conn)
                    .await
                    .unwrap_or_else(|e| panic!("cannot create the test database {name}: {e}"));
                conn.close().await.ok();
                TestDb {
                    url: with_database(&admin, &name),
                    _dir: None,
                    postgres: Some((admin, name)),
                }
            }
        }
    }
}

async fn connect_admin(admin: &str) -> sqlx::PgConnection {
    let options = PgConnectOptions::from_str(admin)
        .unwrap_or_else(|e| panic!("the test PostgreSQL URL is not valid ({e}); run tests/setup.sh"));
    options.connect().await.unwrap_or_else(|e| {
        panic!("the test PostgreSQL server does not answer ({e}): run tests/setup.sh, which starts it")
    })
}

impl Drop for TestDb {
    fn drop(&mut self) {
        let Some((admin, name)) = self.postgres.take() else {
            return;
        };
        // Dropped from a test's runtime: a thread with its own runtime runs
        // the DROP (FORCE closes the store's connections still open).
        let _ = std::thread::spawn(move || {
            let rt = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
                .unwrap();
            rt.block_on(async {
                let mut conn = connect_admin(&admin).await;
                let _ = sqlx::query(&format!("DROP DATABASE IF EXISTS {name} WITH (FORCE)"))
                    .execute(&mut conn)
                    .await;
            });
        })
        .join();
    }
}

/// Runs each named `async fn name(engine: EngineKind)` of the enclosing
/// module as two tests, `sqlite::name` and `postgres::name`.
macro_rules! on_both_engines {
    ($($name:ident),* $(,)?) => {
        mod sqlite {
            $(
                #[tokio::test]
                async fn $name() {
                    super::$name($crate::engine::EngineKind::Sqlite).await
                }
            )*
        }
        mod postgres {
            $(
                #[tokio::test]
                async fn $name() {
                    super::$name($crate::engine::EngineKind::Postgres).await
                }
            )*
        }
    };
}
pub(crate) use on_both_engines;

#[test]
fn a_test_database_url_keeps_the_server_and_its_parameters() {
    assert_eq!(
        with_database("postgres://postgres@localhost/postgres?host=/x/run&port=54329", "lbt_1"),
        "postgres://postgres@localhost/lbt_1?host=/x/run&port=54329"
    );
    assert_eq!(
        with_database("postgres://u:p@db.lab:5432", "lbt_2"),
        "postgres://u:p@db.lab:5432/lbt_2"
    );
}
