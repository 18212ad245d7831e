//! The MATLAB examples' GNU Octave versions (`web/matlab/*_octave.m`) run
//! as written by GNU Octave's own `octave-cli` (installed by
//! `tests/setup.sh`) against a real daemon on loopback with the simulated
//! PR-650 and display: the same requests a MATLAB script sends (webread,
//! webwrite with the token, a form-encoded and a JSON body, the MAT files
//! read by Octave's `load`). What each prints is checked against the
//! daemon's own JSON. MATLAB itself is not available to the suite; its
//! versions differ only in `struct2table`/`websave` (stated in each file).

use crate::common;
use crate::experiment::calibrated_booth;

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use common::{get_json, Daemon, TOKEN};

/// Runs `web/matlab/{name}` in `dir` with the daemon's address and token in
/// the environment; returns what it printed. Fails on a non-zero exit or an
/// `error:` line (except the line Octave 7 prints at every exit,
/// "ignoring const execution_exception& while preparing to exit").
fn octave(dir: &Path, addr: std::net::SocketAddr, name: &str) -> String {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("web/matlab").join(name);
    let out = Command::new("octave-cli")
        .args(["--no-gui", "--norc", "--quiet"])
        .arg(&script)
        .current_dir(dir)
        .env("LIGHTBOOTH_URL", format!("http://{addr}"))
        .env("LIGHTBOOTH_TOKEN", TOKEN)
        .output()
        .expect("octave-cli runs (tests/setup.sh installs GNU Octave)");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    let errors: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("error:") && !l.contains("while preparing to exit"))
        .collect();
    assert!(
        out.status.success() && errors.is_empty(),
        "{name}: {}\n{stdout}\n{stderr}",
        out.status
    );
    stdout
}

/// The number printed after `prefix` on the line that starts with it.
fn number_after(text: &str, prefix: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no line starting {prefix:?} in:\n{text}"));
    line[prefix.len()..]
        .split_whitespace()
        .next()
        .and_then(|w| w.trim_end_matches([',', ':']).parse().ok())
        .unwrap_or_else(|| panic!("no number after {prefix:?}: {line}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_octave_versions_of_the_matlab_examples_run_against_the_daemon() {
    let d = Daemon::start(0.0).await;
    let (_profile, measurement) = calibrated_booth(&d).await;
    let dir = tempfile::tempdir().unwrap();
    let addr = d.addr;
    let run = |name: &'static str| {
        let dir = dir.path().to_path_buf();
        tokio::task::spawn_blocking(move || octave(&dir, addr, name))
    };

    let listed = run("list_measurements_octave.m").await.unwrap();
    assert!(listed.contains("0 complete measurements of the cylinder"), "{listed}");
    assert!(listed.contains("1 booth(s)"), "{listed}");

    let polled = run("measure_and_poll_octave.m").await.unwrap();
    let id = number_after(&polled, "measurement ") as i64;
    let (s, m) = get_json(d.addr, &format!("/api/measurements/{id}")).await;
    assert_eq!(s, 200, "{m}");
    assert_eq!(m["state"], "complete", "{m}");
    let y = number_after(&polled, "state complete: Y = ");
    assert!((y - m["Y"].as_f64().unwrap()).abs() < 1e-3, "{y} vs {m}");
    assert!(polled.contains("101 wavelengths, 380-780 nm"), "{polled}");

    let (s, c) = get_json(d.addr, "/api/scenes/white/comparisons").await;
    assert_eq!(s, 200, "{c}");
    let fetched = run("fetch_comparison_octave.m").await.unwrap();
    for coding in c["codings"].as_array().expect("codings") {
        let name = coding["coding"].as_str().unwrap();
        let printed = number_after(&fetched, &format!("{name:<10} rms_rel = "));
        assert!(
            (printed - coding["rms_rel"].as_f64().unwrap()).abs() < 1e-4,
            "{name}: {printed} vs {coding}"
        );
    }
    let rows = c["rows"].as_array().expect("rows").len();
    assert!(rows > 0, "WHITE's patch {measurement} was compared: {c}");
    assert!(
        fetched.contains(&format!("{rows} rows in comparisons_white.mat")),
        "{fetched}"
    );

    // The script sets up its experiment on the newest complete measurement
    // of WHITE, the one measure_and_poll took: once it is compared.
    common::poll_until(
        d.addr,
        &format!("/api/measurements/{id}/comparisons"),
        Duration::from_secs(120),
        |v| v.as_array().is_some_and(|rows| !rows.is_empty()),
    )
    .await;
    let odd = run("oddity_experiment_octave.m").await.unwrap();
    let experiment = number_after(&odd, "experiment ") as i64;
    let (s, e) = get_json(d.addr, &format!("/api/experiments/{experiment}")).await;
    assert_eq!(s, 200, "the script's experiment exists: {e}");
    assert!(odd.contains("not verified yet"), "{odd}");
    assert!(odd.contains("analysis.mat: "), "{odd}");
    d.stop().await;
}
