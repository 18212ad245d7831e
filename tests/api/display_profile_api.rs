//! The display calibration through the real daemon with `--mock`: the plan,
//! each colour shown on the simulated display (`POST /api/mock/display`) and
//! measured by the simulated PR-650 on its pty, the profile fitted and
//! stored with its measurement ids, its charts, and bad requests refused
//! with the field named. Truth: the simulated display's own primaries and γ.

use crate::common;

use std::time::Duration;

use common::{get_json, poll_until, post_json, request, Daemon, TOKEN};
use lightbooth::colorimetry::Observer;
use lightbooth::display::SimulatedDisplay;
use serde_json::{json, Value};

async fn measure_shown(d: &Daemon, drive: &Value) -> i64 {
    let (s, _) = post_json(
        d.addr,
        "/api/mock/display",
        TOKEN,
        &json!({ "drive": drive }).to_string(),
    )
    .await;
    assert_eq!(s, 204);
    let (s, started) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples": 3}"#).await;
    assert_eq!(s, 202, "{started}");
    let id = started["id"].as_i64().unwrap();
    let m = poll_until(
        d.addr,
        &format!("/api/measurements/{id}"),
        Duration::from_secs(60),
        |v| !matches!(v["state"].as_str(), Some("queued") | Some("running")),
    )
    .await;
    assert_eq!(m["state"], "complete", "{m}");
    id
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn calibrating_the_simulated_display_through_the_daemon_recovers_it() {
    let d = Daemon::start(0.0).await;
    let (s, plan) = get_json(d.addr, "/api/display-profiles/plan?steps=8").await;
    assert_eq!(s, 200, "{plan}");
    let mut patches = Vec::new();
    for p in plan["patches"].as_array().unwrap() {
        let id = measure_shown(&d, &p["drive"]).await;
        patches.push(json!({ "drive": p["drive"], "measurement_id": id }));
    }
    let body = json!({ "name": "simulated CRT", "patches": patches }).to_string();
    let (s, row) = post_json(d.addr, "/api/display-profiles", TOKEN, &body).await;
    assert_eq!(s, 201, "{row}");
    let id = row["id"].as_i64().unwrap();

    let (s, stored) = get_json(d.addr, &format!("/api/display-profiles/{id}")).await;
    assert_eq!(s, 200);
    let profile: lightbooth::display::DisplayProfile = serde_json::from_value(stored["profile"].clone()).unwrap();
    assert_eq!(
        profile.measurement_ids.len(),
        patches.len(),
        "provenance: every measurement id"
    );
    let display = SimulatedDisplay::crt().unwrap();
    let truth = display.primary_chromaticities(Observer::JuddVos).unwrap();
    let fitted = profile.primary_chromaticities().unwrap();
    for c in 0..3 {
        let dxy = (fitted[c][0] - truth[c][0]).hypot(fitted[c][1] - truth[c][1]);
        assert!(dxy < 0.002, "primary {c}: Δxy {dxy}");
        let g = profile.transfer[c].gamma / display.gammas()[c];
        assert!((g - 1.0).abs() < 0.01, "channel {c}: γ ratio {g}");
    }
    let (s, list) = get_json(d.addr, "/api/display-profiles").await;
    assert_eq!((s, list[0]["id"].as_i64()), (200, Some(id)));
    for chart in ["primaries.svg", "transfer.svg", "additivity.svg"] {
        let (s, body) = request(
            d.addr,
            "GET",
            &format!("/api/display-profiles/{id}/{chart}"),
            None,
            None,
        )
        .await;
        assert_eq!(s, 200, "{chart}");
        assert!(String::from_utf8_lossy(&body).contains("<svg"), "{chart}");
    }
    let (s, page) = request(d.addr, "GET", "/calibrate", None, None).await;
    assert_eq!(s, 200);
    assert!(String::from_utf8_lossy(&page).contains("calibrate.js"));
    d.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_display_profile_without_a_black_or_from_a_missing_measurement_is_refused_naming_it() {
    let d = Daemon::start(0.0).await;
    let red = measure_shown(&d, &json!([1.0, 0.0, 0.0])).await;
    let body = json!({ "patches": [{ "drive": [1.0, 0.0, 0.0], "measurement_id": red }] }).to_string();
    let (s, e) = post_json(d.addr, "/api/display-profiles", TOKEN, &body).await;
    assert_eq!(s, 400, "{e}");
    assert!(
        e["error"]["message"].as_str().unwrap().contains("no black patch"),
        "{e}"
    );

    let body = json!({ "patches": [{ "drive": [0.0, 0.0, 0.0], "measurement_id": 9999 }] }).to_string();
    let (s, e) = post_json(d.addr, "/api/display-profiles", TOKEN, &body).await;
    assert_eq!(s, 404, "{e}");
    assert!(e["error"]["message"].as_str().unwrap().contains("9999"), "{e}");

    let (s, e) = post_json(d.addr, "/api/mock/display", TOKEN, r#"{"drive": [1.5, 0, 0]}"#).await;
    assert_eq!(s, 400, "{e}");
    assert!(e["error"]["message"].as_str().unwrap().contains("field `drive`"), "{e}");
    let (s, e) = get_json(d.addr, "/api/display-profiles/plan?steps=1").await;
    assert_eq!(s, 400, "{e}");
    assert!(e["error"]["message"].as_str().unwrap().contains("steps"), "{e}");
    let (s, _) = get_json(d.addr, "/api/display-profiles/77").await;
    assert_eq!(s, 404);
    d.stop().await;
}
