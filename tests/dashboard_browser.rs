//! The dashboard in a real headless browser (Debian `chromium`, driven by
//! `playwright-core` from npm) against the whole daemon on loopback: open
//! the printed URL, start a measurement, see its progress and the charts, no
//! console errors. `tests/setup.sh` installs the browser and the npm package.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use lightbooth::daemon::{self, DaemonOptions};
use lightbooth::instrument::Pr650Settings;

const TOKEN: &str = "browser-token-0123456789abcdef";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_runs_a_measurement_and_shows_the_study_charts() {
    let browser_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser");
    assert!(
        browser_dir.join("node_modules/playwright-core").exists(),
        "playwright-core is not installed: run tests/setup.sh (it installs chromium and the npm package)"
    );
    let dir = tempfile::tempdir().unwrap();
    let token_file = dir.path().join("token");
    std::fs::write(&token_file, TOKEN).unwrap();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let options = DaemonOptions {
        bind: addr,
        db_url: format!("sqlite://{}", dir.path().join("lab.sqlite").display()),
        mock: true,
        // Slow enough that the page sees the progress sample by sample.
        mock_speed: 0.02,
        mock_faults: Vec::new(),
        instrument: Pr650Settings::default(),
        scenes_dir: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes"),
        cache_dir: PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("converged-cache"),
        token_file: Some(token_file),
        default_token_file: dir.path().join("unused"),
        codings: ["rgb", "srgb", "nstep3", "nstep9", "nstep27", "nstep81", "spectral"]
            .map(String::from)
            .to_vec(),
        render_samples: 2048,
    };
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(daemon::run(listener, options, async move {
        let _ = stopped.await;
    }));
    common::poll_until(addr, "/api/health", Duration::from_secs(30), |v| {
        v["instrument"]["state"] == "idle"
    })
    .await;

    let shots = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("dashboard-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let out = tokio::task::spawn_blocking(move || {
        Command::new("node")
            .current_dir(&browser_dir)
            .args([
                "dashboard.mjs",
                &format!("http://{addr}"),
                TOKEN,
                shots.to_str().unwrap(),
            ])
            .output()
            .expect("run node (install Node.js 20+)")
    })
    .await
    .unwrap();
    let _ = stop.send(());
    tokio::time::timeout(Duration::from_secs(30), server)
        .await
        .unwrap()
        .unwrap()
        .unwrap();
    assert!(
        out.status.success(),
        "browser test failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
