//! The booth load harness: several `lightbooth serve` processes (simulated
//! booths) sharing one PostgreSQL database, a load of scene-target
//! measurements submitted through their REST APIs, and the audit of what
//! the database holds afterwards — measurements lost or duplicated,
//! comparisons missing — plus the kill test (SIGKILL of one daemon
//! mid-measurement). `benches/booths_scale.rs` (the scale test, with
//! figures) and `tests/daemon/booths_scale.rs` (a small load in CI) both use
//! it as `common::booths`.
//!
//! Every process is started by one small function: [`spawn_serve`] for a
//! booth's daemon, [`spawn_worker`] for a render worker (`lightbooth
//! worker`, run in an empty folder: it renders from the scene bundles in
//! the database); daemons leave their rendering to workers with
//! `--renders workers` in [`ServeOptions::extra_args`].
//!
//! A submission is identified by its note (unique per run), not by the id
//! the daemon answered: the audit counts the rows carrying each note, so a
//! measurement recorded twice or not at all shows whatever ids say.

#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

use super::{get_json, poll_until, post_json, TOKEN};

/// How each `serve` child is started.
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// `--mock-speed`: 0 = instant, 1 = the PR-650's own timing.
    pub mock_speed: f64,
    /// Config keys `heartbeat_seconds` and `lease_seconds`: short, so a
    /// killed daemon's work is recovered within seconds.
    pub heartbeat_seconds: f64,
    pub lease_seconds: f64,
    /// Config key `render_samples` of the comparison renders.
    pub render_samples: u64,
    /// Config key `codings`: every complete scene-target measurement gets
    /// one comparison row per coding.
    pub codings: Vec<String>,
    /// More command-line arguments (e.g. `--renders workers`, once daemons
    /// can leave rendering to workers).
    pub extra_args: Vec<String>,
}

impl Default for ServeOptions {
    fn default() -> ServeOptions {
        ServeOptions {
            mock_speed: 0.0,
            heartbeat_seconds: 0.5,
            lease_seconds: 2.0,
            render_samples: 1024,
            codings: ["rgb", "srgb", "nstep3", "spectral"].map(String::from).to_vec(),
            extra_args: Vec::new(),
        }
    }
}

/// `lightbooth serve` as a child process, killed (SIGKILL) when dropped.
pub struct ServeProcess {
    pub child: Child,
    pub addr: SocketAddr,
    pub booth: String,
    dir: tempfile::TempDir,
}

impl ServeProcess {
    /// The last lines of its log (stderr), for a failure message.
    pub fn log_tail(&self) -> String {
        let log = std::fs::read_to_string(self.dir.path().join("serve.log")).unwrap_or_default();
        let lines: Vec<&str> = log.lines().collect();
        lines[lines.len().saturating_sub(20)..].join("\n")
    }

    /// kill -9: no shutdown, no lease release; waits for the process to end.
    pub fn kill(&mut self) {
        self.child.kill().expect("SIGKILL the daemon");
        self.child.wait().expect("reap the daemon");
    }
}

impl Drop for ServeProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Runs the built binary `serve --mock --db DB --booth BOOTH` on a free
/// loopback port; returns once its instrument is idle. Its address comes
/// from the line `lightbooth listening on http://ADDR/` it prints.
pub async fn spawn_serve(db: &str, booth: &str, options: &ServeOptions) -> ServeProcess {
    let dir = tempfile::tempdir().unwrap();
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    // Converged spectra (the simulated booth's truth) are keyed by scene
    // content: shared by every test and benchmark run.
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("converged-cache");
    let config = dir.path().join("lightbooth.toml");
    std::fs::write(
        &config,
        format!(
            "scenes_dir = {:?}\ncache_dir = {:?}\nheartbeat_seconds = {}\nlease_seconds = {}\nrender_samples = {}\npreview_paths = 1\ncodings = {:?}\n",
            root.join("scenes").display().to_string(),
            cache.display().to_string(),
            options.heartbeat_seconds,
            options.lease_seconds,
            options.render_samples,
            options.codings,
        ),
    )
    .unwrap();
    let token_file = dir.path().join("token");
    std::fs::write(&token_file, TOKEN).unwrap();
    let log = std::fs::File::create(dir.path().join("serve.log")).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .current_dir(&root)
        .args(["serve", "--mock", "--bind", "127.0.0.1:0", "--db", db, "--booth", booth])
        .args(["--mock-speed", &options.mock_speed.to_string()])
        .arg("--config")
        .arg(&config)
        .arg("--token-file")
        .arg(&token_file)
        .args(&options.extra_args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::from(log))
        .spawn()
        .expect("run lightbooth serve");
    let stdout = child.stdout.take().unwrap();
    // Read its lines on a thread (and keep draining them) so it never
    // blocks on a full pipe.
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if let Some(rest) = line.strip_prefix("lightbooth listening on http://") {
                let _ = tx.send(rest.trim_end_matches('/').to_string());
            }
        }
    });
    let printed = tokio::task::spawn_blocking(move || rx.recv_timeout(Duration::from_secs(60)))
        .await
        .unwrap();
    let mut process = ServeProcess {
        child,
        addr: SocketAddr::from(([127, 0, 0, 1], 0)),
        booth: booth.to_string(),
        dir,
    };
    let Ok(addr) = printed else {
        panic!(
            "the daemon of booth {booth} never printed its address:\n{}",
            process.log_tail()
        );
    };
    process.addr = addr.parse().unwrap();
    poll_until(process.addr, "/api/health", Duration::from_secs(60), |v| {
        v["instrument"]["state"] == "idle"
    })
    .await;
    process
}

/// `lightbooth worker` as a child process in an empty folder, killed
/// (SIGKILL) when dropped.
pub struct WorkerProcess {
    pub child: Child,
    /// Its id in `daemons` (it prints `lightbooth worker ID claiming jobs …`).
    pub id: i64,
    dir: tempfile::TempDir,
}

impl WorkerProcess {
    /// The last lines of its log (stderr), for a failure message.
    pub fn log_tail(&self) -> String {
        let log = std::fs::read_to_string(self.dir.path().join("worker.log")).unwrap_or_default();
        let lines: Vec<&str> = log.lines().collect();
        lines[lines.len().saturating_sub(20)..].join("\n")
    }

    /// kill -9: no shutdown, no lease release; waits for the process to end.
    pub fn kill(&mut self) {
        self.child.kill().expect("SIGKILL the worker");
        self.child.wait().expect("reap the worker");
    }
}

impl Drop for WorkerProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Runs the built binary `worker --db DB` with the given lease, in an empty
/// folder (no `scenes/`); returns once it has registered.
pub async fn spawn_worker(db: &str, heartbeat_seconds: f64, lease_seconds: f64) -> WorkerProcess {
    let dir = tempfile::tempdir().unwrap();
    let log = std::fs::File::create(dir.path().join("worker.log")).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .current_dir(dir.path())
        .args(["worker", "--db", db, "--poll-ms", "50"])
        .arg("--cache-dir")
        .arg(dir.path().join("cache"))
        .args(["--heartbeat-seconds", &heartbeat_seconds.to_string()])
        .args(["--lease-seconds", &lease_seconds.to_string()])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::from(log))
        .spawn()
        .expect("run lightbooth worker");
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if let Some(rest) = line.strip_prefix("lightbooth worker ") {
                let _ = tx.send(rest.split_whitespace().next().and_then(|s| s.parse::<i64>().ok()));
            }
        }
    });
    let printed = tokio::task::spawn_blocking(move || rx.recv_timeout(Duration::from_secs(60)))
        .await
        .unwrap();
    let mut worker = WorkerProcess { child, id: 0, dir };
    match printed {
        Ok(Some(id)) => worker.id = id,
        _ => panic!("the worker never printed its id:\n{}", worker.log_tail()),
    }
    worker
}

/// The booths' daemons on one database, and the render workers.
pub struct Lab {
    pub db: String,
    pub daemons: Vec<ServeProcess>,
    pub workers: Vec<WorkerProcess>,
}

/// `booth-1` … `booth-N`.
pub fn booth_names(n: usize) -> Vec<String> {
    (1..=n).map(|k| format!("booth-{k}")).collect()
}

/// Starts one daemon per booth on `db`.
pub async fn start_lab(db: &str, booths: &[String], options: &ServeOptions) -> Lab {
    let mut daemons = Vec::new();
    for booth in booths {
        daemons.push(spawn_serve(db, booth, options).await);
    }
    Lab {
        db: db.to_string(),
        daemons,
        workers: Vec::new(),
    }
}

/// The scene targets the load measures, round robin: the four single-patch
/// scenes (the WHITE patch is the others' CIELAB white, so its
/// measurements also bring their comparisons to a new white).
pub const TARGETS: [(&str, &str); 4] = [
    ("red", "patch"),
    ("green", "patch"),
    ("blue", "patch"),
    ("white", "patch"),
];

/// One measurement the load asked a daemon for.
#[derive(Clone, Debug)]
pub struct Submission {
    pub note: String,
    pub booth: String,
    pub scene: String,
    pub target: String,
    /// The id the daemon answered with its 202.
    pub id: i64,
}

/// Asks the daemon at `addr` for a measurement of `scene`/`target` with
/// `samples` samples and the note `note`; a 409 (its queue is full) is
/// retried after a pause, since it records nothing.
pub async fn submit(addr: SocketAddr, scene: &str, target: &str, samples: usize, note: &str) -> i64 {
    let body = json!({ "scene": scene, "target": target, "samples": samples, "note": note }).to_string();
    let deadline = Instant::now() + Duration::from_secs(600);
    loop {
        let (status, v) = post_json(addr, "/api/measurements", TOKEN, &body).await;
        match status {
            202 => return v["id"].as_i64().expect("202 names the id"),
            409 if Instant::now() < deadline => tokio::time::sleep(Duration::from_millis(50)).await,
            _ => panic!("POST /api/measurements to {addr} ({note}): {status} {v}"),
        }
    }
}

/// Submits `per_booth` measurements to every daemon of `lab` at once (one
/// submitter per booth), `targets` round robin; `run` makes the notes unique.
pub async fn submit_load(
    lab: &Lab,
    run: &str,
    per_booth: usize,
    samples: usize,
    targets: &[(&'static str, &'static str)],
) -> Vec<Submission> {
    let mut tasks = Vec::new();
    for d in &lab.daemons {
        let (addr, booth, run, targets) = (d.addr, d.booth.clone(), run.to_string(), targets.to_vec());
        tasks.push(tokio::spawn(async move {
            let mut out = Vec::new();
            for k in 0..per_booth {
                let (scene, target) = targets[k % targets.len()];
                let note = format!("{run} {booth} #{k}");
                let id = submit(addr, scene, target, samples, &note).await;
                out.push(Submission {
                    note,
                    booth: booth.clone(),
                    scene: scene.into(),
                    target: target.into(),
                    id,
                });
            }
            out
        }));
    }
    let mut all = Vec::new();
    for t in tasks {
        all.extend(t.await.unwrap());
    }
    all
}

/// Every measurement row in the database, through the API of the daemon at
/// `reader` (pages of 1000).
pub async fn all_measurements(reader: SocketAddr) -> Vec<Value> {
    let mut rows = Vec::new();
    loop {
        let (status, page) = get_json(reader, &format!("/api/measurements?limit=1000&offset={}", rows.len())).await;
        assert_eq!(status, 200, "{page}");
        let items = page["items"].as_array().unwrap();
        rows.extend(items.iter().cloned());
        if items.is_empty() || rows.len() as i64 >= page["total"].as_i64().unwrap() {
            return rows;
        }
    }
}

/// What the database holds for a set of submissions.
#[derive(Debug, Default)]
pub struct Audit {
    pub submitted: usize,
    /// Submitted, but no row carries the note, or its row is not final.
    pub lost: Vec<String>,
    /// More than one row carries the note.
    pub duplicated: Vec<String>,
    /// Final, but not complete (failed, interrupted, cancelled): state and error.
    pub not_complete: Vec<String>,
    /// The row's id or booth differs from what the daemon answered.
    pub mismatched: Vec<String>,
    /// Complete scene-target measurements whose comparison rows are not
    /// exactly one per configured coding: what was found.
    pub comparisons_missing: Vec<String>,
    pub comparisons: usize,
    /// Still queued or running (a subset of `lost` while waiting).
    pub unfinished: usize,
}

impl Audit {
    pub fn passed(&self) -> bool {
        self.lost.is_empty()
            && self.duplicated.is_empty()
            && self.not_complete.is_empty()
            && self.mismatched.is_empty()
            && self.comparisons_missing.is_empty()
    }

    pub fn to_json(&self) -> Value {
        json!({
            "submitted": self.submitted,
            "lost": self.lost.len(),
            "duplicated": self.duplicated.len(),
            "not_complete": self.not_complete.len(),
            "mismatched": self.mismatched.len(),
            "comparisons": self.comparisons,
            "comparisons_missing": self.comparisons_missing.len(),
            "examples": self.lost.iter().chain(&self.duplicated).chain(&self.not_complete)
                .chain(&self.mismatched).chain(&self.comparisons_missing).take(10).collect::<Vec<_>>(),
        })
    }
}

/// Audits `subs` against the database (through `reader`): every submission
/// exactly one row, final and complete, with one comparison per coding of
/// `codings`.
pub async fn audit(reader: SocketAddr, subs: &[Submission], codings: &[String]) -> Audit {
    let mut by_note: BTreeMap<&str, Vec<Value>> = BTreeMap::new();
    let rows = all_measurements(reader).await;
    for row in &rows {
        if let Some(note) = row["note"].as_str() {
            by_note.entry(note).or_default().push(row.clone());
        }
    }
    let wanted: BTreeSet<&str> = codings.iter().map(String::as_str).collect();
    let mut a = Audit {
        submitted: subs.len(),
        ..Audit::default()
    };
    for s in subs {
        let found = by_note.get(s.note.as_str()).map(Vec::as_slice).unwrap_or_default();
        let row = match found {
            [] => {
                a.lost
                    .push(format!("{}: no row (the daemon answered id {})", s.note, s.id));
                continue;
            }
            [row] => row,
            more => {
                let ids: Vec<i64> = more.iter().filter_map(|r| r["id"].as_i64()).collect();
                a.duplicated.push(format!("{}: rows {ids:?}", s.note));
                continue;
            }
        };
        let state = row["state"].as_str().unwrap_or_default();
        if row["id"].as_i64() != Some(s.id) || row["booth"].as_str() != Some(s.booth.as_str()) {
            a.mismatched.push(format!(
                "{}: answered id {} booth {}, row {} booth {}",
                s.note, s.id, s.booth, row["id"], row["booth"]
            ));
        }
        match state {
            "queued" | "running" => {
                a.unfinished += 1;
                a.lost.push(format!("{}: measurement {} still {state}", s.note, s.id));
                continue;
            }
            "complete" => {}
            other => {
                a.not_complete
                    .push(format!("{}: measurement {} {other}: {}", s.note, s.id, row["error"]));
                continue;
            }
        }
        let (status, rows) = get_json(reader, &format!("/api/measurements/{}/comparisons", s.id)).await;
        assert_eq!(status, 200, "{rows}");
        let rows = rows.as_array().cloned().unwrap_or_default();
        a.comparisons += rows.len();
        let got: Vec<&str> = rows.iter().filter_map(|r| r["coding"].as_str()).collect();
        let distinct: BTreeSet<&str> = got.iter().copied().collect();
        if got.len() != wanted.len() || distinct != wanted {
            a.comparisons_missing
                .push(format!("{}: measurement {} has comparisons {got:?}", s.note, s.id));
        }
    }
    a
}

/// Audits until every submission is final with its comparisons (or
/// `limit` passes); the last audit.
pub async fn audit_when_settled(reader: SocketAddr, subs: &[Submission], codings: &[String], limit: Duration) -> Audit {
    let deadline = Instant::now() + limit;
    loop {
        let a = audit(reader, subs, codings).await;
        let settled = a.unfinished == 0 && a.comparisons_missing.is_empty();
        if settled || Instant::now() >= deadline {
            return a;
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
    }
}

/// The load part of the scale test: `per_booth` measurements of `samples`
/// samples of `targets` on every booth, waited for (bounded by `limit`)
/// and audited. Each daemon renders each scene for its comparisons once
/// (unless another daemon's render of it is already stored): with the
/// camera preview every render makes, that dominates a small load.
pub struct LoadRun {
    pub submissions: Vec<Submission>,
    pub audit: Audit,
    /// From the first submission until every measurement was final with
    /// its comparisons.
    pub wall_seconds: f64,
    pub submit_seconds: f64,
}

impl LoadRun {
    pub fn comparisons_per_second(&self) -> f64 {
        self.audit.comparisons as f64 / self.wall_seconds
    }

    pub fn to_json(&self) -> Value {
        json!({
            "audit": self.audit.to_json(),
            "wall_seconds": self.wall_seconds,
            "submit_seconds": self.submit_seconds,
            "measurements_per_second": self.submissions.len() as f64 / self.wall_seconds,
            "comparisons_per_second": self.comparisons_per_second(),
        })
    }
}

pub async fn run_load(
    lab: &Lab,
    run: &str,
    per_booth: usize,
    samples: usize,
    targets: &[(&'static str, &'static str)],
    codings: &[String],
    limit: Duration,
) -> LoadRun {
    let t = Instant::now();
    let submissions = submit_load(lab, run, per_booth, samples, targets).await;
    let submit_seconds = t.elapsed().as_secs_f64();
    let audit = audit_when_settled(lab.daemons[0].addr, &submissions, codings, limit).await;
    LoadRun {
        submissions,
        audit,
        wall_seconds: t.elapsed().as_secs_f64(),
        submit_seconds,
    }
}

/// What the kill test saw.
#[derive(Debug, Default)]
pub struct KillOutcome {
    pub victim: String,
    pub measurement_id: i64,
    pub samples_at_kill: usize,
    /// The killed measurement as a neighbour left it.
    pub state_after: String,
    pub samples_after: usize,
    pub error: String,
    /// From the kill until a neighbour marked it interrupted.
    pub recovery_seconds: f64,
    /// Measurements on the other booths started around the kill.
    pub neighbours: Audit,
    /// Everything measured before (the load), audited again after the kill.
    pub before: Audit,
    pub failures: Vec<String>,
}

impl KillOutcome {
    pub fn to_json(&self) -> Value {
        json!({
            "victim": self.victim,
            "measurement_id": self.measurement_id,
            "samples_at_kill": self.samples_at_kill,
            "state_after": self.state_after,
            "samples_after": self.samples_after,
            "error": self.error,
            "recovery_seconds": self.recovery_seconds,
            "neighbours": self.neighbours.to_json(),
            "load_after_kill": self.before.to_json(),
            "failures": self.failures,
        })
    }
}

/// kill -9 of the last daemon of `lab` mid-measurement: its replies are
/// slowed (the simulated PR-650's `slow@MS` fault, every reply) so a
/// measurement of `samples` samples is still running when it is killed
/// after two samples, while every other booth measures `per_neighbour`
/// more. A neighbour must mark the killed measurement interrupted with
/// every sample it took, and everything else — the neighbours' new
/// measurements and all of `earlier` — must end (or stay) complete with
/// its comparisons. The victim is removed from `lab`.
pub async fn kill_test(
    lab: &mut Lab,
    run: &str,
    samples: usize,
    per_neighbour: usize,
    earlier: &[Submission],
    codings: &[String],
) -> KillOutcome {
    let mut victim = lab.daemons.pop().expect("a daemon to kill");
    let reader = lab.daemons.first().expect("a neighbour that survives the kill").addr;
    let mut out = KillOutcome {
        victim: victim.booth.clone(),
        ..KillOutcome::default()
    };
    let (status, v) = post_json(victim.addr, "/api/mock/faults", TOKEN, r#"{"faults":"slow@250ms"}"#).await;
    assert_eq!(status, 204, "{v}");
    let note = format!("{run} {} slow", victim.booth);
    let (scene, target) = TARGETS[0];
    out.measurement_id = submit(victim.addr, scene, target, samples, &note).await;
    let url = format!("/api/measurements/{}", out.measurement_id);
    let mut tasks = Vec::new();
    for d in &lab.daemons {
        let (addr, booth, run) = (d.addr, d.booth.clone(), run.to_string());
        tasks.push(tokio::spawn(async move {
            let mut subs = Vec::new();
            for k in 0..per_neighbour {
                let (scene, target) = TARGETS[k % TARGETS.len()];
                let note = format!("{run} {booth} beside the kill #{k}");
                let id = submit(addr, scene, target, 3, &note).await;
                subs.push(Submission {
                    note,
                    booth: booth.clone(),
                    scene: scene.into(),
                    target: target.into(),
                    id,
                });
            }
            subs
        }));
    }
    poll_until(reader, &url, Duration::from_secs(120), |v| {
        v["state"] == "running" && v["samples"].as_array().is_some_and(|s| s.len() >= 2)
    })
    .await;
    victim.kill();
    let killed_at = Instant::now();
    let (_, at_kill) = get_json(reader, &url).await;
    out.samples_at_kill = at_kill["samples"].as_array().map_or(0, Vec::len);
    let after = poll_until(reader, &url, Duration::from_secs(60), |v| v["state"] != "running").await;
    out.recovery_seconds = killed_at.elapsed().as_secs_f64();
    out.state_after = after["state"].as_str().unwrap_or_default().to_string();
    out.samples_after = after["samples"].as_array().map_or(0, Vec::len);
    out.error = after["error"].as_str().unwrap_or_default().to_string();
    if out.state_after != "interrupted" {
        out.failures.push(format!(
            "the killed measurement is {}, not interrupted",
            out.state_after
        ));
    }
    if out.samples_after != out.samples_at_kill || out.samples_at_kill < 2 {
        out.failures.push(format!(
            "the killed measurement had {} samples at the kill and {} after recovery",
            out.samples_at_kill, out.samples_after
        ));
    }
    if !out.error.contains(&format!("booth `{}`", out.victim)) {
        out.failures
            .push(format!("the interruption does not name the dead booth: {}", out.error));
    }
    let mut beside = Vec::new();
    for t in tasks {
        beside.extend(t.await.unwrap());
    }
    out.neighbours = audit_when_settled(reader, &beside, codings, Duration::from_secs(300)).await;
    out.before = audit(reader, earlier, codings).await;
    if !out.neighbours.passed() {
        out.failures
            .push("the other booths' measurements beside the kill did not all complete".into());
    }
    if !out.before.passed() {
        out.failures
            .push("the kill (or its recovery) touched measurements finished before it".into());
    }
    out
}

/// What the worker kill test saw.
#[derive(Debug, Default)]
pub struct WorkerKillOutcome {
    pub render_id: i64,
    pub killed_worker: i64,
    /// The render's final state and the worker that finished it.
    pub state_after: String,
    pub finished_by: Option<i64>,
    /// How many workers claimed the job.
    pub attempts: i64,
    /// From the kill until the render was complete.
    pub seconds_to_complete: f64,
    pub failures: Vec<String>,
}

impl WorkerKillOutcome {
    pub fn to_json(&self) -> Value {
        json!({
            "render_id": self.render_id,
            "killed_worker": self.killed_worker,
            "state_after": self.state_after,
            "finished_by": self.finished_by,
            "attempts": self.attempts,
            "seconds_to_complete": self.seconds_to_complete,
            "failures": self.failures,
        })
    }
}

/// The job of `kind` about `subject` (state, worker, attempts), read from
/// the database directly: the API does not show worker jobs.
async fn worker_job(db: &str, kind: &str, subject: i64) -> Option<(String, Option<i64>, i64)> {
    use sqlx::Connection;
    let mut conn = sqlx::PgConnection::connect(db).await.unwrap();
    sqlx::query_as("SELECT state, worker_id, attempts FROM worker_jobs WHERE kind = $1 AND subject_id = $2")
        .bind(kind)
        .bind(subject)
        .fetch_optional(&mut conn)
        .await
        .unwrap()
}

/// kill -9 of a render worker mid-job: a render of `samples` paths per
/// target is asked of the first booth; once a worker runs it, that worker
/// is killed, and another must finish the render (complete, never
/// interrupted), the job claimed twice. The killed worker is removed from
/// `lab`; at least two workers are needed.
pub async fn kill_worker_test(lab: &mut Lab, samples: u32) -> WorkerKillOutcome {
    assert!(lab.workers.len() >= 2, "the worker kill test needs two workers");
    let booth = lab.daemons[0].addr;
    let (status, r) = post_json(
        booth,
        "/api/scenes/white/renders",
        TOKEN,
        &json!({ "samples": samples }).to_string(),
    )
    .await;
    assert_eq!(status, 202, "{r}");
    let mut out = WorkerKillOutcome {
        render_id: r["render_id"].as_i64().unwrap(),
        ..WorkerKillOutcome::default()
    };
    let url = format!("/api/renders/{}", out.render_id);
    let deadline = Instant::now() + Duration::from_secs(600);
    let holder = loop {
        let job = worker_job(&lab.db, "render", out.render_id).await;
        let (_, row) = get_json(booth, &url).await;
        if let Some((state, Some(worker), _)) = &job {
            if state == "running" && row["state"] == "running" {
                break *worker;
            }
        }
        assert!(
            Instant::now() < deadline,
            "no worker ever ran render {}: {job:?} {row}",
            out.render_id
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    let k = lab
        .workers
        .iter()
        .position(|w| w.id == holder)
        .expect("a worker of this lab");
    let mut victim = lab.workers.remove(k);
    victim.kill();
    out.killed_worker = holder;
    let killed_at = Instant::now();
    let done = poll_until(booth, &url, Duration::from_secs(900), |v| {
        v["state"] != "running" && v["state"] != "queued"
    })
    .await;
    out.seconds_to_complete = killed_at.elapsed().as_secs_f64();
    out.state_after = done["state"].as_str().unwrap_or_default().to_string();
    if let Some((_, worker, attempts)) = worker_job(&lab.db, "render", out.render_id).await {
        out.finished_by = worker;
        out.attempts = attempts;
    }
    if out.state_after != "complete" {
        out.failures
            .push(format!("the render is {}: {}", out.state_after, done["error"]));
    }
    if out.attempts != 2 || out.finished_by == Some(holder) || out.finished_by.is_none() {
        out.failures.push(format!(
            "the job was claimed {} times, last by worker {:?} (killed: {holder})",
            out.attempts, out.finished_by
        ));
    }
    out
}

/// A study asked of the first booth (every coding of `scenes` against the
/// measurements, one seed): its final state, waited for (bounded).
pub async fn run_study(lab: &Lab, scenes: &str, limit: Duration) -> Value {
    let booth = lab.daemons[0].addr;
    let (status, s) = post_json(
        booth,
        "/api/studies",
        TOKEN,
        &json!({ "scenes": scenes, "against": "measurements", "seeds": 1 }).to_string(),
    )
    .await;
    assert_eq!(status, 202, "{s}");
    let url = format!("/api/studies/{}", s["id"].as_i64().unwrap());
    poll_until(booth, &url, limit, |v| {
        v["state"] != "running" && v["state"] != "queued"
    })
    .await
}
