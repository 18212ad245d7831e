//! The HTTP side of the daemon: the REST API (for MATLAB scripts and the
//! dashboard), server-sent events, and the dashboards in `web/`.
//!
//! [`app`] builds the router from an [`AppState`] and is what tests call with
//! `tower::ServiceExt::oneshot`, without a socket; [`serve`] runs it on a
//! listener until a shutdown future resolves, within [`ServeLimits`] (a
//! bounded number of connections, idle ones closed first, a bounded number
//! of event streams, deadlines on request heads and bodies). Every request
//! must name a host the daemon answers for ([`hosts`]: no DNS rebinding),
//! and a body announced larger than [`MAX_BODY_BYTES`] is refused before it
//! is read.
//!
//! The service never touches the instrument itself: it queues
//! [`MeasurementJob`]s for the task that owns the instrument and reads that
//! task's live [`InstrumentStatus`]; everything that happens is broadcast as
//! [`Event`]s.

pub mod auth;
pub mod error;
pub mod events;
pub mod hosts;
pub mod image_views;
pub mod input;
pub mod limits;
mod openapi;
mod routes;
mod scene_charts;
mod web;

use std::future::Future;
use std::path::PathBuf;
use std::sync::Arc;

use axum::extract::DefaultBodyLimit;
use axum::Router;
use serde::Serialize;
use tokio::net::TcpListener;
use tokio::sync::{broadcast, mpsc, watch};
use utoipa::ToSchema;

pub use events::Event;
pub use limits::ServeLimits;

use crate::store::Store;

/// Requests larger than this are refused with 413; no legitimate body
/// (a measurement request, a render request) comes near it.
pub const MAX_BODY_BYTES: usize = 64 * 1024;

/// Settings the service needs, fixed at start-up.
#[derive(Clone, Debug)]
pub struct ServiceConfig {
    /// The booth this daemon measures in (`serve --booth`): every measurement
    /// it takes records it.
    pub booth: crate::store::Booth,
    /// The bearer token for writes (and for reads when not on loopback).
    pub token: String,
    /// True when the daemon listens on loopback only: reads need no token.
    pub loopback_only: bool,
    /// The `Host` names requests may use besides `localhost` and loopback
    /// addresses, and the address the daemon listens on (see [`hosts`]).
    pub allowed_hosts: hosts::AllowedHosts,
    /// Where scene files live; nothing outside it is read on a request's behalf.
    pub scenes_dir: PathBuf,
    /// Colour codings rendered for comparisons.
    pub codings: Vec<String>,
    /// What the booth's instrument model can do: its samples per measurement
    /// when a request does not say, and the most it may be asked for.
    pub instrument: crate::instrument::Capabilities,
    /// The observer of every x,y, XYZ, CIELAB and ΔE the service computes or
    /// charts (`serve --observer`; Judd–Vos 1978 by default, the study's).
    pub observer: crate::colorimetry::Observer,
}

/// A measurement for the instrument task to take.
#[derive(Clone, Debug)]
pub struct MeasurementJob {
    pub id: i64,
    pub samples: usize,
    pub scene: Option<String>,
    pub target: Option<String>,
}

/// What the instrument is doing, as the dashboard shows it.
#[derive(Clone, Debug, PartialEq, Serialize, ToSchema)]
#[serde(tag = "state", rename_all = "snake_case")]
pub enum InstrumentStatus {
    /// No port open; `reason` says why and what the daemon is doing about it.
    Disconnected { reason: String },
    Idle {
        model: String,
        serial: Option<String>,
        port: String,
    },
    Measuring {
        measurement_id: i64,
        sample: usize,
        of: usize,
    },
    /// Last operation failed; the daemon will retry.
    Error { message: String },
}

/// Shared state of every handler. Cheap to clone: everything is behind an
/// `Arc` or is itself a handle.
#[derive(Clone)]
pub struct AppState {
    pub store: Store,
    pub config: Arc<ServiceConfig>,
    /// Queue of measurements for the instrument task (bounded: a full queue
    /// answers 409 rather than growing without limit).
    pub jobs: mpsc::Sender<MeasurementJob>,
    /// The instrument task's live status (written only by that task).
    pub status: watch::Receiver<InstrumentStatus>,
    /// Everything that happens, for `/api/events`. Lagging subscribers miss
    /// events (and are told so) rather than slowing the daemon.
    pub events: broadcast::Sender<Event>,
    /// Renders requested through the API (run off the async runtime).
    pub renders: Option<Arc<dyn RenderService>>,
    /// The simulated PR-650, when the daemon runs one.
    pub mock: Option<Arc<dyn MockControl>>,
    /// Stops the running measurement (the instrument task's; None without one).
    pub measurement_cancel: Option<Arc<dyn CancelMeasurement>>,
    /// Turns true when the daemon shuts down: endless responses (the event
    /// stream) end then, so graceful shutdown does not wait on them forever.
    pub shutting_down: watch::Receiver<bool>,
}

/// A boxed future, for the async methods of the traits below.
pub type BoxFuture<T> = std::pin::Pin<Box<dyn Future<Output = T> + Send>>;

/// The renderer as the service sees it; the daemon provides it.
pub trait RenderService: Send + Sync {
    /// The scenes available under `scenes_dir`, in the study's order.
    fn scenes(&self) -> Vec<SceneInfo>;
    /// Records a render of a scene and starts it; resolves to its id at once.
    fn start_render(self: Arc<Self>, scene: String, request: RenderRequest) -> BoxFuture<Result<i64, error::ApiError>>;
    /// Checks a study request field by field without starting anything.
    fn check_study(&self, request: &StudyRequest) -> Result<(), error::ApiError>;
    /// Records a study and starts it in the background; resolves to its id at once.
    fn start_study(self: Arc<Self>, request: StudyRequest) -> BoxFuture<Result<i64, error::ApiError>>;
    /// Cancels a queued or running render or study (409 once it has ended).
    fn cancel(self: Arc<Self>, job: crate::store::Job, id: i64) -> BoxFuture<Result<(), error::ApiError>>;
    /// Queues a new render or study with the request of an interrupted,
    /// failed or cancelled one; resolves to the new id.
    fn retry(self: Arc<Self>, job: crate::store::Job, id: i64) -> BoxFuture<Result<i64, error::ApiError>>;
    /// Queues a camera image of a render (or finds the one already made
    /// with the same settings); resolves to its id and whether it was reused.
    fn start_image(
        self: Arc<Self>,
        _render_id: i64,
        _request: crate::daemon::images::ImageRequest,
    ) -> BoxFuture<Result<(i64, bool), error::ApiError>> {
        Box::pin(async {
            Err(error::ApiError::Unavailable(
                "this daemon renders no camera images".into(),
            ))
        })
    }
    /// The camera images this daemon keeps (see `daemon::images`); `None`
    /// when it renders none.
    fn images(&self) -> Option<&crate::daemon::images::ImageJobs> {
        None
    }
    /// The CIELAB white of a scene in a booth now, with its source (see
    /// `daemon::renders`).
    fn cielab_white(
        self: Arc<Self>,
        _scene: String,
        _booth: crate::store::Booth,
    ) -> BoxFuture<Result<(crate::colorimetry::Xyz, String), error::ApiError>> {
        Box::pin(async { Err(error::ApiError::Unavailable("this daemon has no scenes".into())) })
    }
}

/// Options of a study started through the API (see `lightbooth study`).
#[derive(Clone, Debug, Default, serde::Deserialize, Serialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct StudyRequest {
    /// Comma-separated scene ids, each named once, at most 64
    /// (`routes::MAX_STUDY_SCENES`); default: every scene.
    pub scenes: Option<String>,
    /// `measurements` (default) or `reference` (a converged spectral rendering).
    pub against: Option<String>,
    /// Seeds, 1–64 (default 8).
    #[schema(minimum = 1, maximum = 64)]
    pub seeds: Option<u32>,
    /// Also sweep samples, bounces and N for the speed-against-accuracy chart.
    pub sweeps: Option<bool>,
    /// Also compute the failure maps.
    pub failure_map: Option<bool>,
    /// Also choose per scene the cheapest settings meeting this tolerance, e.g. `de00=1,rms=0.02`.
    pub auto: Option<String>,
    /// Against measurements: first measure, through the instrument queue,
    /// every target of the chosen scenes that has no complete measurement;
    /// the study waits for them (reporting progress), then runs. Without it,
    /// a study missing measurements is refused with 409 naming them.
    pub measure_missing: Option<bool>,
    /// The measurements queued for this study by `measure_missing` (set by the daemon).
    #[serde(skip_deserializing, default, skip_serializing_if = "Vec::is_empty")]
    #[schema(read_only)]
    pub measured_first: Vec<i64>,
}

/// Stopping a running measurement; the instrument task provides it.
pub trait CancelMeasurement: Send + Sync {
    /// Asks measurement `id` to stop at once: between instrument commands, or
    /// within a poll slice of a reply being read, so at most the sample in
    /// progress is lost. False when `id` is not the measurement the
    /// instrument has taken (it is still queued, or already finished).
    fn cancel(&self, id: i64) -> bool;
}

/// Fault injection into the simulated PR-650 (`serve --mock` only).
pub trait MockControl: Send + Sync {
    /// `KIND[@DELAY][:RATE]`, comma-separated (see `lightbooth serve --help`); empty clears.
    fn set_faults(&self, spec: &str) -> Result<(), String>;
    /// Shows drives 0–1 per channel on the simulated display
    /// ([`crate::display::SimulatedDisplay`]) the simulated PR-650 is aimed
    /// at: what it measures until a measurement names a scene target.
    fn show_on_display(&self, drive: [f64; 3]) -> Result<(), String>;
}

/// A scene as the API lists it.
#[derive(Clone, Debug, Serialize, ToSchema)]
pub struct SceneInfo {
    pub id: String,
    pub title: String,
    pub targets: Vec<String>,
}

/// Options of a render request.
#[derive(Clone, Debug, Default, serde::Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RenderRequest {
    /// Comma-separated codings, e.g. `rgb,srgb,nstep3,spectral`; default: the daemon's.
    pub codings: Option<String>,
    /// Radiometer paths per target, 2–4194304 (`daemon::jobs::MAX_RENDER_SAMPLES`:
    /// two paths at least for a standard error; the renderer's own cap on
    /// adaptive sampling at most).
    #[schema(minimum = 2, maximum = 4_194_304)]
    pub samples: Option<u32>,
    /// A cap on indirect bounces, 0–64 (`daemon::jobs::MAX_RENDER_BOUNCES`;
    /// 5 emulates RADIANCE `-ab 5`). Absent: no cap, Russian roulette ends
    /// the paths (unbiased). A capped render's result says so:
    /// `truncated_at_bounces` (`null` when uncapped) and `truncation_note`.
    #[schema(minimum = 0, maximum = 64)]
    pub bounces: Option<u32>,
    pub seed: Option<u64>,
}

/// The whole HTTP application.
pub fn app(state: AppState) -> Router {
    let api = Router::from(routes::api_router())
        .method_not_allowed_fallback(error::method_not_allowed)
        .layer(axum::middleware::from_fn_with_state(state.clone(), auth::require_token))
        .layer(DefaultBodyLimit::max(MAX_BODY_BYTES));
    Router::new()
        .nest("/api", api)
        .merge(web::router())
        .fallback(error::no_route)
        .layer(axum::middleware::map_response(error::json_error_bodies))
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            hosts::require_known_host,
        ))
        .layer(axum::middleware::from_fn(error::refuse_oversized_head))
        .with_state(state)
}

/// Serves `app(state)` on `listener` with the default [`ServeLimits`] until
/// `shutdown` resolves, then lets in-flight requests finish.
pub async fn serve(
    listener: TcpListener,
    state: AppState,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    serve_with_limits(listener, state, ServeLimits::default(), shutdown).await
}

/// [`serve`] with explicit limits on connections and on slow clients (see [`limits`]).
pub async fn serve_with_limits(
    listener: TcpListener,
    state: AppState,
    limits: ServeLimits,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    limits::serve_with_limits(listener, app(state), limits, shutdown).await
}
