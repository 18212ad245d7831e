//! The REST API through `app(state)` with `oneshot`, no socket: statuses,
//! error bodies, authorisation, both body encodings. The instrument side is
//! the job queue and status channel the real instrument task uses; here the
//! test plays that task.

use std::sync::Arc;

use axum::body::Body;
use axum::http::{Request, StatusCode};
use http_body_util::BodyExt;
use lightbooth::http::{app, AppState, ServiceConfig};
use lightbooth::lab::measure::booth_instrument::BoothInstrument;
use lightbooth::lab::measure::queue::InstrumentStatus;
use lightbooth::lab::measure::queue::MeasurementJob;
use lightbooth::lab::LabHandle;
use lightbooth::store::Store;
use serde_json::Value;
use tokio::sync::{mpsc, watch};
use tokio_util::sync::CancellationToken;
use tower::ServiceExt;

const TOKEN: &str = "0123456789abcdef0123456789abcdef";

struct Harness {
    state: AppState,
    /// The store under the lab, for what the test checks behind the API.
    store: Store,
    jobs: mpsc::Receiver<MeasurementJob>,
    status: watch::Sender<InstrumentStatus>,
    _shutdown: CancellationToken,
    _dir: tempfile::TempDir,
}

async fn harness(queue: usize) -> Harness {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(&format!("sqlite://{}", dir.path().join("api.sqlite").display()))
        .await
        .unwrap();
    let (tx, rx) = mpsc::channel(queue);
    let (status_tx, status_rx) = watch::channel(InstrumentStatus::Idle {
        model: "PR-650".into(),
        measures: "spectrum".into(),
        serial: Some("60931502".into()),
        port: "/dev/pts/9".into(),
    });
    let events = lightbooth::lab::events::EventSink::bus(64);
    let shutdown = CancellationToken::new();
    let instrument = BoothInstrument::new(
        store.clone(),
        tx,
        status_rx,
        events.clone(),
        None,
        lightbooth::instrument::Pr650Settings::default().capabilities(),
        Default::default(),
    );
    let state = AppState {
        lab: LabHandle::new(
            store.clone(),
            lightbooth::colorimetry::Observer::JuddVos,
            instrument,
            None,
        ),
        config: Arc::new(ServiceConfig {
            token: TOKEN.into(),
            loopback_only: true,
            allowed_hosts: Default::default(),
        }),
        events,
        mock: None,
        shutting_down: shutdown.clone(),
    };
    Harness {
        state,
        store,
        jobs: rx,
        status: status_tx,
        _shutdown: shutdown,
        _dir: dir,
    }
}

async fn send(state: &AppState, req: Request<Body>) -> (StatusCode, Value) {
    let response = app(state.clone()).oneshot(req).await.unwrap();
    let status = response.status();
    let bytes = response.into_body().collect().await.unwrap().to_bytes();
    let json = serde_json::from_slice(&bytes).unwrap_or(Value::Null);
    (status, json)
}

fn post(path: &str, content_type: &str, body: impl Into<Body>, token: Option<&str>) -> Request<Body> {
    let mut b = Request::post(path).header("content-type", content_type);
    if let Some(t) = token {
        b = b.header("authorization", format!("Bearer {t}"));
    }
    b.body(body.into()).unwrap()
}

fn get(path: &str) -> Request<Body> {
    Request::get(path).body(Body::empty()).unwrap()
}

fn error_message(v: &Value) -> &str {
    v["error"]["message"]
        .as_str()
        .unwrap_or_else(|| panic!("not an error body: {v}"))
}

#[tokio::test]
async fn health_and_openapi_answer_without_a_token() {
    let h = harness(4).await;
    let (status, body) = send(&h.state, get("/api/health")).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(body["status"], "ok");
    assert_eq!(body["instrument"]["state"], "idle");
    let (status, doc) = send(&h.state, get("/api/openapi.json")).await;
    assert_eq!(status, StatusCode::OK);
    for path in [
        "/api/health",
        "/api/measurements",
        "/api/measurements/{id}",
        "/api/measurements/{id}/cancel",
        "/api/events",
        "/api/openapi.json",
    ] {
        if path != "/api/openapi.json" {
            assert!(doc["paths"].get(path).is_some(), "OpenAPI lacks {path}");
        }
    }
    assert!(doc["components"]["securitySchemes"]["bearer"].is_object());
}

#[tokio::test]
async fn starting_a_measurement_needs_the_token() {
    let h = harness(4).await;
    let (status, body) = send(&h.state, post("/api/measurements", "application/json", "{}", None)).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    assert_eq!(body["error"]["code"], "unauthorized");
    assert!(error_message(&body).contains("Authorization: Bearer"));
    let (status, body) = send(
        &h.state,
        post("/api/measurements", "application/json", "{}", Some("not-the-token")),
    )
    .await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    assert_eq!(error_message(&body), "wrong token");
}

#[tokio::test]
async fn a_measurement_is_queued_from_json_or_a_form_and_can_be_read_back() {
    let mut h = harness(4).await;
    let (status, body) = send(
        &h.state,
        post(
            "/api/measurements",
            "application/json",
            r#"{"samples": 3, "note": "json"}"#,
            Some(TOKEN),
        ),
    )
    .await;
    assert_eq!(status, StatusCode::ACCEPTED, "{body}");
    let id = body["id"].as_i64().unwrap();
    assert_eq!(body["state"], "queued");
    let job = h.jobs.try_recv().unwrap();
    assert_eq!((job.id, job.samples), (id, 3));

    // MATLAB's webwrite(url, struct('samples', 5)) sends this.
    let (status, body) = send(
        &h.state,
        post(
            "/api/measurements",
            "application/x-www-form-urlencoded",
            "samples=5&note=form",
            Some(TOKEN),
        ),
    )
    .await;
    assert_eq!(status, StatusCode::ACCEPTED, "{body}");
    assert_eq!(h.jobs.try_recv().unwrap().samples, 5);

    let (status, m) = send(&h.state, get(&format!("/api/measurements/{id}"))).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(m["note"], "json");
    assert_eq!(m["samples_requested"], 3);
    assert!(m["samples"].as_array().unwrap().is_empty());
    let (_, list) = send(&h.state, get("/api/measurements?state=queued&limit=10")).await;
    assert_eq!(list["total"], 2);
}

#[tokio::test]
async fn bad_bodies_get_400_naming_the_field() {
    let h = harness(4).await;
    let cases = [
        (
            "application/json",
            "{\"samples\": ",
            "malformed JSON: EOF while parsing",
        ),
        ("application/json", r#"{"samples": "five"}"#, "field `samples`"),
        ("application/json", r#"{"sample": 5}"#, "unknown field `sample`"),
        (
            "application/json",
            r#"{"samples": 500}"#,
            "field `samples`: 500 is outside 1–99",
        ),
        ("application/x-www-form-urlencoded", "samples=abc", "field `samples`"),
        (
            "application/json",
            r#"{"target": "patch"}"#,
            "field `target`: a target needs its `scene`",
        ),
    ];
    for (ct, body, expected) in cases {
        let (status, v) = send(&h.state, post("/api/measurements", ct, body, Some(TOKEN))).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{body}: {v}");
        assert!(error_message(&v).contains(expected), "{body}: {v}");
    }
    let (status, v) = send(
        &h.state,
        post("/api/measurements", "text/plain", "samples=5", Some(TOKEN)),
    )
    .await;
    assert_eq!(status, StatusCode::UNSUPPORTED_MEDIA_TYPE, "{v}");
}

#[tokio::test]
async fn a_huge_body_gets_413() {
    let h = harness(4).await;
    let huge = format!("{{\"note\": \"{}\"}}", "x".repeat(lightbooth::http::MAX_BODY_BYTES + 1));
    let (status, v) = send(
        &h.state,
        post("/api/measurements", "application/json", huge, Some(TOKEN)),
    )
    .await;
    assert_eq!(status, StatusCode::PAYLOAD_TOO_LARGE, "{v}");
    assert_eq!(v["error"]["code"], "payload_too_large");
}

#[tokio::test]
async fn a_disconnected_instrument_gets_503_and_a_full_queue_409() {
    let h = harness(1).await;
    h.status
        .send(InstrumentStatus::Disconnected {
            reason: "port /dev/ttyUSB0 missing".into(),
        })
        .unwrap();
    let (status, v) = send(
        &h.state,
        post("/api/measurements", "application/json", "{}", Some(TOKEN)),
    )
    .await;
    assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE, "{v}");
    assert!(error_message(&v).contains("/dev/ttyUSB0"));

    h.status
        .send(InstrumentStatus::Idle {
            model: "PR-650".into(),
            measures: "spectrum".into(),
            serial: None,
            port: "p".into(),
        })
        .unwrap();
    let (status, _) = send(
        &h.state,
        post("/api/measurements", "application/json", "{}", Some(TOKEN)),
    )
    .await;
    assert_eq!(status, StatusCode::ACCEPTED);
    let (status, v) = send(
        &h.state,
        post("/api/measurements", "application/json", "{}", Some(TOKEN)),
    )
    .await;
    assert_eq!(status, StatusCode::CONFLICT, "{v}");
    assert!(error_message(&v).contains("busy"));
}

#[tokio::test]
async fn unknown_resources_get_404_json() {
    let h = harness(1).await;
    let (status, v) = send(&h.state, get("/api/measurements/9999")).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    assert_eq!(error_message(&v), "no measurement 9999");
    let (status, _) = send(&h.state, get("/matlab/../../Cargo.toml")).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
}

#[tokio::test]
async fn the_dashboard_and_matlab_examples_are_served() {
    let h = harness(1).await;
    let response = app(h.state.clone()).oneshot(get("/")).await.unwrap();
    assert_eq!(response.status(), StatusCode::OK);
    let html = response.into_body().collect().await.unwrap().to_bytes();
    assert!(std::str::from_utf8(&html)
        .unwrap()
        .contains("<title>lightbooth</title>"));
    let response = app(h.state.clone())
        .oneshot(get("/matlab/measure_and_poll.m"))
        .await
        .unwrap();
    assert_eq!(response.status(), StatusCode::OK);
}

/// Issue 32: `/favicon.ico` answered 404 (every browser asks for it).
#[tokio::test]
async fn the_favicon_ico_is_served_not_404() {
    let h = harness(1).await;
    for path in ["/favicon.ico", "/favicon.svg"] {
        let response = app(h.state.clone()).oneshot(get(path)).await.unwrap();
        assert_eq!(response.status(), StatusCode::OK, "{path}");
        let kind = response.headers()["content-type"].to_str().unwrap().to_string();
        assert_eq!(kind, "image/svg+xml", "{path}");
        let body = response.into_body().collect().await.unwrap().to_bytes();
        assert!(std::str::from_utf8(&body).unwrap().starts_with("<svg"), "{path}");
    }
}

/// Issue 32: a display profile's name ran as a script on the Calibrate
/// page. Every answer (pages, scripts, the API, refusals) carries a
/// Content-Security-Policy that allows only the daemon's own script files:
/// no inline script, no event-handler attribute, no `javascript:` URL, and
/// (Trusted Types) no string written as HTML. The pages themselves have no
/// inline script or handler attribute for the policy to break, and no
/// script of the pages writes markup from a string.
#[tokio::test]
async fn every_answer_carries_a_policy_that_forbids_inline_script_and_no_page_writes_html() {
    let h = harness(1).await;
    let pages = [
        "/",
        "/calibrate",
        "/experiment",
        "/experiment/1",
        "/experiment/1/run",
        "/matlab/",
    ];
    let scripts = [
        "/app.js",
        "/home.js",
        "/material.js",
        "/viewer.js",
        "/nav.js",
        "/measure.js",
        "/shared.js",
        "/trial.js",
        "/calibrate.js",
        "/experiment.js",
        "/experiment-run.js",
    ];
    let others = [
        "/style.css",
        "/api/health",
        "/api/measurements/9999",
        "/no-such-page",
        "/favicon.ico",
    ];
    for path in pages.iter().chain(&scripts).chain(&others) {
        let response = app(h.state.clone()).oneshot(get(path)).await.unwrap();
        let policy = response
            .headers()
            .get("content-security-policy")
            .unwrap_or_else(|| panic!("{path}: no Content-Security-Policy"))
            .to_str()
            .unwrap()
            .to_string();
        let script_src = policy
            .split(';')
            .map(str::trim)
            .find_map(|d| d.strip_prefix("script-src "))
            .unwrap_or_else(|| panic!("{path}: the policy names no script-src: {policy}"));
        assert_eq!(script_src, "'self'", "{path}: {policy}");
        assert!(policy.contains("object-src 'none'"), "{path}: {policy}");
        assert!(
            policy.contains("require-trusted-types-for 'script'"),
            "{path}: {policy}"
        );
        assert_eq!(response.headers()["x-content-type-options"], "nosniff", "{path}");
        let body = response.into_body().collect().await.unwrap().to_bytes();
        let text = String::from_utf8_lossy(&body).to_ascii_lowercase();
        if pages.contains(path) {
            for (i, _) in text.match_indices("<script") {
                let tag = &text[i..i + text[i..].find('>').unwrap()];
                assert!(tag.contains(" src="), "{path}: an inline script: {tag}");
            }
            let handler = event_handler_attribute(&text);
            assert!(handler.is_none(), "{path}: an event-handler attribute: {handler:?}");
            assert!(!text.contains("javascript:"), "{path}: a javascript: URL");
        }
        if scripts.contains(path) {
            for sink in ["innerhtml", "outerhtml", "insertadjacenthtml", "document.write"] {
                assert!(!text.contains(sink), "{path} writes markup with {sink}");
            }
        }
    }
}

/// The first ` on…=` attribute in `html`, if any.
fn event_handler_attribute(html: &str) -> Option<String> {
    html.match_indices(" on").find_map(|(i, _)| {
        let rest = &html[i + 3..];
        let name: String = rest.chars().take_while(|c| c.is_ascii_alphabetic()).collect();
        let after = rest[name.len()..].trim_start();
        (!name.is_empty() && after.starts_with('=')).then(|| html[i..(i + 40).min(html.len())].to_string())
    })
}

#[tokio::test]
async fn health_says_degraded_while_the_instrument_task_restarts_and_503_when_it_is_gone() {
    let h = harness(4).await;
    h.status.send_replace(InstrumentStatus::Error {
        message: "the instrument task panicked (test); restarting it in 1 s".into(),
    });
    let (status, body) = send(&h.state, get("/api/health")).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(body["status"], "degraded");
    assert_eq!(body["instrument_task"], "restarting");
    // The task holds the queue's receiving end: without it nothing can run.
    let Harness {
        state,
        jobs,
        status: status_tx,
        _shutdown,
        _dir,
        ..
    } = h;
    status_tx.send_replace(InstrumentStatus::Idle {
        model: "PR-650".into(),
        measures: "spectrum".into(),
        serial: None,
        port: "/dev/pts/9".into(),
    });
    drop(jobs);
    let (status, body) = send(&state, get("/api/health")).await;
    assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE, "{body}");
    assert_eq!(body["status"], "down");
    assert_eq!(body["instrument_task"], "stopped");
    let (status, body) = send(
        &state,
        post("/api/measurements", "application/json", r#"{"samples":2}"#, Some(TOKEN)),
    )
    .await;
    assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE, "{body}");
}

#[tokio::test]
async fn the_measurement_list_had_no_paging_filters_notes_or_partial_averages() {
    use lightbooth::store::{MeasurementState, NewMeasurement, NewSample};
    let h = harness(4).await;
    let store = &h.store;
    let new = |scene: Option<&str>| NewMeasurement {
        booth: Default::default(),
        session_id: None,
        scene: scene.map(String::from),
        target: scene.map(|_| "patch".to_string()),
        samples: 5,
        settings_json: serde_json::json!({}),
        note: String::new(),
    };
    for i in 0..130 {
        store
            .create_measurement(&new(if i % 13 == 0 { Some("white") } else { None }))
            .await
            .unwrap();
    }
    // Notes given when it is started are kept and listed (`notes` or `note`).
    let (status, body) = send(
        &h.state,
        post(
            "/api/measurements",
            "application/json",
            r#"{"samples": 5, "notes": "lamp warmed up 20 min"}"#,
            Some(TOKEN),
        ),
    )
    .await;
    assert_eq!(status, StatusCode::ACCEPTED, "{body}");
    let noted = body["id"].as_i64().unwrap();

    // An interrupted measurement with three good samples and a bad one: a
    // flat spectrum at 0.009, 0.010, 0.011 W/(sr·m²·nm) on the PR-650's 101 points.
    let interrupted = store.create_measurement(&new(Some("white"))).await.unwrap();
    store.mark_running(interrupted, None).await.unwrap();
    for (i, level) in [0.009, 0.010, 0.011].into_iter().enumerate() {
        let s = NewSample {
            index: i,
            taken_at: 1.7e9 + i as f64,
            code: 0,
            message: "OK".into(),
            usable: true,
            radiance: Some(vec![level; 101]),
            luminance_cd_m2: Some(73.0),
            instrument_xyz: None,
        };
        store.insert_sample(interrupted, &s).await.unwrap();
    }
    let bad = NewSample {
        index: 3,
        taken_at: 1.7e9 + 3.0,
        code: 18,
        message: "light source too dim".into(),
        usable: false,
        radiance: None,
        luminance_cd_m2: None,
        instrument_xyz: None,
    };
    store.insert_sample(interrupted, &bad).await.unwrap();
    store
        .end_measurement(interrupted, MeasurementState::Interrupted, "the cable was pulled")
        .await
        .unwrap();
    let total = 132;

    // Paging beyond 100 rows, newest first, with the total.
    let (status, first) = send(&h.state, get("/api/measurements?limit=100")).await;
    assert_eq!(status, StatusCode::OK, "{first}");
    assert_eq!(first["total"], total);
    assert_eq!(first["items"].as_array().unwrap().len(), 100);
    let (_, second) = send(&h.state, get("/api/measurements?limit=100&offset=100")).await;
    let second_items = second["items"].as_array().unwrap();
    assert_eq!(second_items.len(), total - 100);
    assert_eq!(
        first["items"][99]["id"].as_i64().unwrap() - 1,
        second_items[0]["id"].as_i64().unwrap(),
        "the second page starts where the first ended"
    );
    // Filters by scene and state, and bad ones name the field.
    let (_, white) = send(&h.state, get("/api/measurements?scene=white")).await;
    assert_eq!(white["total"], 11, "{white}");
    let (_, both) = send(&h.state, get("/api/measurements?scene=white&state=interrupted")).await;
    assert_eq!(both["total"], 1, "{both}");
    for (query, field) in [
        ("state=finished", "state"),
        ("limit=0", "limit"),
        ("limit=5000", "limit"),
        ("offset=-1", "offset"),
    ] {
        let (status, body) = send(&h.state, get(&format!("/api/measurements?{query}"))).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{query}: {body}");
        assert!(error_message(&body).contains(&format!("`{field}`")), "{query}: {body}");
    }

    let listed = |page: &Value, id: i64| {
        page["items"]
            .as_array()
            .unwrap()
            .iter()
            .find(|i| i["id"] == id)
            .cloned()
            .unwrap()
    };
    let (_, newest) = send(&h.state, get("/api/measurements?limit=5")).await;
    assert_eq!(listed(&newest, noted)["note"], "lamp warmed up 20 min");
    let queued = listed(&newest, noted);
    assert_eq!(
        (queued["partial"].clone(), queued["good_samples"].clone()),
        (Value::Bool(false), 0.into())
    );
    assert!(queued["Y"].is_null());

    // The interrupted one: the average of its three good samples, marked partial.
    let m = listed(&newest, interrupted);
    assert_eq!(m["state"], "interrupted");
    assert_eq!(m["partial"], true, "{m}");
    assert_eq!(m["good_samples"], 3);
    assert_eq!(m["samples_taken"], 4);
    // Equal-energy white: x = y = 1/3; Y = Km·∫ȳ dλ·L = 683 lm/W × 106.86 nm × 0.010 W/(sr·m²·nm) = 729.8 cd/m².
    let y = m["Y"].as_f64().unwrap();
    assert!((y / 729.8 - 1.0).abs() < 0.01, "partial Y = {y}");
    assert!((m["x"].as_f64().unwrap() - 1.0 / 3.0).abs() < 0.003, "{m}");
    assert!((m["y"].as_f64().unwrap() - 1.0 / 3.0).abs() < 0.003, "{m}");
    // The detail says the same, and still has no (complete) average spectrum.
    let (_, detail) = send(&h.state, get(&format!("/api/measurements/{interrupted}"))).await;
    assert_eq!(detail["partial"], true);
    assert_eq!(detail["Y"], m["Y"]);
    assert!(detail["radiance"].is_null());
}

#[tokio::test]
async fn a_queued_measurement_could_not_be_cancelled() {
    let mut h = harness(4).await;
    let (_, body) = send(
        &h.state,
        post("/api/measurements", "application/json", "{}", Some(TOKEN)),
    )
    .await;
    let id = body["id"].as_i64().unwrap();
    let mut events = h.state.events.subscribe().expect("the test state has a bus");
    let cancel = format!("/api/measurements/{id}/cancel");
    let (status, body) = send(&h.state, post(&cancel, "application/json", "{}", None)).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED, "{body}");
    let (status, body) = send(&h.state, post(&cancel, "application/json", "{}", Some(TOKEN))).await;
    assert_eq!(status, StatusCode::OK, "{body}");
    assert_eq!(body["state"], "cancelled");
    match events.try_recv().unwrap() {
        lightbooth::lab::events::Event::MeasurementFinished {
            measurement_id, state, ..
        } => {
            assert_eq!(
                (measurement_id, state),
                (id, lightbooth::store::MeasurementState::Cancelled)
            )
        }
        other => panic!("unexpected event {other:?}"),
    }
    // The instrument task then finds it no longer queued and skips it.
    let job = h.jobs.try_recv().unwrap();
    assert!(h.store.mark_running(job.id, None).await.is_err());
    let (status, body) = send(&h.state, post(&cancel, "application/json", "{}", Some(TOKEN))).await;
    assert_eq!(status, StatusCode::CONFLICT, "{body}");
    assert!(error_message(&body).contains("already cancelled"), "{body}");
    let (status, _) = send(
        &h.state,
        post("/api/measurements/4242/cancel", "application/json", "{}", Some(TOKEN)),
    )
    .await;
    assert_eq!(status, StatusCode::NOT_FOUND);
}

fn request(method: &str, path: &str, token: Option<&str>) -> Request<Body> {
    let mut b = Request::builder().method(method).uri(path);
    if let Some(t) = token {
        b = b.header("authorization", format!("Bearer {t}"));
    }
    b.body(Body::empty()).unwrap()
}

/// Status, content type and JSON body (Null when not JSON).
async fn send_typed(state: &AppState, req: Request<Body>) -> (StatusCode, String, Value) {
    let response = app(state.clone()).oneshot(req).await.unwrap();
    let status = response.status();
    let content_type = response
        .headers()
        .get("content-type")
        .map(|v| v.to_str().unwrap().to_string())
        .unwrap_or_default();
    let bytes = response.into_body().collect().await.unwrap().to_bytes();
    (
        status,
        content_type,
        serde_json::from_slice(&bytes).unwrap_or(Value::Null),
    )
}

#[tokio::test]
async fn json_body_with_trailing_bytes_is_refused_and_starts_nothing() {
    let mut h = harness(4).await;
    for body in [r#"{"samples":3}xx"#, r#"{"samples":3} {}"#, "{}]"] {
        let (status, v) = send(
            &h.state,
            post("/api/measurements", "application/json", body, Some(TOKEN)),
        )
        .await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{body}: {v}");
        assert!(error_message(&v).contains("after the JSON value"), "{v}");
    }
    let (status, v) = send(
        &h.state,
        post(
            "/api/sessions",
            "application/json",
            r#"{"operator":"ana"}garbage"#,
            Some(TOKEN),
        ),
    )
    .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    assert!(h.jobs.try_recv().is_err(), "a measurement was queued");
    let (_, page) = send(&h.state, get("/api/measurements")).await;
    assert_eq!(page["total"], 0, "{page}");
    // Trailing whitespace is still one JSON document.
    let (status, v) = send(
        &h.state,
        post(
            "/api/measurements",
            "application/json",
            "{\"samples\":3}\n ",
            Some(TOKEN),
        ),
    )
    .await;
    assert_eq!(status, StatusCode::ACCEPTED, "{v}");
}

#[tokio::test]
async fn non_numeric_and_out_of_range_path_ids_answer_json_naming_the_parameter() {
    let h = harness(1).await;
    for path in [
        "/api/measurements/abc",
        "/api/measurements/99999999999999999999",
        "/api/measurements/1.5/spectrum.csv",
        "/api/renders/-x",
        "/api/studies/abc/files/index.html",
    ] {
        let (status, content_type, v) = send_typed(&h.state, get(path)).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{path}: {v}");
        assert_eq!(content_type, "application/json", "{path}");
        assert_eq!(v["error"]["code"], "bad_request", "{path}: {v}");
        assert!(error_message(&v).contains("path parameter `id`"), "{path}: {v}");
    }
}

#[tokio::test]
async fn unknown_paths_and_wrong_methods_answer_json_not_empty_bodies() {
    let h = harness(1).await;
    for path in ["/api/nope", "/api/measurements/1/nope", "/nope", "/matlab/nope.m"] {
        let (status, content_type, v) = send_typed(&h.state, get(path)).await;
        assert_eq!(status, StatusCode::NOT_FOUND, "{path}");
        assert_eq!(content_type, "application/json", "{path}");
        assert_eq!(v["error"]["code"], "not_found", "{path}: {v}");
    }
    for (method, path) in [
        ("DELETE", "/api/measurements"),
        ("PUT", "/api/measurements/1"),
        ("POST", "/api/health"),
        ("POST", "/"),
    ] {
        let response = app(h.state.clone())
            .oneshot(request(method, path, Some(TOKEN)))
            .await
            .unwrap();
        assert_eq!(response.status(), StatusCode::METHOD_NOT_ALLOWED, "{method} {path}");
        assert!(response.headers().get("allow").is_some(), "{method} {path}: no Allow");
        let bytes = response.into_body().collect().await.unwrap().to_bytes();
        let v: Value = serde_json::from_slice(&bytes).unwrap_or_else(|_| panic!("{method} {path}: {bytes:?}"));
        assert_eq!(v["error"]["code"], "method_not_allowed", "{v}");
    }
}

#[tokio::test]
async fn oversized_request_target_and_headers_answer_json_414_and_431() {
    let h = harness(1).await;
    let long = format!("/api/measurements?scene={}", "a".repeat(10_000));
    let (status, content_type, v) = send_typed(&h.state, get(&long)).await;
    assert_eq!(status, StatusCode::URI_TOO_LONG, "{v}");
    assert_eq!(content_type, "application/json");
    assert_eq!(v["error"]["code"], "uri_too_long");
    let req = Request::get("/api/health")
        .header("x-padding", "b".repeat(40_000))
        .body(Body::empty())
        .unwrap();
    let (status, _, v) = send_typed(&h.state, req).await;
    assert_eq!(status, StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE, "{v}");
    assert_eq!(v["error"]["code"], "headers_too_large");
}

#[tokio::test]
async fn negative_limit_and_offset_are_refused_not_clamped() {
    let h = harness(1).await;
    for (query, parameter) in [
        ("limit=-5", "limit"),
        ("limit=0", "limit"),
        ("limit=1001", "limit"),
        ("offset=-1", "offset"),
        ("limit=abc", "limit"),
    ] {
        let (status, v) = send(&h.state, get(&format!("/api/measurements?{query}"))).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{query}: {v}");
        assert!(error_message(&v).contains(&format!("`{parameter}`")), "{query}: {v}");
    }
    let (status, v) = send(&h.state, get("/api/measurements?limit=1000&offset=0")).await;
    assert_eq!(status, StatusCode::OK, "{v}");
}

/// Fills `{param}` placeholders with values that parse.
fn concrete(path: &str) -> String {
    path.replace("{id}", "1")
        .replace("{scene}", "white")
        .replace("{chart}", "de.svg")
        .replace("{name}", "index.html")
}

#[tokio::test]
async fn openapi_document_and_router_list_the_same_paths_and_methods() {
    let h = harness(1).await;
    let (status, doc) = send(&h.state, get("/api/openapi.json")).await;
    assert_eq!(status, StatusCode::OK);
    let paths = doc["paths"].as_object().unwrap();
    assert!(paths.contains_key("/api/openapi.json"));
    assert!(paths.len() >= 25, "{} paths", paths.len());
    for (path, item) in paths {
        assert!(path.starts_with("/api/"), "{path}");
        for method in ["get", "post", "put", "delete", "patch"] {
            let documented = item.get(method).is_some();
            if path == "/api/events" && documented {
                continue; // an endless stream: it is routed (see `/api/events` tests)
            }
            let response = app(h.state.clone())
                .oneshot(request(&method.to_uppercase(), &concrete(path), Some(TOKEN)))
                .await
                .unwrap();
            let status = response.status();
            let bytes = response.into_body().collect().await.unwrap().to_bytes();
            let body = String::from_utf8_lossy(&bytes);
            if documented {
                assert_ne!(
                    status,
                    StatusCode::METHOD_NOT_ALLOWED,
                    "{method} {path} is documented, not routed"
                );
                assert!(
                    !body.contains("no resource at"),
                    "{method} {path} is documented, not routed: {body}"
                );
                let declared = item[method]["responses"].as_object().unwrap();
                assert!(
                    declared.contains_key(status.as_str()),
                    "{method} {path} answered {status}, not in the document ({:?})",
                    declared.keys().collect::<Vec<_>>()
                );
            } else {
                assert_eq!(
                    status,
                    StatusCode::METHOD_NOT_ALLOWED,
                    "{method} {path} is routed, not documented"
                );
            }
        }
    }
}

#[tokio::test]
async fn openapi_states_the_real_ranges_and_every_error_status() {
    let h = harness(1).await;
    let (_, doc) = send(&h.state, get("/api/openapi.json")).await;
    let samples = &doc["components"]["schemas"]["StartMeasurement"]["properties"]["samples"];
    assert_eq!(samples["minimum"], 1, "{samples}");
    // The most samples is the instrument model's (the PR-650's driver: 99),
    // not one number the schema could state: the description says so.
    assert!(samples["maximum"].is_null(), "{samples}");
    assert!(
        samples["description"]
            .as_str()
            .unwrap()
            .contains("instrument model allows"),
        "{samples}"
    );
    let params = doc["paths"]["/api/measurements"]["get"]["parameters"]
        .as_array()
        .unwrap();
    let limit = params.iter().find(|p| p["name"] == "limit").unwrap();
    assert_eq!(limit["schema"]["minimum"], 1, "{limit}");
    assert_eq!(limit["schema"]["maximum"], 1000, "{limit}");
    let offset = params.iter().find(|p| p["name"] == "offset").unwrap();
    assert_eq!(offset["schema"]["minimum"], 0, "{offset}");
    let post = &doc["paths"]["/api/measurements"]["post"]["responses"];
    for status in ["202", "400", "401", "409", "413", "415", "500", "503"] {
        assert!(post.get(status).is_some(), "POST /api/measurements lacks {status}");
    }
    let get_one = &doc["paths"]["/api/measurements/{id}"]["get"]["responses"];
    for status in ["200", "400", "401", "404", "500"] {
        assert!(
            get_one.get(status).is_some(),
            "GET /api/measurements/{{id}} lacks {status}"
        );
    }
}

#[tokio::test]
async fn openapi_states_render_and_study_limits() {
    let h = harness(1).await;
    let (_, doc) = send(&h.state, get("/api/openapi.json")).await;
    let render = &doc["components"]["schemas"]["RenderRequest"]["properties"];
    assert_eq!(
        render["samples"]["maximum"],
        lightbooth::lab::jobs::MAX_RENDER_SAMPLES,
        "{render}"
    );
    assert_eq!(
        render["bounces"]["maximum"],
        lightbooth::lab::jobs::MAX_RENDER_BOUNCES,
        "{render}"
    );
    assert_eq!(render["bounces"]["maximum"], 64, "{render}");
    assert_eq!(
        doc["components"]["schemas"]["StudyRequest"]["properties"]["seeds"]["maximum"],
        64
    );
}

/// An empty POST means "all defaults" (MATLAB `webwrite(url)`), so the
/// document must not call those bodies required; a blank operator is refused,
/// so the document says it must hold a non-blank character.
#[tokio::test]
async fn openapi_marks_default_bodies_optional_and_operator_non_blank() {
    let h = harness(2).await;
    let (_, doc) = send(&h.state, get("/api/openapi.json")).await;
    for (path, method) in [
        ("/api/measurements", "post"),
        ("/api/studies", "post"),
        ("/api/scenes/{scene}/renders", "post"),
    ] {
        let body = &doc["paths"][path][method]["requestBody"];
        assert_ne!(body["required"], true, "{method} {path}: {body}");
    }
    let (status, v) = send(&h.state, post("/api/measurements", "", "", Some(TOKEN))).await;
    assert_eq!(status, StatusCode::ACCEPTED, "{v}");
    let (status, v) = send(
        &h.state,
        post("/api/measurements", "application/json", "null", Some(TOKEN)),
    )
    .await;
    assert_eq!(status, StatusCode::ACCEPTED, "{v}");
    let operator = &doc["components"]["schemas"]["NewSession"]["properties"]["operator"];
    assert_eq!(operator["minLength"], 1, "{operator}");
    assert_eq!(operator["pattern"], "\\S", "{operator}");
}

/// "Look for instruments again": the scan needs the token, answers within
/// its deadline and a margin, lists every serial port of this machine with
/// a status from the probe's vocabulary, and never asks the port this
/// daemon's instrument is on.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_instrument_scan_needs_the_token_is_bounded_and_names_each_port() {
    let h = harness(4).await;
    let (status, _) = send(&h.state, post("/api/instruments/scan", "application/json", "{}", None)).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    let started = std::time::Instant::now();
    let (status, scan) = send(
        &h.state,
        post("/api/instruments/scan", "application/json", "{}", Some(TOKEN)),
    )
    .await;
    let took = started.elapsed();
    assert_eq!(status, StatusCode::OK, "{scan}");
    assert!(took < std::time::Duration::from_secs(4), "{took:?}");
    assert_eq!(scan["deadline_s"], 2.0);
    let known = [
        "identified",
        "not-probed",
        "busy",
        "permission-denied",
        "missing",
        "not-serial",
        "open-failed",
        "io-error",
        "silent",
        "unrecognised",
        "overran",
        "this-daemon",
    ];
    for p in scan["ports"].as_array().unwrap() {
        let status = p["status"].as_str().unwrap();
        assert!(known.contains(&status), "{p}");
        assert!(!p["message"].as_str().unwrap().is_empty(), "{p}");
        assert_ne!(
            p["port"], "/dev/pts/9",
            "a pty is not in sysfs, and this daemon's port is never asked"
        );
    }
    eprintln!("scan in {took:?}: {scan:#}");
}

/// Regression (issue 46): hold ids were counted in memory from 1, so after
/// a restart a calibration page left open posted into another client's new
/// hold 1, and stored measurements carried ambiguous hold ids. They differ
/// across a daemon restart on the same SQLite file, and the old hold stays
/// ended.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hold_ids_started_again_at_1_after_a_restart() {
    use crate::common::{post_json, Daemon, TOKEN};
    let purpose = r#"{"purpose": "display calibration “crt”"}"#;
    let d = Daemon::start(0.0).await;
    let (s, first) = post_json(d.addr, "/api/instrument/hold", TOKEN, purpose).await;
    assert_eq!(s, 201, "{first}");
    let dir = d.stop_keeping_files().await;
    let d = Daemon::start_on(0.0, &format!("sqlite://{}", dir.path().join("lab.sqlite").display())).await;
    let (s, second) = post_json(d.addr, "/api/instrument/hold", TOKEN, purpose).await;
    assert_eq!(s, 201, "{second}");
    assert_ne!(
        first["id"], second["id"],
        "a new hold after the restart: {first} then {second}"
    );
    // The page left open across the restart names its old hold: refused,
    // not taken into the new one.
    let old = serde_json::json!({ "samples": 1, "hold": first["id"] }).to_string();
    let (s, v) = post_json(d.addr, "/api/measurements", TOKEN, &old).await;
    assert_eq!(s, 409, "{v}");
    d.stop().await;
}

/// Regression (issue 46): a hold lasted until released, so a vanished
/// client blocked every measurement until an operator stepped in. A hold
/// says when it expires and how often to renew it; a renewal moves the
/// expiry on; an ended hold cannot be renewed.
#[tokio::test]
async fn a_hold_stated_no_expiry_and_could_not_be_renewed() {
    let h = harness(4).await;
    let take = r#"{"purpose": "display calibration “crt”"}"#;
    let (status, hold) = send(
        &h.state,
        post("/api/instrument/hold", "application/json", take, Some(TOKEN)),
    )
    .await;
    assert_eq!(status, StatusCode::CREATED, "{hold}");
    let id = hold["id"].as_i64().unwrap();
    let since = hold["since"].as_f64().unwrap();
    let within = hold["renew_within_s"]
        .as_f64()
        .unwrap_or_else(|| panic!("no renew_within_s: {hold}"));
    let expires = hold["expires_at"]
        .as_f64()
        .unwrap_or_else(|| panic!("no expires_at: {hold}"));
    assert!((60.0..=600.0).contains(&within), "{hold}");
    assert!((expires - (since + within)).abs() < 1e-6, "{hold}");
    let renew = format!("/api/instrument/hold/{id}/renew");
    let (status, renewed) = send(&h.state, post(&renew, "application/json", "{}", Some(TOKEN))).await;
    assert_eq!(status, StatusCode::OK, "{renewed}");
    assert_eq!(renewed["id"], id);
    assert!(renewed["expires_at"].as_f64().unwrap() >= expires, "{renewed}");
    let (status, current) = send(&h.state, get("/api/instrument/hold")).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(current["expires_at"], renewed["expires_at"], "{current}");
    // Renewing needs the token, as taking and releasing do.
    let (status, _) = send(&h.state, post(&renew, "application/json", "{}", None)).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    let release = format!("/api/instrument/hold/{id}/release");
    let (status, v) = send(&h.state, post(&release, "application/json", "{}", Some(TOKEN))).await;
    assert_eq!(status, StatusCode::OK, "{v}");
    let (status, v) = send(&h.state, post(&renew, "application/json", "{}", Some(TOKEN))).await;
    assert_eq!(status, StatusCode::NOT_FOUND, "{v}");
    assert!(error_message(&v).contains(&format!("hold {id}")), "{v}");
}

/// Regression (issue 46): `/api/health` said `ok` while the instrument was
/// `starting` and a measurement answered 503. It says measurements are
/// refused, in the words a measurement POST answers, and `degraded`.
#[tokio::test]
async fn health_said_ok_while_the_instrument_was_starting_and_measurements_answered_503() {
    let h = harness(4).await;
    h.status.send_replace(InstrumentStatus::Disconnected {
        reason: "starting".into(),
    });
    let (status, refused) = send(
        &h.state,
        post("/api/measurements", "application/json", r#"{"samples":2}"#, Some(TOKEN)),
    )
    .await;
    assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE, "{refused}");
    let (status, body) = send(&h.state, get("/api/health")).await;
    assert_eq!(status, StatusCode::OK, "the daemon itself runs: {body}");
    assert_eq!(body["status"], "degraded", "{body}");
    assert_eq!(body["measurements"], "refused", "{body}");
    assert_eq!(body["measurements_refused"], error_message(&refused), "{body}");
    // Once the instrument is idle, both say yes.
    h.status.send_replace(InstrumentStatus::Idle {
        model: "PR-650".into(),
        measures: "spectrum".into(),
        serial: None,
        port: "/dev/pts/9".into(),
    });
    let (_, body) = send(&h.state, get("/api/health")).await;
    assert_eq!(body["status"], "ok", "{body}");
    assert_eq!(body["measurements"], "accepted", "{body}");
    assert!(body.get("measurements_refused").is_none(), "{body}");
}

/// Regression (issue 46): a verification whose `geometry` had the wrong
/// type (valid JSON) was answered "malformed JSON: expected value"; the
/// answer names the field and the type it takes.
#[tokio::test]
async fn a_wrong_typed_geometry_was_answered_malformed_json() {
    let h = harness(4).await;
    for geometry in ["5", r#"["pie"]"#, "true", "null"] {
        let body = format!(r#"{{"patches": [{{"colour": "original", "geometry": {geometry}, "measurement_id": 1}}]}}"#);
        let (status, v) = send(
            &h.state,
            post(
                "/api/experiments/1/verifications",
                "application/json",
                body,
                Some(TOKEN),
            ),
        )
        .await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{geometry}: {v}");
        let m = error_message(&v);
        assert!(m.starts_with("field `patches[0].geometry`: "), "{geometry}: {m}");
        assert!(!m.contains("malformed") && m.contains("string"), "{geometry}: {m}");
    }
    // What is not JSON is still called so.
    let (status, v) = send(
        &h.state,
        post(
            "/api/experiments/1/verifications",
            "application/json",
            r#"{"patches": [{"geometry": }]}"#,
            Some(TOKEN),
        ),
    )
    .await;
    assert_eq!(status, StatusCode::BAD_REQUEST);
    assert!(error_message(&v).starts_with("malformed JSON"), "{v}");
}

/// Regression (issue 46): `figure.svg?ids=-1` answered 404 where a path id
/// `-1` answers 400; an id in `ids` is plain digits, as in a path.
#[tokio::test]
async fn figure_ids_of_minus_1_answered_404() {
    let h = harness(4).await;
    for (ids, bad) in [
        ("-1", "-1"),
        ("1,-2", "-2"),
        ("%2B3", "+3"),
        ("007", "007"),
        ("1,x", "x"),
    ] {
        let (status, v) = send(&h.state, get(&format!("/api/experiments/figure.svg?ids={ids}"))).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "ids={ids}: {v}");
        let m = error_message(&v);
        assert!(m.contains("`ids`") && m.contains(&format!("`{bad}`")), "ids={ids}: {m}");
    }
}

/// Regression (issue 46): a query key a route does not take was ignored
/// silently on the routes without a query (`/api/health?verbose=1`); every
/// route answers 400 naming the key and the keys it takes.
#[tokio::test]
async fn unknown_query_keys_were_ignored_silently() {
    let h = harness(4).await;
    let (status, v) = send(&h.state, get("/api/health?verbose=1")).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    let m = error_message(&v);
    assert!(m.contains("`verbose`") && m.contains("no query"), "{m}");
    let (status, v) = send(&h.state, get("/api/measurements?limt=5")).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    let m = error_message(&v);
    assert!(
        m.contains("`limt`") && m.contains("`limit`") && m.contains("`offset`"),
        "{m}"
    );
    let (status, v) = send(&h.state, get("/api/experiments/1/analysis?x=1")).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    assert!(error_message(&v).contains("`x`"), "{v}");
    // The keys a route takes are still taken, and the document lists them:
    // `t`, with which pages fetch a changed image again, on image GETs.
    let (_, doc) = send(&h.state, get("/api/openapi.json")).await;
    let spectrum = &doc["paths"]["/api/measurements/{id}/spectrum.svg"]["get"]["parameters"];
    assert!(
        spectrum
            .as_array()
            .unwrap()
            .iter()
            .any(|p| p["name"] == "t" && p["in"] == "query"),
        "{spectrum}"
    );
    let (status, v) = send(&h.state, get("/api/measurements/1/spectrum.svg?t=1765000000")).await;
    assert_eq!(status, StatusCode::NOT_FOUND, "no measurement 1, but `t` is taken: {v}");
    let (status, v) = send(&h.state, get("/api/measurements?limit=5")).await;
    assert_eq!(status, StatusCode::OK, "{v}");
    let (status, v) = send(&h.state, get("/api/health")).await;
    assert_eq!(status, StatusCode::OK, "{v}");
}
