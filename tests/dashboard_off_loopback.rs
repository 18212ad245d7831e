//! The dashboard in a real headless browser against a daemon bound off
//! loopback (`0.0.0.0`), where reads need the token too: the page opened
//! with the printed `#token=…` URL must follow the event stream, fetch,
//! measure and show its charts without one request refused. `tests/setup.sh`
//! installs the browser and the npm package.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{request, Daemon, TOKEN};

/// Regression: bound off loopback, the dashboard's GETs, chart images and
/// event stream sent no token, so every read got 401 and the page stayed empty.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_works_when_the_daemon_is_bound_off_loopback() {
    let browser_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser");
    assert!(
        browser_dir.join("node_modules/playwright-core").exists(),
        "playwright-core is not installed: run tests/setup.sh (it installs chromium and the npm package)"
    );
    let d = Daemon::start_bound(0.02, "0.0.0.0:0").await;
    let addr = d.addr;
    // Off loopback, a read without the token is refused: the page must send it.
    assert_eq!(request(addr, "GET", "/api/scenes", None, None).await.0, 401);
    let shots = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("dashboard-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let out = tokio::task::spawn_blocking(move || {
        Command::new("node")
            .current_dir(&browser_dir)
            .args([
                "off_loopback.mjs",
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
