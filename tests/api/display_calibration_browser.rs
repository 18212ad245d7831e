//! The display calibration page in a real headless browser against the whole
//! daemon with `--mock` (`tests/browser/calibrate.mjs`): start, the patches
//! shown full-screen with progress, the profile page with its charts.
//! Screenshots go to `target/screenshots/`. `tests/setup.sh` installs the
//! browser and the npm package.

use crate::common;

use common::Daemon;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_calibration_page_calibrates_the_simulated_display_and_shows_the_profile() {
    let d = Daemon::start(0.0).await;
    let addr = d.addr;
    let shots = common::screenshot_dir();
    eprintln!("calibration screenshots: {}", shots.display());
    let result = common::run_browser_script("calibrate.mjs", addr, shots).await;
    d.stop().await;
    if let Err(e) = result {
        panic!("{e}");
    }
}
