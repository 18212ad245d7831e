//! The daemon as a real process on a real SQLite file: killed with SIGKILL
//! in the middle of a measurement, a render or a study, then restarted on
//! the same file — the measurement is marked interrupted with the samples it
//! had, renders and studies are marked interrupted (never `running` forever)
//! and can be retried, and no completed work is lost. Also: a panic in the
//! renderer fails one job and never the daemon, and a second daemon on the
//! same file is refused.

use crate::common;

use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use common::{get_json, poll_until, post_json};

const TOKEN: &str = "crash-token-0123456789abcdef";

/// Starts `lightbooth serve --mock` in `dir`; returns the child and its address.
fn start(dir: &Path, speed: &str) -> (Child, SocketAddr) {
    start_with_env(dir, speed, &[])
}

/// The `serve --mock` command on `dir`'s database and token.
fn serve_command(dir: &Path, speed: &str) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_lightbooth"));
    command
        .current_dir(dir)
        .args([
            "serve",
            "--mock",
            "--mock-speed",
            speed,
            "--bind",
            "127.0.0.1:0",
            "--config",
            "lightbooth.toml",
        ])
        .args(["--db", &format!("sqlite://{}", dir.join("lab.sqlite").display())])
        .args(["--token-file", dir.join("token").to_str().unwrap()]);
    command
}

/// [`start`] with extra environment variables for the daemon.
fn start_with_env(dir: &Path, speed: &str, env: &[(&str, &str)]) -> (Child, SocketAddr) {
    let mut child = serve_command(dir, speed)
        .envs(env.iter().copied())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start the daemon");
    let stdout = child.stdout.take().unwrap();
    let mut lines = BufReader::new(stdout).lines();
    let addr = loop {
        let line = lines.next().expect("the daemon printed its address").unwrap();
        if let Some(rest) = line.strip_prefix("lightbooth listening on http://") {
            break rest.trim_end_matches('/').parse().unwrap();
        }
    };
    // Keep draining stdout so the daemon never blocks on a full pipe.
    std::thread::spawn(move || for _ in lines {});
    (child, addr)
}

/// A folder with the token and a config naming the scenes and the shared cache.
fn lab_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("token"), TOKEN).unwrap();
    let manifest = env!("CARGO_MANIFEST_DIR");
    std::fs::write(
        dir.path().join("lightbooth.toml"),
        format!(
            "scenes_dir = \"{manifest}/scenes\"\ncache_dir = \"{}\"\n",
            Path::new(env!("CARGO_TARGET_TMPDIR")).join("converged-cache").display()
        ),
    )
    .unwrap();
    dir
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigkill_mid_measurement_marks_it_interrupted_and_loses_nothing_completed() {
    let dir = lab_dir();

    let (mut child, addr) = start(dir.path(), "0.1");
    poll_until(addr, "/api/health", Duration::from_secs(30), |v| {
        v["instrument"]["state"] == "idle"
    })
    .await;
    let (status, done) = post_json(addr, "/api/measurements", TOKEN, r#"{"samples":2}"#).await;
    assert_eq!(status, 202);
    let done_url = done["url"].as_str().unwrap().to_string();
    poll_until(addr, &done_url, Duration::from_secs(60), |v| v["state"] == "complete").await;

    let (_, running) = post_json(addr, "/api/measurements", TOKEN, r#"{"samples":5}"#).await;
    let running_url = running["url"].as_str().unwrap().to_string();
    let before = poll_until(addr, &running_url, Duration::from_secs(60), |v| {
        v["samples_taken"].as_i64() >= Some(1)
    })
    .await;
    assert_eq!(before["state"], "running");
    child.kill().unwrap(); // SIGKILL: no chance to clean up
    child.wait().unwrap();

    let (mut child, addr) = start(dir.path(), "0");
    let (status, m) = get_json(addr, &running_url).await;
    assert_eq!(status, 200);
    assert_eq!(m["state"], "interrupted", "{m}");
    let kept = m["samples"].as_array().unwrap().len();
    assert!(
        (1..5).contains(&kept),
        "samples written before the kill are kept: {kept}"
    );
    assert!(m["radiance"].is_null());
    let (_, d) = get_json(addr, &done_url).await;
    assert_eq!(d["state"], "complete");
    assert_eq!(d["samples"].as_array().unwrap().len(), 2);
    assert_eq!(d["radiance"].as_array().unwrap().len(), 101);
    child.kill().unwrap();
    child.wait().unwrap();
}

/// Kills the daemon at a pseudo-random moment within `window` (the seed is
/// printed, so a failure can be replayed with the same moment).
async fn kill_within(child: &mut Child, window: Duration, seed: u64) {
    let ms = splitmix(seed) % window.as_millis().max(1) as u64;
    eprintln!("killing after {ms} ms (seed {seed})");
    tokio::time::sleep(Duration::from_millis(ms)).await;
    child.kill().unwrap(); // SIGKILL: no chance to clean up
    child.wait().unwrap();
}

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

fn seed() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn renders_and_studies_left_running_by_a_crash_are_interrupted_at_start_up_and_can_be_retried() {
    let dir = lab_dir();
    for round in 0..2u64 {
        let (mut child, addr) = start(dir.path(), "0.05");
        poll_until(addr, "/api/health", Duration::from_secs(30), |v| {
            v["instrument"]["state"] == "idle"
        })
        .await;
        // Work of every kind at once: a measurement, a long render, a study
        // (queued behind it) and a second render waiting.
        let (_, m) = post_json(addr, "/api/measurements", TOKEN, r#"{"samples":5}"#).await;
        assert!(m["id"].is_i64(), "{m}");
        let heavy = r#"{"samples":4194304,"codings":"rgb,spectral"}"#;
        let (status, r) = post_json(addr, "/api/scenes/cylinder/renders", TOKEN, heavy).await;
        assert_eq!(status, 202, "{r}");
        let (status, s) = post_json(
            addr,
            "/api/studies",
            TOKEN,
            r#"{"scenes":"white","seeds":1,"against":"reference"}"#,
        )
        .await;
        assert_eq!(status, 202, "{s}");
        let (status, _) = post_json(addr, "/api/scenes/white/renders", TOKEN, r#"{"codings":"rgb"}"#).await;
        assert_eq!(status, 202);
        let render_url = r["url"].as_str().unwrap().to_string();
        poll_until(addr, &render_url, Duration::from_secs(30), |v| v["state"] == "running").await;
        kill_within(&mut child, Duration::from_secs(2), seed() ^ round).await;

        let (mut child, addr) = start(dir.path(), "0");
        let (_, renders) = get_json(addr, "/api/scenes/cylinder/renders").await;
        let (_, whites) = get_json(addr, "/api/scenes/white/renders").await;
        let (_, studies) = get_json(addr, "/api/studies").await;
        let (_, running) = get_json(addr, "/api/measurements?state=running").await;
        let (_, queued) = get_json(addr, "/api/measurements?state=queued").await;
        assert_eq!(running["total"], 0, "{running}");
        assert_eq!(queued["total"], 0, "{queued}");
        let all: Vec<&serde_json::Value> = renders
            .as_array()
            .unwrap()
            .iter()
            .chain(whites.as_array().unwrap())
            .chain(studies.as_array().unwrap())
            .collect();
        for job in &all {
            assert!(
                job["state"] != "running" && job["state"] != "queued",
                "nothing is left running or queued after a crash: {job}"
            );
        }
        let heavy_row = all
            .iter()
            .find(|j| j["id"] == r["render_id"] && j["scene"] == "cylinder")
            .unwrap();
        assert_eq!(heavy_row["state"], "interrupted", "{heavy_row}");
        assert!(heavy_row["error"].as_str().unwrap().contains("retry"), "{heavy_row}");
        let study_row = studies.as_array().unwrap().iter().find(|j| j["id"] == s["id"]).unwrap();
        assert_eq!(study_row["state"], "interrupted", "{study_row}");

        if round == 0 {
            // A retried study is a new job with the same request, and it runs.
            let (status, again) = post_json(addr, &format!("/api/studies/{}/retry", s["id"]), TOKEN, "{}").await;
            assert_eq!(status, 202, "{again}");
            assert_ne!(again["id"], s["id"]);
            let url = again["url"].as_str().unwrap().to_string();
            let (_, row) = get_json(addr, &url).await;
            assert_eq!(row["request"]["scenes"], "white");
            assert!(row["state"] == "queued" || row["state"] == "running", "{row}");
            // A retried render too.
            let (status, again) = post_json(addr, &format!("/api/renders/{}/retry", r["render_id"]), TOKEN, "{}").await;
            assert_eq!(status, 202, "{again}");
            let (_, row) = get_json(addr, again["url"].as_str().unwrap()).await;
            assert_eq!(row["settings"]["samples"], 4194304, "{row}");
        }
        child.kill().unwrap();
        child.wait().unwrap();
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_panic_in_a_render_fails_that_job_and_the_daemon_and_instrument_survive() {
    // The test hook: renders, studies and converged spectra of `red` panic
    // on a rayon worker (LIGHTBOOTH_TEST_PANIC_SCENE, read by the daemon).
    let dir = lab_dir();
    let (mut child, addr) = start_with_env(dir.path(), "0", &[("LIGHTBOOTH_TEST_PANIC_SCENE", "red")]);
    poll_until(addr, "/api/health", Duration::from_secs(30), |v| {
        v["instrument"]["state"] == "idle"
    })
    .await;
    let (status, r) = post_json(addr, "/api/scenes/red/renders", TOKEN, r#"{"codings":"rgb"}"#).await;
    assert_eq!(status, 202, "{r}");
    let failed = poll_until(addr, r["url"].as_str().unwrap(), Duration::from_secs(60), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(failed["state"], "failed", "{failed}");
    assert!(failed["error"].as_str().unwrap().contains("panicked"), "{failed}");
    let (status, s) = post_json(
        addr,
        "/api/studies",
        TOKEN,
        r#"{"scenes":"red","seeds":1,"against":"reference"}"#,
    )
    .await;
    assert_eq!(status, 202, "{s}");
    let failed = poll_until(addr, s["url"].as_str().unwrap(), Duration::from_secs(60), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(failed["state"], "failed", "{failed}");
    assert!(failed["error"].as_str().unwrap().contains("panicked"), "{failed}");

    // The same panic on the instrument thread (aiming the simulated PR-650 at red).
    let (status, m) = post_json(
        addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene":"red","target":"patch","samples":2}"#,
    )
    .await;
    assert_eq!(status, 202, "{m}");
    let m = poll_until(addr, m["url"].as_str().unwrap(), Duration::from_secs(60), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(m["state"], "failed", "{m}");
    assert!(m["error"].as_str().unwrap().contains("panicked"), "{m}");
    // Health tells the truth while the task restarts, then it is back.
    let h = poll_until(addr, "/api/health", Duration::from_secs(30), |v| {
        v["status"] == "degraded" || v["instrument"]["state"] == "idle"
    })
    .await;
    if h["status"] == "degraded" {
        assert_eq!(h["instrument_task"], "restarting", "{h}");
    }
    poll_until(addr, "/api/health", Duration::from_secs(30), |v| {
        v["status"] == "ok" && v["instrument"]["state"] == "idle"
    })
    .await;
    // The daemon is alive and the next measurement and render work.
    let (status, m) = post_json(addr, "/api/measurements", TOKEN, r#"{"samples":2}"#).await;
    assert_eq!(status, 202, "{m}");
    poll_until(addr, m["url"].as_str().unwrap(), Duration::from_secs(60), |v| {
        v["state"] == "complete"
    })
    .await;
    let (status, r) = post_json(addr, "/api/scenes/white/renders", TOKEN, r#"{"codings":"rgb"}"#).await;
    assert_eq!(status, 202, "{r}");
    poll_until(addr, r["url"].as_str().unwrap(), Duration::from_secs(120), |v| {
        v["state"] == "complete"
    })
    .await;
    assert!(child.try_wait().unwrap().is_none(), "the daemon is still running");
    child.kill().unwrap();
    child.wait().unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_second_daemon_on_the_same_database_is_refused_naming_the_file_and_pid() {
    let dir = lab_dir();
    let (mut first, addr) = start(dir.path(), "0");
    poll_until(addr, "/api/health", Duration::from_secs(30), |v| {
        v["instrument"]["state"] == "idle"
    })
    .await;
    let (_, m) = post_json(addr, "/api/measurements", TOKEN, r#"{"samples":2}"#).await;
    let url = m["url"].as_str().unwrap().to_string();
    let second = serve_command(dir.path(), "0")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .expect("run a second daemon");
    assert!(!second.status.success(), "the second daemon must not start");
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(stderr.contains("lab.sqlite"), "{stderr}");
    assert!(stderr.contains(&format!("pid {}", first.id())), "{stderr}");
    // The first one's work was left alone.
    let done = poll_until(addr, &url, Duration::from_secs(60), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(done["state"], "complete", "{done}");
    first.kill().unwrap();
    first.wait().unwrap();
}
