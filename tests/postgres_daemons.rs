//! `serve --db postgres://…`: whole daemons on a real PostgreSQL database
//! (the server `tests/setup.sh` starts). A measurement goes through the API
//! into PostgreSQL with every sample, and a second daemon on the same
//! database starts (no file lock between them) and serves what the first
//! measured.

mod common;

use std::time::Duration;

use common::{get_json, poll_until, post_json, Daemon, TOKEN};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_daemons_share_one_postgres_database_and_see_each_others_measurements() {
    let db = common::fresh_postgres_database().await;
    let a = Daemon::start_on(0.0, &db).await;
    let (status, m) = post_json(a.addr, "/api/measurements", TOKEN, r#"{"samples":3,"note":"booth A"}"#).await;
    assert_eq!(status, 202, "{m}");
    let url = m["url"].as_str().unwrap().to_string();
    let done = poll_until(a.addr, &url, Duration::from_secs(60), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(done["state"], "complete", "{done}");
    assert_eq!(done["samples"].as_array().unwrap().len(), 3);

    let b = Daemon::start_on(0.0, &db).await;
    let (status, page) = get_json(b.addr, "/api/measurements").await;
    assert_eq!(status, 200);
    assert_eq!(page["total"], 1, "{page}");
    assert_eq!(page["items"][0]["note"], "booth A");
    assert_eq!(page["items"][0]["state"], "complete");
    let (_, health) = get_json(b.addr, "/api/health").await;
    assert_eq!(health["status"], "ok", "{health}");
    b.stop().await;
    a.stop().await;
}
