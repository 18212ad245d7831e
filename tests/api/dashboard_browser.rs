//! The dashboard in a real headless browser (Debian `chromium`, driven by
//! `playwright-core` from npm) against the whole daemon on loopback: open
//! the printed URL, start a measurement, see its progress and the charts,
//! every scene's page, run a study and see it scene by scene, a failed study
//! without report links; no console errors, failed requests or HTTP errors.
//! Screenshots of every page go to `target/screenshots/` (path printed). `tests/setup.sh` installs the browser and
//! the npm package.

use crate::common;

use common::Daemon;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_runs_a_measurement_and_shows_the_study_charts() {
    // Slow enough that the page sees the progress sample by sample.
    let d = Daemon::start(0.02).await;
    let addr = d.addr;
    let shots = common::screenshot_dir();
    eprintln!("dashboard screenshots: {}", shots.display());
    let result = common::run_browser_script("dashboard.mjs", addr, shots).await;
    d.stop().await;
    if let Err(e) = result {
        panic!("{e}");
    }
}
