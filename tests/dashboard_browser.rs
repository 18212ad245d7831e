//! The dashboard in a real headless browser (Debian `chromium`, driven by
//! `playwright-core` from npm) against the whole daemon on loopback: open
//! the printed URL, start a measurement, see its progress and the charts,
//! every scene's page, run a study and see it scene by scene, a failed study
//! without report links; no console errors, failed requests or HTTP errors.
//! Screenshots of every page go to `target/screenshots/` (path printed). `tests/setup.sh` installs the browser and
//! the npm package.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{Daemon, TOKEN};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_runs_a_measurement_and_shows_the_study_charts() {
    let browser_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser");
    assert!(
        browser_dir.join("node_modules/playwright-core").exists(),
        "playwright-core is not installed: run tests/setup.sh (it installs chromium and the npm package)"
    );
    // Slow enough that the page sees the progress sample by sample.
    let d = Daemon::start(0.02).await;
    let addr = d.addr;
    // target/screenshots/: an artefact a reviewer can look at.
    let shots = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .map(|t| t.join("screenshots"))
        .unwrap_or_else(|| PathBuf::from("target/screenshots"));
    std::fs::create_dir_all(&shots).unwrap();
    eprintln!("dashboard screenshots: {}", shots.display());
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
    d.stop().await;
    assert!(
        out.status.success(),
        "browser test failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
