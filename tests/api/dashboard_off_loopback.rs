//! The dashboard in a real headless browser against a daemon bound off
//! loopback (`0.0.0.0`), where reads need the token too: the page opened
//! with the printed `#token=…` URL must follow the event stream, fetch,
//! measure and show its charts without one request refused. `tests/setup.sh`
//! installs the browser and the npm package.

use crate::common;

use common::{request, Daemon};

/// Regression: bound off loopback, the dashboard's GETs, chart images and
/// event stream sent no token, so every read got 401 and the page stayed empty.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_works_when_the_daemon_is_bound_off_loopback() {
    let d = Daemon::start_bound(0.02, "0.0.0.0:0").await;
    let addr = d.addr;
    // Off loopback, a read without the token is refused: the page must send it.
    assert_eq!(request(addr, "GET", "/api/scenes", None, None).await.0, 401);
    let shots = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("dashboard-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let result = common::run_browser_script("off_loopback.mjs", addr, shots).await;
    d.stop().await;
    if let Err(e) = result {
        panic!("{e}");
    }
}
