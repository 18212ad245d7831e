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
//! The service never touches the instrument itself: its handlers ask the
//! lab's [`BoothInstrument`] to queue a measurement for the task that owns
//! the instrument, to cancel one, or for that task's live status;
//! everything that happens is broadcast as [`Event`]s.

pub mod auth;
pub mod error;
pub mod hosts;
pub mod image_views;
pub mod input;
pub mod limits;
mod openapi;
mod routes;
mod scene_charts;
mod sse;
mod web;

use std::future::Future;
use std::path::PathBuf;
use std::sync::Arc;

use axum::extract::DefaultBodyLimit;
use axum::Router;
use tokio::net::TcpListener;
use tokio::sync::broadcast;
use tokio_util::sync::CancellationToken;

pub use limits::ServeLimits;

use crate::lab::booth_instrument::BoothInstrument;
use crate::lab::events::Event;
use crate::lab::instrument_queue::MockControl;
use crate::lab::services::RenderService;
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
    /// The observer of every x,y, XYZ, CIELAB and ΔE the service computes or
    /// charts (`serve --observer`; Judd–Vos 1978 by default, the study's).
    pub observer: crate::colorimetry::Observer,
}

/// Shared state of every handler. Cheap to clone: everything is behind an
/// `Arc` or is itself a handle.
#[derive(Clone)]
pub struct AppState {
    pub store: Store,
    pub config: Arc<ServiceConfig>,
    /// The booth's instrument: measurements asked for and cancelled, its
    /// live status, its queue and the calibration's hold.
    pub instrument: BoothInstrument,
    /// Everything that happens, for `/api/events`. Lagging subscribers miss
    /// events (and are told so) rather than slowing the daemon.
    pub events: broadcast::Sender<Event>,
    /// Renders requested through the API (run off the async runtime).
    pub renders: Option<Arc<dyn RenderService>>,
    /// The simulated PR-650, when the daemon runs one.
    pub mock: Option<Arc<dyn MockControl>>,
    /// Turns true when the daemon shuts down: endless responses (the event
    /// stream) end then, so graceful shutdown does not wait on them forever.
    pub shutting_down: CancellationToken,
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
        // Outermost: every answer, refusals included, carries the policy.
        .layer(axum::middleware::map_response(web::security_headers))
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
