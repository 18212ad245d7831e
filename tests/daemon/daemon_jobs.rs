//! Renders and studies as bounded, cancellable jobs, and what a refused or
//! broken request leaves behind, against a whole daemon in-process (real
//! SQLite file, real HTTP on loopback, the simulated PR-650 on a pty).

use crate::common;

use std::time::Duration;

use common::{get_json, poll_until, post_json, request, Daemon, TOKEN};
use lightbooth::lab::assemble::QUEUE_CAPACITY;
use lightbooth::lab::jobs::{JOB_QUEUE_CAPACITY, MAX_RENDER_BOUNCES, MAX_RENDER_SAMPLES};
use lightbooth::store::Store;

/// A render of CYLINDER (21 targets) big enough to run for minutes.
const HEAVY: &str = r#"{"samples":4194304,"bounces":64,"codings":"rgb,spectral"}"#;

async fn count(addr: std::net::SocketAddr, path: &str) -> usize {
    let (status, v) = get_json(addr, path).await;
    assert_eq!(status, 200, "{path}: {v}");
    v.as_array().map(Vec::len).unwrap_or(0)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn render_request_of_4e9_samples_or_bounces_is_refused_naming_the_field_and_limit() {
    let d = Daemon::start(0.0).await;
    for (body, field, limit) in [
        (r#"{"samples":4000000000}"#, "samples", MAX_RENDER_SAMPLES),
        (r#"{"bounces":4000000000}"#, "bounces", MAX_RENDER_BOUNCES),
    ] {
        let (status, e) = post_json(d.addr, "/api/scenes/white/renders", TOKEN, body).await;
        assert_eq!(status, 400, "{body}: {e}");
        let message = e["error"]["message"].as_str().unwrap();
        assert!(message.contains(&format!("`{field}`")), "{message}");
        assert!(message.contains(&limit.to_string()), "{message}");
    }
    let (status, e) = post_json(d.addr, "/api/scenes/white/renders", TOKEN, r#"{"codings":"rgb,rgb"}"#).await;
    assert_eq!(status, 400, "{e}");
    assert_eq!(
        count(d.addr, "/api/scenes/white/renders").await,
        0,
        "a refused request records nothing"
    );
    d.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn render_queue_full_refuses_with_409_leaves_no_row_and_cancel_ends_every_job() {
    let d = Daemon::start(0.0).await;
    let mut ids = Vec::new();
    // One running and JOB_QUEUE_CAPACITY waiting.
    for _ in 0..=JOB_QUEUE_CAPACITY {
        let (status, r) = post_json(d.addr, "/api/scenes/cylinder/renders", TOKEN, HEAVY).await;
        assert_eq!(status, 202, "{r}");
        ids.push(r["render_id"].as_i64().unwrap());
    }
    poll_until(
        d.addr,
        &format!("/api/renders/{}", ids[0]),
        // Generous: the other tests of this file render on the same two cores.
        Duration::from_secs(120),
        |v| v["state"] == "running",
    )
    .await;
    let before = count(d.addr, "/api/scenes/cylinder/renders").await;
    let studies_before = count(d.addr, "/api/studies").await;
    for _ in 0..5 {
        let (status, e) = post_json(d.addr, "/api/scenes/cylinder/renders", TOKEN, HEAVY).await;
        assert_eq!(status, 409, "{e}");
        assert!(e["error"]["message"].as_str().unwrap().contains("queue is full"), "{e}");
        let (status, e) = post_json(
            d.addr,
            "/api/studies",
            TOKEN,
            r#"{"scenes":"white","seeds":1,"against":"reference"}"#,
        )
        .await;
        assert_eq!(status, 409, "{e}");
    }
    assert_eq!(
        count(d.addr, "/api/scenes/cylinder/renders").await,
        before,
        "refusals leave no render row"
    );
    assert_eq!(
        count(d.addr, "/api/studies").await,
        studies_before,
        "refusals leave no study row"
    );

    // Cancel a waiting one: it ends at once; then the running one: it stops.
    let (status, r) = post_json(d.addr, &format!("/api/renders/{}/cancel", ids[3]), TOKEN, "{}").await;
    assert_eq!(status, 202, "{r}");
    assert_eq!(r["state"], "cancelled", "{r}");
    let (status, _) = post_json(d.addr, &format!("/api/renders/{}/cancel", ids[3]), TOKEN, "{}").await;
    assert_eq!(status, 409, "an ended render cannot be cancelled again");
    for id in ids.iter().filter(|&&i| i != ids[3]) {
        let (status, r) = post_json(d.addr, &format!("/api/renders/{id}/cancel"), TOKEN, "{}").await;
        assert_eq!(status, 202, "{r}");
    }
    for id in &ids {
        let r = poll_until(d.addr, &format!("/api/renders/{id}"), Duration::from_secs(30), |v| {
            v["state"] != "running" && v["state"] != "queued"
        })
        .await;
        assert_eq!(r["state"], "cancelled", "{r}");
        assert!(r["result"].is_null());
    }
    let (status, _) = post_json(d.addr, "/api/renders/999999/cancel", TOKEN, "{}").await;
    assert_eq!(status, 404);
    d.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cancelled_render_and_study_can_be_retried_as_new_jobs() {
    let d = Daemon::start(0.0).await;
    let (_, r) = post_json(
        d.addr,
        "/api/scenes/white/renders",
        TOKEN,
        r#"{"samples":4096,"codings":"rgb"}"#,
    )
    .await;
    let first = r["render_id"].as_i64().unwrap();
    let (_, r) = post_json(d.addr, "/api/scenes/cylinder/renders", TOKEN, HEAVY).await;
    let heavy = r["render_id"].as_i64().unwrap();
    let (_, s) = post_json(
        d.addr,
        "/api/studies",
        TOKEN,
        r#"{"scenes":"white","seeds":1,"against":"reference"}"#,
    )
    .await;
    let study = s["id"].as_i64().unwrap();
    // The heavy render waits behind the first, the study behind both: cancel them.
    let (status, r) = post_json(d.addr, &format!("/api/studies/{study}/cancel"), TOKEN, "{}").await;
    assert_eq!(status, 202, "{r}");
    assert_eq!(r["state"], "cancelled", "{r}");
    poll_until(
        d.addr,
        &format!("/api/renders/{heavy}"),
        Duration::from_secs(120),
        |v| v["state"] == "running",
    )
    .await;
    post_json(d.addr, &format!("/api/renders/{heavy}/cancel"), TOKEN, "{}").await;
    let done = poll_until(
        d.addr,
        &format!("/api/renders/{first}"),
        Duration::from_secs(120),
        |v| v["state"] == "complete",
    )
    .await;
    assert!(done["result"].is_object());
    let (status, e) = post_json(d.addr, &format!("/api/renders/{first}/retry"), TOKEN, "{}").await;
    assert_eq!(status, 409, "a complete render is not retried: {e}");

    // Retry the cancelled study: a new id with the same request, which completes.
    let (status, s) = post_json(d.addr, &format!("/api/studies/{study}/retry"), TOKEN, "{}").await;
    assert_eq!(status, 202, "{s}");
    let again = s["id"].as_i64().unwrap();
    assert_ne!(again, study);
    let st = poll_until(
        d.addr,
        &format!("/api/studies/{again}"),
        Duration::from_secs(300),
        |v| v["state"] != "queued" && v["state"] != "running",
    )
    .await;
    assert_eq!(st["state"], "complete", "{st}");
    assert_eq!(st["request"]["scenes"], "white");
    let (_, old) = get_json(d.addr, &format!("/api/studies/{study}")).await;
    assert_eq!(old["state"], "cancelled", "the old row stays as it ended");
    d.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_cancels_a_running_render_and_marks_it_interrupted() {
    let d = Daemon::start(0.0).await;
    let (_, r) = post_json(d.addr, "/api/scenes/cylinder/renders", TOKEN, HEAVY).await;
    let running = r["render_id"].as_i64().unwrap();
    let (_, r) = post_json(d.addr, "/api/scenes/cylinder/renders", TOKEN, HEAVY).await;
    let queued = r["render_id"].as_i64().unwrap();
    poll_until(
        d.addr,
        &format!("/api/renders/{running}"),
        Duration::from_secs(30),
        |v| v["state"] == "running",
    )
    .await;
    // Daemon::stop bounds the shutdown (30 s); a render of minutes must not hold it.
    let dir = d.stop_keeping_files().await;
    let store = Store::open(&format!("sqlite://{}", dir.path().join("lab.sqlite").display()))
        .await
        .unwrap();
    for id in [running, queued] {
        let row = store.get_render(id).await.unwrap().unwrap();
        assert_eq!(row.state, "interrupted", "{row:?}");
        assert!(row.error.unwrap().contains("shut down"));
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_long_render_does_not_starve_the_instrument() {
    let d = Daemon::start(0.0).await;
    let (_, r) = post_json(d.addr, "/api/scenes/cylinder/renders", TOKEN, HEAVY).await;
    let heavy = r["render_id"].as_i64().unwrap();
    poll_until(d.addr, &format!("/api/renders/{heavy}"), Duration::from_secs(30), |v| {
        v["state"] == "running"
    })
    .await;
    // The simulated PR-650 needs the converged spectrum of its target
    // (rendered on the instrument's own pool) while the render fills rayon's.
    let (status, m) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene":"green","target":"patch","samples":2}"#,
    )
    .await;
    assert_eq!(status, 202, "{m}");
    let url = m["url"].as_str().unwrap().to_string();
    let done = poll_until(d.addr, &url, Duration::from_secs(240), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(done["state"], "complete", "{done}");
    let (_, r) = get_json(d.addr, &format!("/api/renders/{heavy}")).await;
    assert_eq!(
        r["state"], "running",
        "the render was still going: the test measured what it meant to"
    );
    d.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn queue_full_409_leaves_no_cancelled_measurement_row() {
    // Real timing: each sample takes the instrument's seconds, so the queue stays full.
    let d = Daemon::start(1.0).await;
    let body = r#"{"samples":99}"#;
    let mut admitted = 0;
    let mut refused = 0;
    // Race admissions against each other: all at once, more than fit.
    let mut tasks = Vec::new();
    for _ in 0..(QUEUE_CAPACITY + 40) {
        let addr = d.addr;
        tasks.push(tokio::spawn(async move {
            post_json(addr, "/api/measurements", TOKEN, body).await
        }));
    }
    for t in tasks {
        match t.await.unwrap() {
            (202, _) => admitted += 1,
            (409, _) => refused += 1,
            (status, v) => panic!("unexpected {status}: {v}"),
        }
    }
    assert!(
        refused >= 30,
        "the queue filled: {admitted} admitted, {refused} refused"
    );
    let (_, page) = get_json(d.addr, "/api/measurements?limit=1").await;
    let total = page["total"].as_i64().unwrap();
    assert_eq!(total, admitted as i64, "every row belongs to an admitted request");
    let (_, cancelled) = get_json(d.addr, "/api/measurements?state=cancelled&limit=1").await;
    assert_eq!(cancelled["total"], 0, "no refused request left a cancelled row");
    // And once more, sequentially: with the instrument busy on its first
    // measurement (99 samples at real speed take minutes), top the queue
    // up until it refuses; every refusal after that leaves the count alone.
    poll_until(d.addr, "/api/health", Duration::from_secs(30), |v| {
        v["instrument"]["state"] == "measuring"
    })
    .await;
    while post_json(d.addr, "/api/measurements", TOKEN, body).await.0 == 202 {}
    let (_, page) = get_json(d.addr, "/api/measurements?limit=1").await;
    let total_before = page["total"].as_i64();
    for _ in 0..10 {
        let (status, _) = post_json(d.addr, "/api/measurements", TOKEN, body).await;
        assert_eq!(status, 409);
    }
    let (_, page) = get_json(d.addr, "/api/measurements?limit=1").await;
    assert_eq!(page["total"].as_i64(), total_before);
    d.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_sample_write_that_fails_leaves_the_measurement_failed_not_complete() {
    let d = Daemon::start(0.0).await;
    // A real SQLite failure on the daemon's own file: a trigger (added by a
    // second connection, as a full disk or a broken file would) refuses
    // the second sample of any measurement.
    let url = format!("sqlite://{}", d.dir.path().join("lab.sqlite").display());
    let pool = sqlx::SqlitePool::connect(&url).await.unwrap();
    sqlx::query(
        "CREATE TRIGGER refuse_second_sample BEFORE INSERT ON samples WHEN NEW.idx = 1 \
         BEGIN SELECT RAISE(ABORT, 'disk I/O error (test trigger)'); END",
    )
    .execute(&pool)
    .await
    .unwrap();
    let (status, m) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples":3}"#).await;
    assert_eq!(status, 202, "{m}");
    let url = m["url"].as_str().unwrap().to_string();
    let done = poll_until(d.addr, &url, Duration::from_secs(60), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(done["state"], "failed", "{done}");
    let error = done["error"].as_str().unwrap();
    assert!(error.contains("sample 1 could not be written"), "{error}");
    assert!(done["radiance"].is_null(), "no average without every sample");
    assert_eq!(
        done["samples"].as_array().unwrap().len(),
        1,
        "the sample written is kept"
    );
    sqlx::query("DROP TRIGGER refuse_second_sample")
        .execute(&pool)
        .await
        .unwrap();
    pool.close().await;
    // The instrument goes on.
    let (_, m) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples":2}"#).await;
    let url = m["url"].as_str().unwrap().to_string();
    poll_until(d.addr, &url, Duration::from_secs(60), |v| v["state"] == "complete").await;
    let (status, _) = request(d.addr, "GET", "/api/health", None, None).await;
    assert_eq!(status, 200);
    d.stop().await;
}

/// Found by Schemathesis on the merged daemon: a study that queued its
/// missing measurements first stores `measured_first` in its request, and
/// retrying it answered 500 ("unknown field `measured_first`").
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_study_that_measured_missing_targets_first_can_be_retried() {
    let d = Daemon::start(0.0).await;
    let (status, s) = post_json(
        d.addr,
        "/api/studies",
        TOKEN,
        r#"{"scenes":"white","seeds":1,"measure_missing":true}"#,
    )
    .await;
    assert_eq!(status, 202, "{s}");
    let study = s["id"].as_i64().unwrap();
    let (_, row) = get_json(d.addr, &format!("/api/studies/{study}")).await;
    assert!(
        row["request"]["measured_first"]
            .as_array()
            .is_some_and(|m| !m.is_empty()),
        "{row}"
    );
    post_json(d.addr, &format!("/api/studies/{study}/cancel"), TOKEN, "{}").await;
    poll_until(
        d.addr,
        &format!("/api/studies/{study}"),
        Duration::from_secs(120),
        |v| v["state"] != "queued" && v["state"] != "running",
    )
    .await;
    let (status, again) = post_json(d.addr, &format!("/api/studies/{study}/retry"), TOKEN, "{}").await;
    assert_eq!(status, 202, "{again}");
    assert_ne!(again["id"].as_i64().unwrap(), study);
    d.stop().await;
}

/// The bug (issue 32): two simultaneous `POST /api/renders/{id}/retry`
/// answered two 202s (renders 3 and 4), and ten retries of one cancelled
/// render queued 8 renders. One retry per render: every other answers 409
/// naming the first retry.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ten_simultaneous_retries_of_one_cancelled_render_queued_eight_renders() {
    let d = Daemon::start(0.0).await;
    // A long render runs; a short one waits behind it and is cancelled.
    let (_, r) = post_json(d.addr, "/api/scenes/cylinder/renders", TOKEN, HEAVY).await;
    let heavy = r["render_id"].as_i64().unwrap();
    let (_, r) = post_json(
        d.addr,
        "/api/scenes/white/renders",
        TOKEN,
        r#"{"samples":64,"codings":"rgb"}"#,
    )
    .await;
    let cancelled = r["render_id"].as_i64().unwrap();
    let (status, r) = post_json(d.addr, &format!("/api/renders/{cancelled}/cancel"), TOKEN, "{}").await;
    assert_eq!((status, r["state"].as_str()), (202, Some("cancelled")), "{r}");
    let before = count(d.addr, "/api/scenes/white/renders").await;

    let path = format!("/api/renders/{cancelled}/retry");
    let answers = futures_util::future::join_all((0..10).map(|_| post_json(d.addr, &path, TOKEN, "{}"))).await;
    let accepted: Vec<i64> = answers
        .iter()
        .filter(|(s, _)| *s == 202)
        .map(|(_, v)| v["render_id"].as_i64().unwrap())
        .collect();
    assert_eq!(accepted.len(), 1, "exactly one retry is queued: {answers:?}");
    let first = accepted[0];
    let named = format!("render {cancelled} was already retried as render {first}");
    for (status, v) in answers.iter().filter(|(s, _)| *s != 202) {
        assert_eq!(*status, 409, "{v}");
        let message = v["error"]["message"].as_str().unwrap_or_default();
        assert!(message.starts_with(&named), "the 409 names the first retry: {v}");
    }
    assert_eq!(
        count(d.addr, "/api/scenes/white/renders").await,
        before + 1,
        "one render more, not ten"
    );
    // A later retry, one at a time, still names the same first retry.
    let (status, v) = post_json(d.addr, &path, TOKEN, "{}").await;
    assert_eq!(status, 409, "{v}");
    assert!(
        v["error"]["message"].as_str().unwrap_or_default().starts_with(&named),
        "{v}"
    );
    // Cancelled, the long render stops within a batch of paths (slow on a
    // busy machine): wait for it, so the daemon's shutdown is quick.
    for id in [first, heavy] {
        post_json(d.addr, &format!("/api/renders/{id}/cancel"), TOKEN, "{}").await;
        poll_until(d.addr, &format!("/api/renders/{id}"), Duration::from_secs(600), |v| {
            v["state"] != "queued" && v["state"] != "running"
        })
        .await;
    }
    d.stop().await;
}

/// The bug (issue 46): the scene page offered to "measure the 17 targets
/// not yet measured" while those 17 were queued, and one click queued 17
/// duplicates; the server queued whatever it was sent. A request for a
/// scene target already queued or running (same booth, samples, session,
/// hold) queues nothing and answers 200 with that measurement, even when
/// the copies arrive at once; other samples are another measurement; a
/// study's "measure the missing targets first" skips the ones on their way
/// and says how many.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_second_request_for_a_queued_target_queued_a_duplicate() {
    // Real timing: the instrument is busy for seconds, so the requests stay queued.
    let d = Daemon::start(1.0).await;
    let h01 = r#"{"scene":"cylinder","target":"h01","samples":5}"#;
    let copies: Vec<_> = (0..6)
        .map(|_| {
            let addr = d.addr;
            tokio::spawn(async move { post_json(addr, "/api/measurements", TOKEN, h01).await })
        })
        .collect();
    let mut answers = Vec::new();
    for c in copies {
        answers.push(c.await.unwrap());
    }
    let queued: Vec<_> = answers.iter().filter(|(s, _)| *s == 202).collect();
    assert_eq!(
        queued.len(),
        1,
        "one measurement queued of six identical requests: {answers:?}"
    );
    let first = queued[0].1["id"].as_i64().unwrap();
    assert_eq!(queued[0].1["duplicate"], false);
    for (status, v) in answers.iter().filter(|(s, _)| *s != 202) {
        assert_eq!(*status, 200, "{v}");
        assert_eq!(v["id"].as_i64(), Some(first), "{v}");
        assert_eq!(v["duplicate"], true, "{v}");
        assert_eq!(v["url"], format!("/api/measurements/{first}"), "{v}");
        let message = v["message"].as_str().unwrap();
        assert!(
            message.contains("cylinder/h01") && message.contains("nothing new was queued"),
            "{message}"
        );
    }
    // Other samples: another measurement.
    let (status, other) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene":"cylinder","target":"h01","samples":3}"#,
    )
    .await;
    assert_eq!(status, 202, "{other}");
    assert_ne!(other["id"].as_i64(), Some(first));
    for target in ["h02", "h03"] {
        let body = format!(r#"{{"scene":"cylinder","target":"{target}"}}"#);
        assert_eq!(post_json(d.addr, "/api/measurements", TOKEN, &body).await.0, 202);
    }
    let (_, page) = get_json(d.addr, "/api/measurements?scene=cylinder&limit=1000").await;
    assert_eq!(page["total"], 4, "{page}");

    // The study's batch: 21 targets, 3 on their way.
    let (status, s) = post_json(
        d.addr,
        "/api/studies",
        TOKEN,
        r#"{"scenes":"cylinder","seeds":1,"measure_missing":true}"#,
    )
    .await;
    assert_eq!(status, 202, "{s}");
    assert_eq!(s["measured_first"].as_array().map(Vec::len), Some(18), "{s}");
    let skipped = s["already_on_their_way"].as_array().unwrap();
    assert_eq!(skipped.len(), 3, "{s}");
    assert!(skipped.iter().any(|i| i.as_i64() == Some(first)), "{s}");
    assert!(
        s["message"]
            .as_str()
            .unwrap()
            .starts_with("3 of the missing targets already had a measurement"),
        "{s}"
    );
    let (_, page) = get_json(d.addr, "/api/measurements?scene=cylinder&limit=1000").await;
    assert_eq!(page["total"], 4 + 18, "no target queued twice: {page}");
    let (_, row) = get_json(d.addr, &format!("/api/studies/{}", s["id"])).await;
    assert_eq!(
        row["request"]["measured_first"].as_array().map(Vec::len),
        Some(21),
        "the study waits for the ones on their way too: {row}"
    );
    // A repeat on purpose (repeatability runs from a script) is queued.
    let (status, again) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene":"cylinder","target":"h01","samples":5,"repeat":true}"#,
    )
    .await;
    assert_eq!(status, 202, "{again}");
    assert_eq!(again["duplicate"], false, "{again}");
    assert_ne!(again["id"].as_i64(), Some(first), "{again}");
    post_json(d.addr, &format!("/api/studies/{}/cancel", s["id"]), TOKEN, "{}").await;
    d.stop().await;
}
