//! The REST API through `app(state)` with `oneshot`, no socket: statuses,
//! error bodies, authorisation, both body encodings. The instrument side is
//! the job queue and status channel the real instrument task uses; here the
//! test plays that task.

use std::sync::Arc;

use axum::body::Body;
use axum::http::{Request, StatusCode};
use http_body_util::BodyExt;
use lightbooth::service::{app, AppState, InstrumentStatus, MeasurementJob, ServiceConfig};
use lightbooth::store::Store;
use serde_json::Value;
use tokio::sync::{broadcast, mpsc, watch};
use tower::ServiceExt;

const TOKEN: &str = "0123456789abcdef0123456789abcdef";

struct Harness {
    state: AppState,
    jobs: mpsc::Receiver<MeasurementJob>,
    status: watch::Sender<InstrumentStatus>,
    _shutdown: watch::Sender<bool>,
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
        serial: Some("60931502".into()),
        port: "/dev/pts/9".into(),
    });
    let (events, _) = broadcast::channel(64);
    let (shutdown_tx, shutdown_rx) = watch::channel(false);
    let state = AppState {
        store,
        config: Arc::new(ServiceConfig {
            token: TOKEN.into(),
            loopback_only: true,
            scenes_dir: "scenes".into(),
            codings: vec!["rgb".into(), "spectral".into()],
            default_samples: 5,
            observer: lightbooth::colorimetry::Observer::JuddVos,
        }),
        jobs: tx,
        status: status_rx,
        events,
        renders: None,
        mock: None,
        shutting_down: shutdown_rx,
    };
    Harness {
        state,
        jobs: rx,
        status: status_tx,
        _shutdown: shutdown_tx,
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
    let huge = format!(
        "{{\"note\": \"{}\"}}",
        "x".repeat(lightbooth::service::MAX_BODY_BYTES + 1)
    );
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
    assert_eq!(samples["maximum"], 99, "{samples}");
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
    assert_eq!(render["samples"]["maximum"], 16_777_216, "{render}");
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
