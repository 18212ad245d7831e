//! A booth made ready for an experiment through the API, as an operator
//! would: the simulated display calibrated and WHITE's patch measured and
//! compared. Shared by the API tests and the load benchmark.

use std::time::Duration;

use serde_json::{json, Value};

use super::{get_json, poll_until, post_json, Daemon, TOKEN};

/// A measurement with `body`, once complete; its id.
pub async fn measure(d: &Daemon, body: Value) -> i64 {
    let (s, started) = post_json(d.addr, "/api/measurements", TOKEN, &body.to_string()).await;
    assert_eq!(s, 202, "{started}");
    let id = started["id"].as_i64().unwrap();
    let m = poll_until(
        d.addr,
        &format!("/api/measurements/{id}"),
        Duration::from_secs(300),
        |v| !matches!(v["state"].as_str(), Some("queued") | Some("running")),
    )
    .await;
    assert_eq!(m["state"], "complete", "{m}");
    id
}

/// A profile of the simulated display (the 4-level plan) and a compared
/// measurement of WHITE's patch: (profile id, measurement id).
pub async fn calibrated_booth(d: &Daemon) -> (i64, i64) {
    let (s, plan) = get_json(d.addr, "/api/display-profiles/plan?steps=4").await;
    assert_eq!(s, 200, "{plan}");
    let mut patches = Vec::new();
    for p in plan["patches"].as_array().unwrap() {
        let (s, _) = post_json(
            d.addr,
            "/api/mock/display",
            TOKEN,
            &json!({ "drive": p["drive"] }).to_string(),
        )
        .await;
        assert_eq!(s, 204);
        let id = measure(d, json!({ "samples": 2 })).await;
        patches.push(json!({ "drive": p["drive"], "measurement_id": id }));
    }
    let (s, profile) = post_json(
        d.addr,
        "/api/display-profiles",
        TOKEN,
        &json!({ "name": "simulated CRT", "patches": patches }).to_string(),
    )
    .await;
    assert_eq!(s, 201, "{profile}");
    let m = compared_measurement(d, "white", "patch").await;
    (profile["id"].as_i64().unwrap(), m)
}

/// A measurement of a scene's target, once its comparisons with the
/// daemon's seven codings are computed.
pub async fn compared_measurement(d: &Daemon, scene: &str, target: &str) -> i64 {
    let m = measure(d, json!({ "scene": scene, "target": target, "samples": 3 })).await;
    // Its comparisons are computed after it completes.
    poll_until(
        d.addr,
        &format!("/api/measurements/{m}/comparisons"),
        Duration::from_secs(900),
        |v| v.as_array().is_some_and(|a| a.len() >= 7),
    )
    .await;
    m
}
