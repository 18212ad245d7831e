//! The dashboard's image viewer in a real headless browser (Debian
//! `chromium` driven by `playwright-core`, see `tests/setup.sh`) against the
//! whole daemon on loopback: CYLINDER's spectral image with its caption, a
//! pixel probe's spectrum chart, the ΔE00 map against rgb with its scale
//! bar; no console errors, failed requests or HTTP errors. Screenshots go to
//! `target/screenshots/` (`viewer-*.png`).

use crate::common;

use std::time::Duration;

use common::{poll_until, post_json, Daemon, TOKEN};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_image_viewer_shows_an_image_probes_a_pixel_and_maps_delta_e() {
    let d = Daemon::start(0.0).await;
    // The default render (the one the CIELAB white of the ΔE map reuses).
    let (status, v) = post_json(d.addr, "/api/scenes/cylinder/renders", TOKEN, "{}").await;
    assert_eq!(status, 202, "{v}");
    let id = v["render_id"].as_i64().unwrap();
    let row = poll_until(d.addr, &format!("/api/renders/{id}"), Duration::from_secs(600), |r| {
        r["state"] != "queued" && r["state"] != "running"
    })
    .await;
    assert_eq!(row["state"], "complete", "{row}");
    let shots = common::screenshot_dir();
    eprintln!("image viewer screenshots: {}", shots.display());
    let result = common::run_browser_script("viewer.mjs", d.addr, shots).await;
    d.stop().await;
    if let Err(e) = result {
        panic!("{e}");
    }
}
