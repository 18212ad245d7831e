//! The dashboards in `web/`, compiled into the binary. Requests are matched
//! against this fixed table, so no path from a request reaches the
//! filesystem.
//!
//! Every response of the daemon carries [`CONTENT_SECURITY_POLICY`]
//! ([`security_headers`]): scripts only from the daemon's own files, never
//! inline, never from an event-handler attribute or a `javascript:` URL, and
//! no string may become HTML through `innerHTML` (Trusted Types with no
//! policy). The pages write stored and requested text (profile, experiment
//! and scene names, notes) as text nodes only; the policy is the second
//! line, so that one text written as HTML by mistake cannot run code that
//! reads the write token from `localStorage`.

use axum::extract::Path;
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use axum::Router;

use super::AppState;

const INDEX: &str = include_str!("../../web/index.html");
/// The pages' icon, also answered for `/favicon.ico` (browsers ask for it).
const FAVICON_SVG: &str = include_str!("../../web/favicon.svg");
/// The display calibration page, opened full-screen on the stimulus monitor.
const CALIBRATE_HTML: &str = include_str!("../../web/calibrate.html");
/// Experiments: set one up, its colours on the display, its results.
const EXPERIMENT_HTML: &str = include_str!("../../web/experiment.html");
/// An experiment's session, full-screen on the stimulus display.
const EXPERIMENT_RUN_HTML: &str = include_str!("../../web/experiment-run.html");
/// Stimulus sets: a rendered image's codings as the display will show them.
const STIMULUS_SET_HTML: &str = include_str!("../../web/stimulus-set.html");

/// The pages' scripts and style sheet, each served at its path. The
/// scripts are ES modules (`<script type="module">`, `import … from
/// "./shared.js"`), served as `text/javascript`: a browser refuses a module
/// of another type (and, with `nosniff`, any script). Each page loads one
/// entry module (the index `app.js`, `calibrate.js`, `experiment.js`,
/// `experiment-run.js`, `stimulus-set.js`), which imports the rest; `script-src 'self'` allows
/// them all.
const FILES: [(&str, &str); 14] = [
    // The index page's entry: Live, Measurements, Scenes, Study; routes the views.
    ("/app.js", include_str!("../../web/app.js")),
    // The home page: the instrument, the queue, the booth, what to do next.
    ("/home.js", include_str!("../../web/home.js")),
    // The "measure a material" view (reflectance against a white standard).
    ("/material.js", include_str!("../../web/material.js")),
    // The image viewer view.
    ("/viewer.js", include_str!("../../web/viewer.js")),
    // The navigation bar and instrument badge every page shares.
    ("/nav.js", include_str!("../../web/nav.js")),
    // What every page shares: `$`, the token, `api`, the notice, the read
    // cookie, the event stream, and the pure formatting helpers.
    ("/shared.js", include_str!("../../web/shared.js")),
    // Measuring what a page shows under an instrument hold (calibration,
    // experiment sessions).
    ("/measure.js", include_str!("../../web/measure.js")),
    // A session's timing and geometry arithmetic (frames, the pie).
    ("/trial.js", include_str!("../../web/trial.js")),
    ("/calibrate.js", include_str!("../../web/calibrate.js")),
    ("/experiment.js", include_str!("../../web/experiment.js")),
    ("/experiment-run.js", include_str!("../../web/experiment-run.js")),
    // Linear RGB drawn as the display gets it (profile γ, output method),
    // shared by the session page and the stimulus-set page.
    ("/display-gl.js", include_str!("../../web/display-gl.js")),
    ("/stimulus-set.js", include_str!("../../web/stimulus-set.js")),
    ("/style.css", include_str!("../../web/style.css")),
];

/// MATLAB examples, served under `/matlab/`, each with its GNU Octave
/// version (`*_octave.m`, run by `tests/api/octave_examples.rs`).
const MATLAB: [(&str, &str); 8] = [
    (
        "list_measurements.m",
        include_str!("../../web/matlab/list_measurements.m"),
    ),
    (
        "list_measurements_octave.m",
        include_str!("../../web/matlab/list_measurements_octave.m"),
    ),
    (
        "measure_and_poll.m",
        include_str!("../../web/matlab/measure_and_poll.m"),
    ),
    (
        "measure_and_poll_octave.m",
        include_str!("../../web/matlab/measure_and_poll_octave.m"),
    ),
    (
        "fetch_comparison.m",
        include_str!("../../web/matlab/fetch_comparison.m"),
    ),
    (
        "fetch_comparison_octave.m",
        include_str!("../../web/matlab/fetch_comparison_octave.m"),
    ),
    (
        "oddity_experiment.m",
        include_str!("../../web/matlab/oddity_experiment.m"),
    ),
    (
        "oddity_experiment_octave.m",
        include_str!("../../web/matlab/oddity_experiment_octave.m"),
    ),
];

/// The daemon's Content-Security-Policy, on every response. `script-src
/// 'self'` forbids inline `<script>`, `on…=` attributes and `javascript:`
/// URLs; `require-trusted-types-for 'script'` with no Trusted Types policy
/// makes a browser that supports it refuse any string assigned to
/// `innerHTML`, `outerHTML`, `insertAdjacentHTML` or `document.write`.
/// Styles may be inline (the pages' `<style>` blocks and `style`
/// attributes); images are the daemon's own (charts, camera views) or
/// `data:`; nothing may frame the pages.
pub const CONTENT_SECURITY_POLICY: &str = "default-src 'self'; script-src 'self'; object-src 'none'; \
     base-uri 'none'; form-action 'self'; frame-ancestors 'none'; img-src 'self' data:; \
     style-src 'self' 'unsafe-inline'; require-trusted-types-for 'script'; trusted-types 'none'";

/// Adds [`CONTENT_SECURITY_POLICY`] (and `nosniff`, no referrer) to a response.
pub async fn security_headers(mut response: Response) -> Response {
    let headers = response.headers_mut();
    headers.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(CONTENT_SECURITY_POLICY),
    );
    headers.insert(header::X_CONTENT_TYPE_OPTIONS, HeaderValue::from_static("nosniff"));
    headers.insert(header::REFERRER_POLICY, HeaderValue::from_static("no-referrer"));
    response
}

/// The `Content-Type` of a file of [`FILES`], by its extension.
fn content_type(path: &str) -> &'static str {
    if path.ends_with(".css") {
        "text/css; charset=utf-8"
    } else {
        "text/javascript; charset=utf-8"
    }
}

pub fn router() -> Router<AppState> {
    let mut router = Router::new()
        .route("/", get(|| async { Html(INDEX) }))
        .route("/favicon.svg", get(favicon))
        .route("/favicon.ico", get(favicon))
        .route("/calibrate", get(|| async { Html(CALIBRATE_HTML) }))
        .route("/experiment", get(|| async { Html(EXPERIMENT_HTML) }))
        .route("/experiment/{id}", get(|| async { Html(EXPERIMENT_HTML) }))
        .route("/experiment/{id}/run", get(|| async { Html(EXPERIMENT_RUN_HTML) }))
        .route("/stimulus-sets", get(|| async { Html(STIMULUS_SET_HTML) }))
        .route("/stimulus-sets/{id}", get(|| async { Html(STIMULUS_SET_HTML) }))
        .route("/matlab/", get(matlab_index))
        .route("/matlab/{file}", get(matlab_file));
    for (path, body) in FILES {
        router = router.route(
            path,
            get(move || async move { ([(header::CONTENT_TYPE, content_type(path))], body) }),
        );
    }
    router
}

async fn favicon() -> impl IntoResponse {
    (
        [
            (header::CONTENT_TYPE, "image/svg+xml"),
            (header::CACHE_CONTROL, "max-age=86400"),
        ],
        FAVICON_SVG,
    )
}

async fn matlab_index() -> Html<String> {
    let items: String = MATLAB
        .iter()
        .map(|(n, _)| format!("<li><a href=\"/matlab/{n}\">{n}</a></li>"))
        .collect();
    Html(format!(
        "<!doctype html><title>MATLAB and GNU Octave examples</title><h1>MATLAB and GNU Octave examples</h1>\
         <p>Each <code>NAME.m</code> needs MATLAB R2016b or later; <code>NAME_octave.m</code> is the same in GNU Octave 6 or later.</p><ul>{items}</ul>"
    ))
}

async fn matlab_file(Path(file): Path<String>) -> Response {
    match MATLAB.iter().find(|(n, _)| *n == file) {
        Some((_, text)) => ([(header::CONTENT_TYPE, "text/plain; charset=utf-8")], *text).into_response(),
        None => (StatusCode::NOT_FOUND, "no such MATLAB example").into_response(),
    }
}
