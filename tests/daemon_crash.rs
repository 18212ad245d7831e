//! The daemon killed with SIGKILL in the middle of a measurement, then
//! restarted on the same SQLite file: the measurement is marked interrupted
//! with the samples it had, and no completed measurement is lost.

mod common;

use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use common::{get_json, poll_until, post_json};

const TOKEN: &str = "crash-token-0123456789abcdef";

/// Starts `lightbooth serve --mock` in `dir`; returns the child and its address.
fn start(dir: &Path, speed: &str) -> (Child, SocketAddr) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
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
        .args(["--token-file", dir.join("token").to_str().unwrap()])
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

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigkill_mid_measurement_marks_it_interrupted_and_loses_nothing_completed() {
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
