//! The daemon's default log (no `LIGHTBOOTH_LOG`) says what went over the
//! wire, whichever instrument it drives: every command and reply at debug,
//! named after the model, and the simulator names the model it simulates.

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The bug: a PR-655/670 daemon logged none of its wire commands by default
/// (the default filter enabled debug for the PR-650's driver only), and its
/// simulator logged "simulated PR-650 powered on".
#[test]
fn a_pr670_daemon_logged_no_wire_commands_and_its_simulator_called_itself_a_pr650() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("serve.log");
    let token = dir.path().join("token");
    std::fs::write(&token, "test-token-0123456789abcdef").unwrap();
    let db = format!("sqlite://{}", dir.path().join("lab.sqlite").display());
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .current_dir(&root)
        .args([
            "serve",
            "--mock",
            "--mock-speed",
            "0",
            "--instrument",
            "instruments/pr670.toml",
        ])
        .args(["--bind", "127.0.0.1:0", "--db", &db])
        .arg("--token-file")
        .arg(&token)
        .env_remove("LIGHTBOOTH_LOG")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::from(std::fs::File::create(&log).unwrap()))
        .spawn()
        .expect("run lightbooth serve");
    let started = Instant::now();
    let text = loop {
        let text = std::fs::read_to_string(&log).unwrap_or_default();
        if text.contains("instrument ready") {
            break text;
        }
        if started.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("the daemon's instrument never got ready; its log:\n{text}");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let _ = child.kill();
    let _ = child.wait();
    assert!(text.contains("simulated PR-670 powered on"), "{text}");
    assert!(!text.contains("simulated PR-650"), "{text}");
    // The model query and its reply, as the PR-650's driver logs its own.
    // (The log may be coloured: the field is `command`, its value `D111`.)
    assert!(
        text.lines().any(|l| l.contains("→ PR-670") && l.contains("D111")),
        "{text}"
    );
    assert!(text.contains("← PR-670"), "{text}");
}
