//! The operator's basics over a whole daemon on loopback (the simulated
//! PR-650 on a real pty, a real SQLite file, real HTTP): cancelling a queued
//! or running measurement, and a study that measures what it is missing
//! instead of failing.

use crate::common;

use std::time::Duration;

use common::{events, get_json, poll_until, post_json, request, wait_for, Daemon, TOKEN};
use serde_json::Value;

fn is_final(v: &Value) -> bool {
    !matches!(v["state"].as_str(), Some("queued") | Some("running") | None)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_queued_or_running_measurement_could_not_be_cancelled() {
    // About 1 s a sample: the measurement is surely running when it is cancelled.
    let d = Daemon::start(0.2).await;
    let mut ev = events(d.addr).await;
    let (status, running) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples":10}"#).await;
    assert_eq!(status, 202, "{running}");
    let (status, queued) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples":3}"#).await;
    assert_eq!(status, 202, "{queued}");
    let running = running["id"].as_i64().unwrap();
    let queued = queued["id"].as_i64().unwrap();

    // Writes need the token; an unknown measurement is 404.
    let (status, _) = request(
        d.addr,
        "POST",
        &format!("/api/measurements/{queued}/cancel"),
        None,
        None,
    )
    .await;
    assert_eq!(status, 401);
    let (status, v) = post_json(d.addr, "/api/measurements/999999/cancel", TOKEN, "{}").await;
    assert_eq!(status, 404, "{v}");

    // The queued one is cancelled at once and never starts.
    let (status, q) = post_json(d.addr, &format!("/api/measurements/{queued}/cancel"), TOKEN, "{}").await;
    assert_eq!(status, 200, "{q}");
    assert_eq!(q["state"], "cancelled", "{q}");
    assert_eq!(q["samples_taken"], 0);
    assert!(q["error"].as_str().unwrap().contains("before it started"), "{q}");
    wait_for(
        &mut ev,
        "the queued measurement's cancellation",
        Duration::from_secs(10),
        |name, v| name == "measurement_finished" && v["measurement_id"] == queued && v["state"] == "cancelled",
    )
    .await;

    // The running one stops after two samples, keeping them.
    wait_for(&mut ev, "two samples", Duration::from_secs(60), |name, v| {
        name == "sample" && v["measurement_id"] == running && v["index"] == 1
    })
    .await;
    let (status, r) = post_json(d.addr, &format!("/api/measurements/{running}/cancel"), TOKEN, "{}").await;
    assert!(status == 200 || status == 202, "{status} {r}");
    let finished = wait_for(
        &mut ev,
        "the running measurement's end",
        Duration::from_secs(30),
        |name, v| name == "measurement_finished" && v["measurement_id"] == running,
    )
    .await;
    assert_eq!(finished["state"], "cancelled", "{finished}");
    let m = poll_until(
        d.addr,
        &format!("/api/measurements/{running}"),
        Duration::from_secs(10),
        is_final,
    )
    .await;
    assert_eq!(m["state"], "cancelled", "never recorded as complete: {m}");
    assert!(
        m["radiance"].is_null(),
        "a cancelled measurement has no (complete) average: {m}"
    );
    let kept = m["samples"].as_array().unwrap().len();
    assert!((2..10).contains(&kept), "the samples taken are kept: {kept}");
    let message = m["error"].as_str().unwrap();
    assert!(
        message.contains(&format!("after {kept} samples of the 10 requested; kept all {kept}")),
        "the message says how many samples it kept: {message}"
    );
    // Its good samples are averaged as a partial result.
    assert_eq!(m["partial"], true, "{m}");
    assert_eq!(m["good_samples"].as_i64().unwrap() as usize, kept);
    // The partial Y (from the mean spectrum) agrees with the instrument's own
    // luminance readings of those samples (its `D2` report, four digits).
    let y = m["Y"].as_f64().unwrap();
    let reported: Vec<f64> = m["samples"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|s| s["Y"].as_f64())
        .collect();
    let mean = reported.iter().sum::<f64>() / reported.len() as f64;
    assert!(
        (y / mean - 1.0).abs() < 0.01,
        "partial Y {y} against the instrument's {mean}"
    );

    // A finished measurement cannot be cancelled: 409 with a clear message.
    let (status, v) = post_json(d.addr, &format!("/api/measurements/{running}/cancel"), TOKEN, "{}").await;
    assert_eq!(status, 409, "{v}");
    assert!(
        v["error"]["message"].as_str().unwrap().contains("is already cancelled"),
        "{v}"
    );

    // The instrument goes on: the next measurement completes, and the
    // cancelled queued one still has no sample and never started.
    let (status, next) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples":2}"#).await;
    assert_eq!(status, 202, "{next}");
    let n = poll_until(d.addr, next["url"].as_str().unwrap(), Duration::from_secs(60), is_final).await;
    assert_eq!(n["state"], "complete", "{n}");
    let (_, q) = get_json(d.addr, &format!("/api/measurements/{queued}")).await;
    assert_eq!(q["state"], "cancelled");
    assert!(q["started_at"].is_null(), "{q}");
    assert_eq!(q["samples"].as_array().unwrap().len(), 0);

    // The list filters by state and marks the partial average.
    let (status, page) = get_json(d.addr, "/api/measurements?state=cancelled").await;
    assert_eq!(status, 200);
    assert_eq!(page["total"], 2, "{page}");
    let listed = page["items"]
        .as_array()
        .unwrap()
        .iter()
        .find(|i| i["id"] == running)
        .unwrap();
    assert_eq!(listed["partial"], true);
    assert_eq!(listed["Y"], m["Y"]);
    d.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_default_study_failed_unless_measurements_existed() {
    let d = Daemon::start(0.0).await;
    let mut ev = events(d.addr).await;
    let study = r#"{"scenes":"white","seeds":1,"sweeps":false}"#;
    // Without measurements and without `measure_missing`: refused at once, in plain words.
    let (status, v) = post_json(d.addr, "/api/studies", TOKEN, study).await;
    assert_eq!(status, 409, "{v}");
    let message = v["error"]["message"].as_str().unwrap();
    assert!(message.contains("no complete measurement of white/patch"), "{message}");
    assert!(message.contains("\"measure_missing\": true"), "{message}");
    let (_, list) = get_json(d.addr, "/api/studies").await;
    assert_eq!(list.as_array().unwrap().len(), 0, "nothing was started: {list}");
    // A bad field is still 400, and nothing is queued for it.
    let (status, v) = post_json(
        d.addr,
        "/api/studies",
        TOKEN,
        r#"{"scenes":"white","seeds":0,"measure_missing":true}"#,
    )
    .await;
    assert_eq!(status, 400, "{v}");
    let (_, page) = get_json(d.addr, "/api/measurements").await;
    assert_eq!(page["total"], 0, "{page}");

    // With `measure_missing`, the study measures white/patch first, then runs against it.
    let (status, accepted) = post_json(
        d.addr,
        "/api/studies",
        TOKEN,
        r#"{"scenes":"white","seeds":1,"sweeps":false,"measure_missing":true}"#,
    )
    .await;
    assert_eq!(status, 202, "{accepted}");
    let id = accepted["id"].as_i64().unwrap();
    let mut progress = Vec::new();
    let done = wait_for(&mut ev, "the study", Duration::from_secs(600), |name, v| {
        if name == "study_progress" && v["study_id"] == id {
            progress.push(v["message"].as_str().unwrap_or_default().to_string());
        }
        name == "study_finished" && v["study_id"] == id
    })
    .await;
    assert_eq!(done["ok"], true, "{done}");
    assert!(
        progress
            .iter()
            .any(|p| p.contains("measuring the 1 missing target first")),
        "{progress:?}"
    );
    let (_, st) = get_json(d.addr, &format!("/api/studies/{id}")).await;
    assert_eq!(st["state"], "complete", "{st}");
    let measured: Vec<i64> = st["request"]["measured_first"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_i64().unwrap())
        .collect();
    assert_eq!(measured.len(), 1, "{st}");
    let (_, m) = get_json(d.addr, &format!("/api/measurements/{}", measured[0])).await;
    assert_eq!(m["state"], "complete");
    assert_eq!(
        (m["scene"].as_str(), m["target"].as_str()),
        (Some("white"), Some("patch"))
    );
    // The study's truth is that measurement.
    let source = st["result"]["scenes"][0]["truth"][0]["source"]
        .as_str()
        .unwrap_or_default();
    assert_eq!(
        source,
        format!("measurement {}", measured[0]),
        "{}",
        st["result"]["scenes"][0]
    );

    // Now nothing is missing: the same study runs without measuring again.
    let (status, again) = post_json(d.addr, "/api/studies", TOKEN, study).await;
    assert_eq!(status, 202, "{again}");
    let again = again["id"].as_i64().unwrap();
    let (_, st2) = get_json(d.addr, &format!("/api/studies/{again}")).await;
    assert!(st2["request"].get("measured_first").is_none(), "{st2}");
    let done = wait_for(&mut ev, "the second study", Duration::from_secs(600), |name, v| {
        name == "study_finished" && v["study_id"] == again
    })
    .await;
    assert_eq!(done["ok"], true, "{done}");
    d.stop().await;
}
