//! Experiment sessions under concurrent requests, through the real daemon
//! on loopback (issue 32): the last trial posted together with posts of
//! the position after it, and two tabs starting one observer at once.

use crate::common;

use common::{get_json, post_json, Daemon, TOKEN};
use serde_json::{json, Value};

use crate::experiment::{calibrated_booth, create, report_display, trial};

/// Regression (issue 32): posting a session's last trial together with a
/// few posts of the next position panicked a worker (`order[24]`, index
/// out of bounds: 39 connections closed without a response in 15 tries).
/// Every post now gets an answer: the last trial 200 once, the others 409
/// saying the session is complete (or which trial is next), and the
/// session is complete with all its trials.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_last_trial_posted_with_posts_of_the_next_position_gets_answers_not_closed_connections() {
    let d = Daemon::start(0.0).await;
    let (profile, measurement) = calibrated_booth(&d).await;
    let e = create(
        &d,
        json!({
            "measurement_id": measurement, "display_profile_id": profile,
            "approximations": ["nstep3"], "presentation": { "repeats": 1 }, "seed": 3,
        }),
    )
    .await;
    let id = e["id"].as_i64().unwrap();
    let mut closed = 0;
    for attempt in 0..15 {
        let (s, view) = post_json(
            d.addr,
            &format!("/api/experiments/{id}/sessions"),
            TOKEN,
            &json!({ "observer": format!("last{attempt}") }).to_string(),
        )
        .await;
        assert_eq!(s, 200, "{view}");
        let sid = view["session"]["id"].as_i64().unwrap();
        assert_eq!(view["trials_total"], 6);
        report_display(&d, sid).await;
        let path = format!("/api/experiment-sessions/{sid}/trials");
        for position in 0..5 {
            let (s, v) = post_json(d.addr, &path, TOKEN, &trial(position, 0).to_string()).await;
            assert_eq!(s, 200, "{v}");
        }
        let posts: Vec<_> = [5, 6, 6, 6, 6]
            .into_iter()
            .map(|position| {
                let (addr, path) = (d.addr, path.clone());
                tokio::spawn(async move {
                    let body = trial(position, 0).to_string();
                    let (s, v) = post_json(addr, &path, TOKEN, &body).await;
                    (position, s, v)
                })
            })
            .collect();
        let mut answers: Vec<(u64, u16, Value)> = Vec::new();
        for p in posts {
            // A panicking handler closes the connection: the client's read panics.
            match p.await {
                Ok(a) => answers.push(a),
                Err(_) => closed += 1,
            }
        }
        for (position, s, v) in &answers {
            match (position, s) {
                (5, 200) => assert_eq!(v["session"]["state"], "complete", "{v}"),
                (6, 409) => {
                    let m = v["error"]["message"].as_str().unwrap_or_default();
                    assert!(m.contains("is complete") || m.contains("the next is trial 5"), "{m}");
                }
                other => panic!("attempt {attempt}: unexpected answer {other:?}: {v}"),
            }
        }
        let (_, now) = get_json(d.addr, &format!("/api/experiment-sessions/{sid}")).await;
        assert_eq!(
            (now["session"]["state"].as_str(), now["trials_recorded"].as_u64()),
            (Some("complete"), Some(6)),
            "{now}"
        );
    }
    assert_eq!(closed, 0, "connections closed without a response in 15 tries");
    let (_, jobs) = get_json(d.addr, "/api/jobs").await;
    assert!(
        !jobs["jobs"]
            .as_array()
            .unwrap()
            .iter()
            .any(|j| j["kind"] == "experiment_session"),
        "no session left running: {jobs}"
    );
    d.stop().await;
}

/// Regression (issue 32): a 4-element `drive` was reported as "malformed
/// JSON: trailing characters" instead of naming the field.
#[tokio::test]
async fn a_drive_with_four_elements_is_refused_naming_the_field() {
    let d = Daemon::start(0.0).await;
    let (s, v) = post_json(
        d.addr,
        "/api/mock/display",
        TOKEN,
        &json!({ "drive": [0.1, 0.2, 0.3, 0.4] }).to_string(),
    )
    .await;
    assert_eq!(s, 400, "{v}");
    let m = v["error"]["message"].as_str().unwrap();
    assert!(m.starts_with("field `drive`: more elements than it takes"), "{m}");
    d.stop().await;
}
