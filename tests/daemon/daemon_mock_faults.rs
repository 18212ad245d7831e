//! Faults injected into the daemon's simulated PR-650 through the API
//! (`POST /api/mock/faults`, the same `KIND[@DELAY][:RATE]` syntax as
//! `serve --mock-fault`), seen from outside: over HTTP on loopback.

use crate::common;

use std::time::{Duration, Instant};

use common::{events, post_json, wait_for, Daemon, TOKEN};

/// Takes a one-sample measurement; returns its final state and the time
/// from just before it was asked for to its finish event: an upper bound of
/// its run that a delay inside it cannot escape. (Timed from the start
/// event as received, a 1.5 s delay once measured 1.499 s: the start event
/// reached the test later than the finish event did.)
async fn timed_measurement(d: &Daemon) -> (String, Duration) {
    let mut ev = events(d.addr).await;
    let started = Instant::now();
    let (status, accepted) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples":1}"#).await;
    assert_eq!(status, 202, "{accepted}");
    let id = accepted["id"].as_i64().unwrap();
    wait_for(&mut ev, "the start", Duration::from_secs(30), |name, v| {
        name == "measurement_started" && v["measurement_id"] == id
    })
    .await;
    let finished = wait_for(&mut ev, "the end", Duration::from_secs(30), |name, v| {
        name == "measurement_finished" && v["measurement_id"] == id
    })
    .await;
    (finished["state"].as_str().unwrap().to_string(), started.elapsed())
}

/// Regression: the `slow` fault did nothing in the daemon (its delay was 0
/// and could not be set). `slow@1500ms:once` delays the next `D5` reply by
/// 1.5 s, inside the test daemon's 2 s command timeout, so the measurement
/// still completes, 1.5 s later.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_slow_fault_delays_the_reply_by_the_delay_it_names() {
    let d = Daemon::start(0.0).await;
    let (status, v) = post_json(d.addr, "/api/mock/faults", TOKEN, r#"{"faults":"slow@1500ms:once"}"#).await;
    assert_eq!(status, 204, "{v}");
    let (state, slowed) = timed_measurement(&d).await;
    assert_eq!(state, "complete");
    assert!(
        slowed >= Duration::from_millis(1500),
        "a reply slowed by 1.5 s came after {slowed:?}"
    );
    // A delay without its unit is refused with the syntax.
    let (status, v) = post_json(d.addr, "/api/mock/faults", TOKEN, r#"{"faults":"slow@1500"}"#).await;
    assert_eq!(status, 400);
    assert!(v["error"]["message"].as_str().unwrap().contains("with its unit"), "{v}");
    d.stop().await;
}
