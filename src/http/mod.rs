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
//! The service never touches the instrument, the renderer or the store
//! itself: its handlers call the methods of the [`LabHandle`] (which asks
//! the task that owns the instrument to queue or cancel a measurement,
//! queues renders and studies, and reads the records), and turn its
//! answers and refusals into responses; everything that happens is
//! broadcast as [`Event`]s.

pub mod auth;
pub mod error;
pub mod hosts;
pub mod input;
mod kept;
pub mod limits;
mod openapi;
mod routes;
mod sse;
mod web;

use std::future::Future;
use std::sync::Arc;

use axum::extract::DefaultBodyLimit;
use axum::Router;
use tokio::net::TcpListener;
use tokio_util::sync::CancellationToken;

pub use limits::ServeLimits;

use crate::lab::events::EventSink;
use crate::lab::measure::queue::MockControl;
use crate::lab::LabHandle;

/// Requests larger than this are refused with 413; no legitimate body
/// (a measurement request, a render request) comes near it.
pub const MAX_BODY_BYTES: usize = 64 * 1024;

/// Settings the service needs, fixed at start-up.
#[derive(Clone, Debug)]
pub struct ServiceConfig {
    /// The bearer token for writes (and for reads when not on loopback).
    pub token: String,
    /// True when the daemon listens on loopback only: reads need no token.
    pub loopback_only: bool,
    /// The `Host` names requests may use besides `localhost` and loopback
    /// addresses, and the address the daemon listens on (see [`hosts`]).
    pub allowed_hosts: hosts::AllowedHosts,
}

/// Shared state of every handler. Cheap to clone: everything is behind an
/// `Arc` or is itself a handle.
#[derive(Clone)]
pub struct AppState {
    /// The lab: the booth (`serve --booth`) and its instrument, the renders,
    /// the experiments, every record, and the observer of every colour
    /// (`serve --observer`); the handlers' one way to all of them.
    pub lab: LabHandle,
    pub config: Arc<ServiceConfig>,
    /// Everything that happens, for `/api/events`. Lagging subscribers miss
    /// events (and are told so) rather than slowing the daemon.
    pub events: EventSink,
    /// The simulated PR-650, when the daemon runs one.
    pub mock: Option<Arc<dyn MockControl>>,
    /// Turns true when the daemon shuts down: endless responses (the event
    /// stream) end then, so graceful shutdown does not wait on them forever.
    pub shutting_down: CancellationToken,
}

/// The whole HTTP application.
pub fn app(state: AppState) -> Router {
    let api = Router::from(routes::api_router())
        .route_layer(axum::middleware::from_fn(input::refuse_unknown_query_keys))
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
