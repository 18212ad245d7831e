//! The display calibration page in a real headless browser against the whole
//! daemon with `--mock` (`tests/browser/calibrate.mjs`): start, the patches
//! shown full-screen with progress, the profile page with its charts.
//! Screenshots go to `target/screenshots/`. `tests/setup.sh` installs the
//! browser and the npm package.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{Daemon, TOKEN};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_calibration_page_calibrates_the_simulated_display_and_shows_the_profile() {
    let browser_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser");
    assert!(
        browser_dir.join("node_modules/playwright-core").exists(),
        "playwright-core is not installed: run tests/setup.sh (it installs chromium and the npm package)"
    );
    let d = Daemon::start(0.0).await;
    let addr = d.addr;
    let shots = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .map(|t| t.join("screenshots"))
        .unwrap_or_else(|| PathBuf::from("target/screenshots"));
    std::fs::create_dir_all(&shots).unwrap();
    eprintln!("calibration screenshots: {}", shots.display());
    let out = tokio::task::spawn_blocking(move || {
        Command::new("node")
            .current_dir(&browser_dir)
            .args([
                "calibrate.mjs",
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
