//! The two database engines behind [`Store`](super::Store): which one a URL
//! names, how each is connected (SQLite's pragmas, pool sizes), and each
//! one's embedded migrations (`migrations/sqlite/`, `migrations/postgres/`).
//! Everything else — every query — is shared, through `with_pool!` in the
//! store's module.

use crate::BoxFuture;
use std::str::FromStr;
use std::time::Duration;

use sqlx::migrate::Migrator;
use sqlx::postgres::{PgConnectOptions, PgPool, PgPoolOptions};
use sqlx::sqlite::{SqliteConnectOptions, SqliteJournalMode, SqlitePool, SqlitePoolOptions, SqliteSynchronous};

use super::StoreError;

/// The SQLite migrations: the files lightbooth has always applied (moved,
/// never edited: sqlx checks each applied migration's checksum).
pub static SQLITE_MIGRATIONS: Migrator = sqlx::migrate!("../../migrations/sqlite");

/// The PostgreSQL migrations: the same versions, one for one, in
/// PostgreSQL's dialect.
pub static POSTGRES_MIGRATIONS: Migrator = sqlx::migrate!("../../migrations/postgres");

/// A connection pool on one of the two engines.
#[derive(Clone, Debug)]
pub enum Engine {
    Sqlite(SqlitePool),
    Postgres(PgPool),
}

/// Which engine a database URL names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EngineKind {
    Sqlite,
    Postgres,
}

impl EngineKind {
    /// `sqlite:…` or `postgres://…` / `postgresql://…`; anything else is an
    /// error that names the accepted forms (never the URL itself: it may
    /// carry a password).
    pub fn of_url(url: &str) -> Result<EngineKind, StoreError> {
        if url.starts_with("sqlite:") {
            Ok(EngineKind::Sqlite)
        } else if url.starts_with("postgres://") || url.starts_with("postgresql://") {
            Ok(EngineKind::Postgres)
        } else {
            let scheme = url.split(':').next().unwrap_or_default();
            Err(StoreError::Url(format!(
                "--db: unknown database kind `{scheme}:`; give sqlite://FILE (one booth) or \
                 postgres://USER@HOST/DATABASE (a shared PostgreSQL server)"
            )))
        }
    }
}

/// Creates the SQLite file `path`, empty and readable only by its owner
/// (0600), unless it exists: SQLite itself would create it with the umask's
/// mode (typically 0644, every user could read every measurement), and it
/// gives its `-wal` and `-shm` files the main file's mode. An existing file
/// keeps its mode (the operator's choice); a file that cannot be created is
/// left to SQLite to report.
fn create_private(path: &std::path::Path) {
    let mut options = std::fs::OpenOptions::new();
    options.write(true).create_new(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    if let Err(e) = options.open(path) {
        if e.kind() != std::io::ErrorKind::AlreadyExists {
            tracing::debug!(path = %path.display(), error = %e, "cannot create the database file; SQLite will say why");
        }
    }
}

impl Engine {
    /// Connects to `url` and applies that engine's migrations.
    pub fn connect<'a>(url: &'a str, synchronous: SqliteSynchronous) -> BoxFuture<'a, Result<Engine, StoreError>> {
        Box::pin(async move {
            match EngineKind::of_url(url)? {
                EngineKind::Sqlite => {
                    let options = SqliteConnectOptions::from_str(url)?;
                    if !url.contains(":memory:") && !url.contains("mode=memory") {
                        create_private(options.get_filename());
                    }
                    let options = options
                        .create_if_missing(true)
                        .journal_mode(SqliteJournalMode::Wal)
                        .synchronous(synchronous)
                        .foreign_keys(true)
                        .busy_timeout(Duration::from_secs(5));
                    // An in-memory database lives per connection: keep exactly one.
                    let max = if url.contains(":memory:") { 1 } else { 8 };
                    let pool = SqlitePoolOptions::new()
                        .max_connections(max)
                        .connect_with(options)
                        .await?;
                    SQLITE_MIGRATIONS.run(&pool).await?;
                    Ok(Engine::Sqlite(pool))
                }
                EngineKind::Postgres => {
                    let options = PgConnectOptions::from_str(url)?.application_name("lightbooth");
                    let pool = PgPoolOptions::new()
                        .max_connections(8)
                        .acquire_timeout(Duration::from_secs(10))
                        .connect_with(options)
                        .await?;
                    POSTGRES_MIGRATIONS.run(&pool).await?;
                    Ok(Engine::Postgres(pool))
                }
            }
        })
    }

    pub fn name(&self) -> &'static str {
        match self {
            Engine::Sqlite(_) => "sqlite",
            Engine::Postgres(_) => "postgres",
        }
    }
}
