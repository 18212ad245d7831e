//! Issue 32's details of the pages, in headless Chromium against the whole
//! daemon with `--mock`:
//!
//! - `tests/browser/page_details.mjs`: the Calibrate and Experiment pages
//!   had no instrument badge; the Calibrate error notice was white on pink.
//! - `tests/browser/measurement_views.mjs`: Live and a measurement's page
//!   showed only Y, x, y, not the comparison with every colour coding the
//!   README promises; the camera view's cd/m² scale stopped near 2 for a
//!   patch of over 30 cd/m².
//!
//! Screenshots go to `target/screenshots/`.

use crate::common;

use common::Daemon;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn calibrate_and_experiment_pages_show_the_instrument_badge_and_a_readable_error_notice() {
    let d = Daemon::start(0.0).await;
    let result = common::run_browser_script("page_details.mjs", d.addr, common::screenshot_dir()).await;
    d.stop().await;
    if let Err(e) = result {
        panic!("{e}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn live_and_a_measurements_page_show_its_comparison_and_the_camera_scale_reaches_the_patch() {
    let d = Daemon::start(0.0).await;
    let result = common::run_browser_script("measurement_views.mjs", d.addr, common::screenshot_dir()).await;
    d.stop().await;
    if let Err(e) = result {
        panic!("{e}");
    }
}
