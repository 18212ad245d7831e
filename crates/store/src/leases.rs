//! Daemon leases (`migrations/0010`): which daemon owns which unfinished
//! work, so that on a database several daemons share (PostgreSQL, one per
//! booth) a daemon recovers only the work of daemons that are gone, never a
//! live neighbour's running measurement.
//!
//! - A daemon registers a row in `daemons` at start ([`Store::register_daemon`])
//!   and then works through a store handle that carries its id
//!   ([`Store::as_daemon`]): every measurement, render and study it creates
//!   or starts records `daemon_id` in the same statement, so no row is ever
//!   briefly without an owner.
//! - It renews `heartbeat_at` every few seconds ([`Store::heartbeat`]) and
//!   sets `stopped_at` at a graceful shutdown ([`Store::mark_daemon_stopped`]).
//! - A daemon is *gone* when it has `stopped_at`, or when its last heartbeat
//!   is older than its own `lease_seconds` (each daemon's lease is stored
//!   with it, so daemons with different settings judge each other fairly).
//!   Times are read from the **database's clock** (`clock_timestamp()` on
//!   PostgreSQL, `julianday('now')` on SQLite), never from the booth PCs',
//!   so their clocks need not agree.
//! - Recovery ([`Store::recover_abandoned_work`]) marks the queued and running
//!   measurements, renders and studies of gone daemons `interrupted` (a
//!   measurement keeps its samples), with an error naming the daemon (booth,
//!   host, pid) and its last heartbeat, and returns the ids it marked (so
//!   the daemon that noticed sends the matching events). Each table is recovered with one
//!   conditional `UPDATE … WHERE daemon_id = $d AND state IN ('queued',
//!   'running') AND <daemon $d is still gone>`: when two daemons notice the
//!   same dead one at once, PostgreSQL row-locks each row for the first
//!   UPDATE and re-checks `state` for the second after the first commits
//!   (READ COMMITTED re-evaluates the WHERE on the new row version), so a
//!   row is interrupted exactly once and keeps the first error text; on
//!   SQLite writers are serialised anyway. The gone-check inside the UPDATE
//!   also keeps a daemon that heartbeated again between the look-up and the
//!   UPDATE from losing its work.
//! - **A database outage never expires a lease.** While the database is
//!   away no daemon can renew its lease, and none can judge another's: so
//!   a lease counts only time during which the database was seen answering.
//!   A daemon is gone when it has not heartbeated for its whole lease since
//!   the later of its last heartbeat and the moment the database was last
//!   seen coming back: the server's start (`pg_postmaster_start_time()` on
//!   PostgreSQL: a restarted server restarts every lease), and, for the
//!   daemon judging, the first heartbeat it renewed after one it could not
//!   ([`Store::recover_abandoned_work_seen_since`]; an outage it saw on its
//!   side of the network restarts every lease it judges). A daemon whose
//!   heartbeat fails keeps trying at every beat and renews as soon as the
//!   database answers, well within the lease it is given after the return,
//!   so recovery never takes the work of a daemon that was alive all along
//!   but renewed late because of the outage; and the gone-check inside each
//!   recovery UPDATE still protects one that renews between the look-up
//!   and the UPDATE.
//! - **A dead predecessor is recovered at once** ([`Store::recover_dead_predecessors`]):
//!   a daemon starting finds its own booth's earlier daemons registered on
//!   the same host and not stopped; one whose process is gone (no such pid,
//!   or the pid now runs another program) cannot be alive, so its work is
//!   marked interrupted and its row stopped then, not a lease later.
//! - Rows without a daemon (made before leases, or by a one-shot tool such as
//!   `lightbooth study`) are recovered only when a daemon starts, as before
//!   leases; heartbeats never touch them, so a tool's study running beside
//!   daemons is not interrupted every few seconds.
//! - On SQLite one daemon owns the file (`lightbooth::daemon::db_lock`): at
//!   open every registered daemon is known to be gone, so recovery there
//!   marks all unfinished work interrupted at once, exactly as before leases.

use crate::BoxFuture;
use std::time::Duration;

use super::engine::Engine;
use super::{Booth, Store, StoreError};

/// Which work a recovery may mark interrupted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RecoveryScope {
    /// Also the unfinished rows that name no daemon (at a daemon's start).
    pub rows_without_daemon: bool,
    /// Treat every registered daemon as gone, whatever its heartbeat: true
    /// only when the caller holds the database alone (SQLite's file lock).
    pub every_daemon_is_gone: bool,
}

/// A registered daemon, as recovery reads it.
#[derive(Clone, Debug, PartialEq, sqlx::FromRow)]
pub struct DaemonRow {
    pub id: i64,
    pub booth: String,
    pub host: String,
    pub pid: i64,
    pub lease_seconds: f64,
    pub started_at: f64,
    pub heartbeat_at: f64,
    pub stopped_at: Option<f64>,
}

/// How many rows a recovery marked interrupted, per table, and which (so
/// the daemon that recovered them can tell its event clients).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Recovered {
    pub measurements: u64,
    pub renders: u64,
    pub studies: u64,
    /// Every row marked interrupted, in the order marked.
    pub interrupted: Vec<InterruptedWork>,
}

/// A row a recovery marked interrupted, with the error it was given.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum InterruptedWork {
    Measurement { id: i64, error: String },
    Render { id: i64, scene: String, error: String },
    Study { id: i64, error: String },
}

impl Recovered {
    pub fn total(&self) -> u64 {
        self.measurements + self.renders + self.studies
    }

    /// Adds the rows `(id, scene)` of `table` marked with `error`.
    fn add(&mut self, table: &str, rows: Vec<(i64, Option<String>)>, error: &str) {
        let n = rows.len() as u64;
        match table {
            "measurements" => self.measurements += n,
            "renders" => self.renders += n,
            _ => self.studies += n,
        }
        for (id, scene) in rows {
            let error = error.to_string();
            self.interrupted.push(match table {
                "measurements" => InterruptedWork::Measurement { id, error },
                "renders" => InterruptedWork::Render {
                    id,
                    scene: scene.unwrap_or_default(),
                    error,
                },
                _ => InterruptedWork::Study { id, error },
            });
        }
    }
}

/// What an UPDATE of `table` returns for each row it marks: its id and, for
/// measurements and renders, its scene.
fn returning(table: &str) -> &'static str {
    match table {
        "studies" => "RETURNING id, CAST(NULL AS TEXT) AS scene",
        _ => "RETURNING id, scene",
    }
}

/// The tables whose rows a daemon owns.
const OWNED_TABLES: [&str; 3] = ["measurements", "renders", "studies"];

/// What the error of a recovered row adds after "… before this X finished".
fn retry_hint(table: &str) -> String {
    match table {
        "measurements" => String::new(),
        other => format!("; retry it with POST /api/{other}/{{id}}/retry"),
    }
}

fn noun(table: &str) -> &'static str {
    match table {
        "measurements" => "measurement",
        "renders" => "render",
        _ => "study",
    }
}

/// This machine's host name (Linux: the kernel's; elsewhere `$HOSTNAME`).
fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "an unknown host".into())
}

/// POSIX seconds as `YYYY-MM-DD hh:mm:ss UTC` (proleptic Gregorian calendar,
/// H. Hinnant's days-to-civil algorithm; leap seconds are not counted, as
/// POSIX time does not count them).
pub fn utc_text(t: f64) -> String {
    let secs = t.floor() as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

impl DaemonRow {
    /// Why its unfinished `table` rows were interrupted, naming it.
    fn interruption(&self, table: &str) -> String {
        let who = format!(
            "the daemon of booth `{}` (host {}, pid {}, daemon {})",
            self.booth, self.host, self.pid, self.id
        );
        let what = match self.stopped_at {
            Some(at) => format!("{who} stopped at {} before this {} finished", utc_text(at), noun(table)),
            None => format!(
                "{who} stopped heartbeating before this {} finished: its last heartbeat was at {} \
                 and its lease is {} s",
                noun(table),
                utc_text(self.heartbeat_at),
                self.lease_seconds
            ),
        };
        format!("{what}{}", retry_hint(table))
    }
}

impl Store {
    /// This store handle acting for daemon `id`: rows it creates or starts
    /// record the daemon.
    pub fn as_daemon(&self, id: i64) -> Store {
        Store {
            daemon_id: Some(id),
            ..self.clone()
        }
    }

    /// The daemon this handle acts for, if any.
    pub fn daemon_id(&self) -> Option<i64> {
        self.daemon_id
    }

    /// The database's clock, POSIX seconds, as an SQL expression.
    pub(super) fn clock_sql(&self) -> &'static str {
        match self.engine {
            Engine::Sqlite(_) => "((julianday('now') - 2440587.5) * 86400.0)",
            Engine::Postgres(_) => "(EXTRACT(EPOCH FROM clock_timestamp())::DOUBLE PRECISION)",
        }
    }

    /// Registers this process as a daemon of `booth` holding a lease of
    /// `lease` (renewed by [`Store::heartbeat`]); returns its id.
    pub fn register_daemon<'a>(&'a self, booth: &'a Booth, lease: Duration) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            let clock = self.clock_sql();
            let sql = format!(
                "INSERT INTO daemons (booth, host, pid, lease_seconds, started_at, heartbeat_at) \
                 VALUES ($1, $2, $3, $4, {clock}, {clock}) RETURNING id"
            );
            Ok(with_pool!(self, |pool| sqlx::query_scalar(&sql)
                .bind(booth.as_str())
                .bind(host_name())
                .bind(i64::from(std::process::id()))
                .bind(lease.as_secs_f64())
                .fetch_one(pool)
                .await?))
        })
    }

    /// Renews daemon `id`'s lease. False when it has been marked stopped.
    pub fn heartbeat<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<bool, StoreError>> {
        Box::pin(async move { Ok(self.renew_lease(id).await?.is_some()) })
    }

    /// Renews daemon `id`'s lease; the database's time of the renewal
    /// (POSIX seconds), or `None` when it has been marked stopped.
    pub fn renew_lease<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<f64>, StoreError>> {
        Box::pin(async move {
            let sql = format!(
                "UPDATE daemons SET heartbeat_at = {} WHERE id = $1 AND stopped_at IS NULL RETURNING heartbeat_at",
                self.clock_sql()
            );
            Ok(with_pool!(self, |pool| sqlx::query_scalar(&sql)
                .bind(id)
                .fetch_optional(pool)
                .await?))
        })
    }

    /// The database's time, POSIX seconds, from which leases count (see the
    /// module doc): the server's start on PostgreSQL, never on SQLite (a file
    /// has no outages of its own).
    fn leases_count_from_sql(&self) -> &'static str {
        match self.engine {
            Engine::Sqlite(_) => "0.0",
            Engine::Postgres(_) => "(EXTRACT(EPOCH FROM pg_postmaster_start_time())::DOUBLE PRECISION)",
        }
    }

    /// Recovers at once the unfinished work of this booth's earlier daemons
    /// (and tools) registered on this host whose process is gone (see the
    /// module doc), and marks them stopped; never this handle's own daemon's.
    pub fn recover_dead_predecessors<'a>(&'a self, booth: &'a Booth) -> BoxFuture<'a, Result<Recovered, StoreError>> {
        Box::pin(async move {
            let me = self.daemon_id.unwrap_or(-1);
            let host = host_name();
            let candidates: Vec<DaemonRow> = with_pool!(self, |pool| sqlx::query_as(
                "SELECT id, booth, host, pid, lease_seconds, started_at, heartbeat_at, stopped_at \
                 FROM daemons WHERE booth = $1 AND host = $2 AND stopped_at IS NULL AND id <> $3 ORDER BY id"
            )
            .bind(booth.as_str())
            .bind(&host)
            .bind(me)
            .fetch_all(pool)
            .await?);
            let clock = self.clock_sql();
            let mut recovered = Recovered::default();
            for daemon in candidates.iter().filter(|d| !process_may_be_alive(d.pid)) {
                for table in OWNED_TABLES {
                    let why = format!(
                        "the daemon of booth `{}` (host {}, pid {}, daemon {}) died before this {} finished: \
                         its process is gone, found by the next daemon of the booth on the same host{}",
                        daemon.booth,
                        daemon.host,
                        daemon.pid,
                        daemon.id,
                        noun(table),
                        retry_hint(table)
                    );
                    let sql = format!(
                        "UPDATE {table} SET state = 'interrupted', error = $1, finished_at = {clock} \
                         WHERE daemon_id = $2 AND state IN ('queued', 'running'){} {}",
                        not_a_worker_job(table),
                        returning(table)
                    );
                    let rows: Vec<(i64, Option<String>)> = with_pool!(self, |pool| sqlx::query_as(&sql)
                        .bind(&why)
                        .bind(daemon.id)
                        .fetch_all(pool)
                        .await?);
                    if !rows.is_empty() {
                        tracing::warn!(
                            daemon = daemon.id,
                            pid = daemon.pid,
                            count = rows.len(),
                            "marked the {table} of this booth's dead predecessor as interrupted"
                        );
                    }
                    recovered.add(table, rows, &why);
                }
                self.mark_daemon_stopped(daemon.id).await?;
            }
            Ok(recovered)
        })
    }

    /// Marks daemon `id` stopped (a graceful shutdown, after it marked its
    /// own unfinished work).
    pub fn mark_daemon_stopped<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            let sql = format!(
                "UPDATE daemons SET stopped_at = {} WHERE id = $1 AND stopped_at IS NULL",
                self.clock_sql()
            );
            with_pool!(self, |pool| sqlx::query(&sql)
                .bind(id)
                .execute(pool)
                .await?
                .rows_affected());
            Ok(())
        })
    }

    /// Daemon `id`'s row.
    pub fn daemon<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<DaemonRow>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_as(
                "SELECT id, booth, host, pid, lease_seconds, started_at, heartbeat_at, stopped_at \
                 FROM daemons WHERE id = $1"
            )
            .bind(id)
            .fetch_optional(pool)
            .await?))
        })
    }

    /// Marks the unfinished work of gone daemons interrupted (and, with
    /// `scope.rows_without_daemon`, the unfinished rows naming no daemon),
    /// never this handle's own daemon's. See the module doc for what *gone*
    /// means and why the UPDATEs are race-safe.
    pub fn recover_abandoned_work<'a>(&'a self, scope: RecoveryScope) -> BoxFuture<'a, Result<Recovered, StoreError>> {
        Box::pin(async move { self.recover_abandoned_work_seen_since(scope, None).await })
    }

    /// [`Store::recover_abandoned_work`] by a daemon that has seen the
    /// database answer continuously only since `seen_since` (the database's
    /// time of its first renewal after a failed one): no lease counts time
    /// before it (the module doc's outage rule).
    pub fn recover_abandoned_work_seen_since<'a>(
        &'a self,
        scope: RecoveryScope,
        seen_since: Option<f64>,
    ) -> BoxFuture<'a, Result<Recovered, StoreError>> {
        Box::pin(async move {
            let clock = self.clock_sql();
            let counts_from = format!(
                "{}({}, {:?})",
                match self.engine {
                    Engine::Sqlite(_) => "MAX",
                    Engine::Postgres(_) => "GREATEST",
                },
                self.leases_count_from_sql(),
                seen_since.filter(|t| t.is_finite()).unwrap_or(0.0)
            );
            let gone = if scope.every_daemon_is_gone {
                "TRUE".to_string()
            } else {
                let last_sign_of_life = match self.engine {
                    Engine::Sqlite(_) => format!("MAX(d.heartbeat_at, {counts_from})"),
                    Engine::Postgres(_) => format!("GREATEST(d.heartbeat_at, {counts_from})"),
                };
                format!("(d.stopped_at IS NOT NULL OR {last_sign_of_life} + d.lease_seconds < {clock})")
            };
            let has_work = OWNED_TABLES
                .iter()
                .map(|t| {
                    format!(
                        "EXISTS (SELECT 1 FROM {t} w WHERE w.daemon_id = d.id AND w.state IN ('queued', 'running'))"
                    )
                })
                .collect::<Vec<_>>()
                .join(" OR ");
            let find = format!(
                "SELECT d.id, d.booth, d.host, d.pid, d.lease_seconds, d.started_at, d.heartbeat_at, d.stopped_at \
                 FROM daemons d WHERE d.id <> $1 AND {gone} AND ({has_work}) ORDER BY d.id"
            );
            let me = self.daemon_id.unwrap_or(-1);
            let daemons: Vec<DaemonRow> =
                with_pool!(self, |pool| sqlx::query_as(&find).bind(me).fetch_all(pool).await?);
            let mut recovered = Recovered::default();
            for daemon in &daemons {
                for table in OWNED_TABLES {
                    let sql = format!(
                        "UPDATE {table} SET state = 'interrupted', error = $1, finished_at = {clock} \
                         WHERE daemon_id = $2 AND state IN ('queued', 'running') \
                         AND EXISTS (SELECT 1 FROM daemons d WHERE d.id = $2 AND {gone}){} {}",
                        not_a_worker_job(table),
                        returning(table)
                    );
                    let why = daemon.interruption(table);
                    let rows: Vec<(i64, Option<String>)> = with_pool!(self, |pool| sqlx::query_as(&sql)
                        .bind(&why)
                        .bind(daemon.id)
                        .fetch_all(pool)
                        .await?);
                    let n = rows.len();
                    if n > 0 {
                        tracing::warn!(
                            daemon = daemon.id,
                            booth = %daemon.booth,
                            host = %daemon.host,
                            pid = daemon.pid,
                            count = n,
                            "marked the {table} of a daemon that is gone as interrupted"
                        );
                    }
                    recovered.add(table, rows, &why);
                }
            }
            if scope.rows_without_daemon {
                for table in OWNED_TABLES {
                    let why = format!(
                        "the daemon stopped before this {} finished{}",
                        noun(table),
                        retry_hint(table)
                    );
                    let sql = format!(
                        "UPDATE {table} SET state = 'interrupted', error = $1, finished_at = {clock} \
                         WHERE daemon_id IS NULL AND state IN ('queued', 'running'){} {}",
                        not_a_worker_job(table),
                        returning(table)
                    );
                    let rows: Vec<(i64, Option<String>)> =
                        with_pool!(self, |pool| sqlx::query_as(&sql).bind(&why).fetch_all(pool).await?);
                    let n = rows.len();
                    if n > 0 {
                        tracing::warn!(
                            count = n,
                            "marked {table} left unfinished by the last run as interrupted"
                        );
                    }
                    recovered.add(table, rows, &why);
                }
            }
            Ok(recovered)
        })
    }

    /// Marks this handle's daemon's queued and running rows of `table`
    /// (`measurements`, `renders` or `studies`) interrupted with `why` — its
    /// own work at shutdown, never a neighbour's. Without a daemon (a
    /// one-shot tool's handle) it marks every unfinished row, as before
    /// leases.
    pub fn interrupt_own_unfinished<'a>(
        &'a self,
        table: &'a str,
        why: &'a str,
    ) -> BoxFuture<'a, Result<u64, StoreError>> {
        Box::pin(async move {
            let table = OWNED_TABLES
                .into_iter()
                .find(|t| *t == table)
                .ok_or_else(|| StoreError::Conflict(format!("no daemon-owned table `{table}`")))?;
            let sql = format!(
                "UPDATE {table} SET state = 'interrupted', error = $1, finished_at = $2 \
                 WHERE state IN ('queued', 'running') AND ($3 IS NULL OR daemon_id = $3)"
            );
            Ok(with_pool!(self, |pool| sqlx::query(&sql)
                .bind(why)
                .bind(super::now())
                .bind(self.daemon_id)
                .execute(pool)
                .await?
                .rows_affected()))
        })
    }
}

/// Whether process `pid` of this host may still be the daemon registered
/// with it: false when no such process exists, or it runs a program that is
/// not lightbooth (the pid was reused). True where `/proc` cannot tell (not
/// Linux), and for this very process (tests run several daemons in one):
/// the lease decides there.
fn process_may_be_alive(pid: i64) -> bool {
    if pid == i64::from(std::process::id()) {
        return true;
    }
    if !std::path::Path::new("/proc/self/cmdline").exists() {
        return true;
    }
    match std::fs::read(format!("/proc/{pid}/cmdline")) {
        // A zombie's cmdline is empty: it is gone too.
        Ok(cmdline) => {
            let argv0 = cmdline.split(|b| *b == 0).next().unwrap_or_default();
            let argv0 = String::from_utf8_lossy(argv0);
            std::path::Path::new(&*argv0)
                .file_name()
                .is_some_and(|name| name.to_string_lossy().contains("lightbooth"))
        }
        Err(_) => false,
    }
}

/// The condition that keeps recovery off the render and study rows of
/// unfinished worker jobs (`worker_jobs.rs`): the job queue owns those, and
/// re-queues them when their worker is gone.
fn not_a_worker_job(table: &str) -> String {
    let kind = match table {
        "renders" => "render",
        "studies" => "study",
        _ => return String::new(),
    };
    format!(
        " AND NOT EXISTS (SELECT 1 FROM worker_jobs j WHERE j.kind = '{kind}' AND j.subject_id = {table}.id \
         AND j.state IN ('queued', 'running'))"
    )
}

#[cfg(test)]
mod tests {
    use super::utc_text;

    /// Against dates whose POSIX times are published (the epoch; the
    /// billennium; a leap day; one before the epoch).
    #[test]
    fn utc_text_matches_known_posix_times() {
        assert_eq!(utc_text(0.0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc_text(1_000_000_000.0), "2001-09-09 01:46:40 UTC");
        assert_eq!(utc_text(951_782_400.5), "2000-02-29 00:00:00 UTC");
        assert_eq!(utc_text(-1.0), "1969-12-31 23:59:59 UTC");
    }
}
