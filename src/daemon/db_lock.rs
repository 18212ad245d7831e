//! One daemon per database file. At start-up a daemon on SQLite marks every
//! measurement, render and study left unfinished as interrupted (holding the
//! file alone, it knows every other daemon registered in it is gone); a
//! second daemon on the same file would do that to the first one's running
//! work. So the daemon holds an exclusive lock on `<database>.lock` (an advisory
//! `flock` through [`std::fs::File::try_lock`]) for as long as it runs; the
//! operating system releases it when the process ends, even on `kill -9`.
//! The file also holds the holder's pid, for the message a second daemon
//! prints.
//!
//! Only SQLite databases are locked. On PostgreSQL (`postgres://…`) several
//! daemons — one per booth — may share one database, so none is refused.
//! There each daemon holds a lease instead (`store/leases.rs`, migration
//! 0010): it registers, records itself on the work it creates or runs, and
//! renews its lease with a heartbeat; at start and on every heartbeat a
//! daemon marks interrupted only the unfinished work of daemons whose lease
//! expired or that stopped (and, at start, rows naming no daemon), never a
//! live neighbour's running measurement.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// The held lock; released when dropped.
#[derive(Debug)]
pub struct DbLock {
    _file: File,
    pub path: PathBuf,
}

/// The database file of an `sqlite:` URL; `None` for an in-memory database
/// and for any other engine (a PostgreSQL server is shared, never locked).
pub fn database_path(url: &str) -> Option<PathBuf> {
    let rest = url.strip_prefix("sqlite://").or_else(|| url.strip_prefix("sqlite:"))?;
    let path = rest.split('?').next().unwrap_or_default();
    if path.is_empty() || path.contains(":memory:") || url.contains("mode=memory") {
        return None;
    }
    Some(PathBuf::from(path))
}

/// The lock file next to a database file: `lab.sqlite` → `lab.sqlite.lock`.
pub fn lock_path(database: &Path) -> PathBuf {
    let mut name = database.as_os_str().to_os_string();
    name.push(".lock");
    PathBuf::from(name)
}

/// Takes the lock of the database at `url` or says who holds it.
pub fn acquire(url: &str) -> anyhow::Result<Option<DbLock>> {
    let Some(database) = database_path(url) else {
        return Ok(None);
    };
    let path = lock_path(&database);
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| anyhow::anyhow!("cannot create the folder {}: {e}", dir.display()))?;
    }
    let mut file = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(&path)
        .map_err(|e| anyhow::anyhow!("cannot open the lock file {}: {e}", path.display()))?;
    match file.try_lock() {
        Ok(()) => {}
        Err(TryLockError::WouldBlock) => {
            let mut holder = String::new();
            let _ = file.read_to_string(&mut holder);
            let pid = match holder.trim().parse::<u32>() {
                Ok(pid) => format!("pid {pid}"),
                Err(_) => "pid unknown".into(),
            };
            anyhow::bail!(
                "the database {} is in use by another lightbooth daemon ({pid}; lock file {}): \
                 stop that daemon first, or give this one another --db",
                database.display(),
                path.display()
            );
        }
        Err(TryLockError::Error(e)) => {
            anyhow::bail!(
                "cannot lock {} (for the database {}): {e}",
                path.display(),
                database.display()
            )
        }
    }
    // Ours now: record who holds it.
    file.set_len(0)?;
    file.seek(SeekFrom::Start(0))?;
    writeln!(file, "{}", std::process::id())?;
    file.flush()?;
    Ok(Some(DbLock { _file: file, path }))
}
