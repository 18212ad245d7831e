//! The dashboard's "measure a material" flow in a real headless browser
//! (`tests/browser/material.mjs`) against the whole daemon on loopback with
//! the simulated PR-650: measure the white standard, then the ColorChecker
//! tile, save the reflectance, see its chart and flags, download its scene
//! CSV. The screenshot goes to `target/screenshots/material.png`.

use crate::common;

use common::Daemon;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_measures_a_material_and_shows_its_reflectance() {
    let d = Daemon::start(0.0).await;
    let addr = d.addr;
    let shots = common::screenshot_dir();
    eprintln!("dashboard screenshots: {}", shots.display());
    let result = common::run_browser_script("material.mjs", addr, shots).await;
    d.stop().await;
    if let Err(e) = result {
        panic!("{e}");
    }
}
