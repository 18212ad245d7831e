//! The daemon's lock on its database file: one daemon per SQLite file
//! (a second is refused naming the file and the holder's pid), none for a
//! server database that several daemons share.

use std::path::{Path, PathBuf};

use lightbooth::daemon::db_lock::{acquire, database_path, lock_path};

#[test]
fn database_urls_name_their_file() {
    assert_eq!(database_path("sqlite://lab.sqlite"), Some(PathBuf::from("lab.sqlite")));
    assert_eq!(
        database_path("sqlite:///tmp/x/lab.sqlite?mode=rwc"),
        Some(PathBuf::from("/tmp/x/lab.sqlite"))
    );
    assert_eq!(database_path("sqlite::memory:"), None);
    assert_eq!(
        lock_path(Path::new("/a/lab.sqlite")),
        PathBuf::from("/a/lab.sqlite.lock")
    );
}

#[test]
fn daemons_sharing_a_postgres_database_do_not_refuse_each_other() {
    let url = "postgres://lab@db.example/lightbooth";
    assert_eq!(database_path(url), None);
    let first = acquire(url).unwrap();
    let second = acquire(url).unwrap();
    assert!(
        first.is_none() && second.is_none(),
        "no file lock for a server database"
    );
}

#[test]
fn a_second_lock_on_one_database_is_refused_naming_the_file_and_the_pid() {
    let dir = tempfile::tempdir().unwrap();
    let url = format!("sqlite://{}", dir.path().join("lab.sqlite").display());
    let first = acquire(&url).unwrap().expect("a file database is locked");
    let err = acquire(&url).unwrap_err().to_string();
    assert!(err.contains("lab.sqlite"), "{err}");
    assert!(err.contains(&format!("pid {}", std::process::id())), "{err}");
    drop(first);
    assert!(acquire(&url).unwrap().is_some(), "released when dropped");
}
