//! The HTTP server's defences against slow and hostile clients: a bounded
//! number of open connections, idle ones given up first when they run
//! short, a bounded number of event streams, and deadlines on a request's
//! head and body.
//!
//! - A connection whose request head (request line and headers) has not
//!   fully arrived within [`ServeLimits::header_timeout`] is closed; this also
//!   closes a keep-alive connection left idle between requests (hyper's
//!   `header_read_timeout`, which starts when it waits for a head).
//! - A request body that has not fully arrived within
//!   [`ServeLimits::body_timeout`] of the head is abandoned: the answer is 408
//!   in the API's JSON error shape, and the connection is closed.
//! - At most [`ServeLimits::max_connections`] connections are served at once
//!   (each holds a file descriptor). When all are taken and another client
//!   connects, the connection that has been open longest **without a request
//!   in progress** (idle keep-alive, or a head still arriving) is closed to
//!   make room; only when every connection is serving a request does the
//!   newcomer wait (in the kernel's listen backlog, one accepted) for a slot.
//!   So a flood of idle or slow-head connections cannot keep an ordinary
//!   request (`/api/health`) waiting: it is served within milliseconds.
//! - Event streams (`/api/events`) are requests that never end, so they are
//!   capped: at most [`ServeLimits::max_event_streams`] at once (a quarter of
//!   the connections by default, keeping the rest for ordinary requests),
//!   and at most [`ServeLimits::max_event_streams_per_client`] from one IP
//!   address. Beyond the cap the answer is 429 (this client holds too many)
//!   or 503 (the daemon holds too many), with `Retry-After`, in the JSON
//!   error shape.
//!
//! `axum::serve` configures none of this, so [`serve_with_limits`] runs the
//! accept loop itself with hyper's HTTP/1 connection builder, and keeps
//! axum's graceful shutdown: on shutdown it stops accepting, asks every
//! connection to finish its current request and close, and waits for them.

use std::collections::{BTreeMap, HashMap};
use std::convert::Infallible;
use std::future::Future;
use std::net::{IpAddr, SocketAddr};
use std::pin::{pin, Pin};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;

use axum::body::{Body, Bytes};
use axum::extract::Request;
use axum::http::{header, Method, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::{Json, Router};
use http_body::{Frame, SizeHint};
use hyper_util::rt::{TokioIo, TokioTimer};
use tokio::net::TcpListener;
use tokio::sync::{watch, Notify, Semaphore};

use super::error::{ErrorBody, ErrorDetail};

/// Bounds on what one client can hold of the server.
#[derive(Clone, Debug)]
pub struct ServeLimits {
    /// Connections served at once; see the module doc for what happens when
    /// they are all taken.
    pub max_connections: usize,
    /// Longest wait for a complete request head, and for the next request on
    /// an idle keep-alive connection.
    pub header_timeout: Duration,
    /// Longest time from a request's head to the end of its body.
    pub body_timeout: Duration,
    /// Event streams (`/api/events`) open at once, from all clients.
    pub max_event_streams: usize,
    /// Event streams open at once from one IP address.
    pub max_event_streams_per_client: usize,
}

impl ServeLimits {
    /// The default limits with `max_connections` connections, of which a
    /// quarter may be event streams, a quarter of those (at least one) from
    /// one client.
    pub fn with_connections(max_connections: usize) -> ServeLimits {
        let max_event_streams = (max_connections / 4).max(1);
        ServeLimits {
            max_connections,
            max_event_streams,
            max_event_streams_per_client: (max_event_streams / 4).max(1),
            ..ServeLimits::default()
        }
    }
}

impl Default for ServeLimits {
    /// 512 connections (half of the usual 1024-descriptor limit, leaving the
    /// rest to the database, the serial port and the renderer's files); 10 s
    /// for a head or a body, which are at most a few kB and 64 KiB; 128 event
    /// streams (a dashboard tab holds one or two), 32 from one address.
    fn default() -> ServeLimits {
        ServeLimits {
            max_connections: 512,
            header_timeout: Duration::from_secs(10),
            body_timeout: Duration::from_secs(10),
            max_event_streams: 128,
            max_event_streams_per_client: 32,
        }
    }
}

/// The address of the client a request came from, as the accept loop saw
/// it (a request extension; absent when the router is called without a
/// socket, as in tests).
#[derive(Clone, Copy, Debug)]
pub struct ClientAddr(pub SocketAddr);

/// What the accept loop knows of one open connection.
#[derive(Default)]
struct Connection {
    /// A request is being served: from its head to the end of its response body.
    in_request: AtomicBool,
    /// Told when the accept loop needs this connection's slot.
    evict: Notify,
}

/// The open connections, oldest first (by accept order).
#[derive(Default)]
struct OpenConnections {
    next: std::sync::atomic::AtomicU64,
    open: Mutex<BTreeMap<u64, Arc<Connection>>>,
}

impl OpenConnections {
    fn add(&self) -> (u64, Arc<Connection>) {
        let id = self.next.fetch_add(1, Ordering::Relaxed);
        let connection = Arc::new(Connection::default());
        lock(&self.open).insert(id, Arc::clone(&connection));
        (id, connection)
    }

    fn remove(&self, id: u64) {
        lock(&self.open).remove(&id);
    }

    /// Tells the oldest connection with no request in progress to close;
    /// false when every connection is serving a request.
    fn evict_oldest_idle(&self) -> bool {
        let open = lock(&self.open);
        match open.values().find(|c| !c.in_request.load(Ordering::Acquire)) {
            Some(c) => {
                c.evict.notify_one();
                true
            }
            None => false,
        }
    }
}

/// A poisoned lock still holds consistent counters (nothing panics while holding one).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Marks its connection busy while it lives (a request's head to the end of
/// its response body).
struct InRequest(Arc<Connection>);

impl InRequest {
    fn new(connection: &Arc<Connection>) -> InRequest {
        connection.in_request.store(true, Ordering::Release);
        InRequest(Arc::clone(connection))
    }
}

impl Drop for InRequest {
    fn drop(&mut self) {
        self.0.in_request.store(false, Ordering::Release);
    }
}

/// A response body that holds `guard` until it is dropped (after its last
/// byte was written, or when the connection ends).
struct Guarded<G> {
    inner: Body,
    _guard: G,
}

impl<G: Send + Unpin + 'static> http_body::Body for Guarded<G> {
    type Data = Bytes;
    type Error = axum::Error;

    fn poll_frame(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Result<Frame<Bytes>, axum::Error>>> {
        Pin::new(&mut self.inner).poll_frame(cx)
    }

    fn is_end_stream(&self) -> bool {
        self.inner.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.inner.size_hint()
    }
}

fn guarded<G: Send + Unpin + 'static>(response: Response, guard: G) -> Response {
    response.map(|inner| Body::new(Guarded { inner, _guard: guard }))
}

/// Serves `router` on `listener` within `limits` until `shutdown` resolves,
/// then lets in-flight requests finish (event streams end on their own when
/// the daemon's shutdown flag turns).
pub async fn serve_with_limits(
    listener: TcpListener,
    router: Router,
    limits: ServeLimits,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let body_timeout = limits.body_timeout;
    let streams = Arc::new(EventStreams::new(&limits));
    let router = router
        .layer(axum::middleware::from_fn(move |req: Request, next: Next| {
            limit_body_time(body_timeout, req, next)
        }))
        .layer(axum::middleware::from_fn(move |req: Request, next: Next| {
            let streams = Arc::clone(&streams);
            async move { streams.limit(req, next).await }
        }));
    let mut builder = hyper::server::conn::http1::Builder::new();
    builder
        .timer(TokioTimer::new())
        .header_read_timeout(limits.header_timeout);
    let slots = Arc::new(Semaphore::new(limits.max_connections.max(1)));
    let connections = Arc::new(OpenConnections::default());
    // Dropping `stop_tx` tells every connection to shut down gracefully;
    // `done_tx.closed()` resolves when every connection has dropped its `done_rx`.
    let (stop_tx, stop_rx) = watch::channel(());
    let (done_tx, done_rx) = watch::channel(());
    let mut shutdown = pin!(shutdown);
    loop {
        let (stream, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(a) => a,
                Err(e) => {
                    // Out of descriptors or memory: wait rather than spin; a
                    // connection reset before accept: just go on.
                    tracing::warn!(error = %e, "cannot accept a connection");
                    if !matches!(
                        e.kind(),
                        std::io::ErrorKind::ConnectionAborted | std::io::ErrorKind::ConnectionReset
                    ) {
                        tokio::time::sleep(Duration::from_millis(200)).await;
                    }
                    continue;
                }
            },
            () = &mut shutdown => break,
        };
        let slot = match Arc::clone(&slots).try_acquire_owned() {
            Ok(slot) => slot,
            Err(_) => {
                // Every slot is taken: free the one idle longest, if any,
                // else wait for a request to finish.
                connections.evict_oldest_idle();
                tokio::select! {
                    slot = Arc::clone(&slots).acquire_owned() => slot.expect("the semaphore is never closed"),
                    () = &mut shutdown => break,
                }
            }
        };
        let (id, connection) = connections.add();
        let router = router.clone();
        let busy = Arc::clone(&connection);
        let service = hyper::service::service_fn(move |req: Request<hyper::body::Incoming>| {
            let in_request = InRequest::new(&busy);
            let mut req = req.map(Body::new);
            req.extensions_mut().insert(ClientAddr(peer));
            let call = tower::ServiceExt::oneshot(router.clone(), req);
            async move {
                let response = call.await?;
                Ok::<_, Infallible>(guarded(response, in_request))
            }
        });
        let builder = builder.clone();
        let mut stop_rx = stop_rx.clone();
        let done_rx = done_rx.clone();
        let connections = Arc::clone(&connections);
        tokio::spawn(async move {
            let mut served = pin!(builder.serve_connection(TokioIo::new(stream), service));
            let result = tokio::select! {
                result = served.as_mut() => result,
                // Needed for a newcomer: close at once (it had no request in progress).
                () = connection.evict.notified() => {
                    tracing::debug!(%peer, "idle connection closed to make room for a new one");
                    Ok(())
                }
                _ = stop_rx.changed() => {
                    served.as_mut().graceful_shutdown();
                    served.await
                }
            };
            if let Err(e) = result {
                tracing::debug!(%peer, error = %e, "connection ended");
            }
            connections.remove(id);
            drop(slot);
            drop(done_rx);
        });
    }
    drop(listener);
    drop(stop_rx);
    drop(stop_tx);
    drop(done_rx);
    done_tx.closed().await;
    Ok(())
}

/// The event streams open now, in all and per client address.
struct EventStreams {
    max: usize,
    max_per_client: usize,
    open: Mutex<(usize, HashMap<IpAddr, usize>)>,
}

/// One open event stream; counted until dropped.
struct EventStreamSlot {
    streams: Arc<EventStreams>,
    client: IpAddr,
}

impl Drop for EventStreamSlot {
    fn drop(&mut self) {
        let mut open = lock(&self.streams.open);
        open.0 = open.0.saturating_sub(1);
        if let Some(n) = open.1.get_mut(&self.client) {
            *n = n.saturating_sub(1);
            if *n == 0 {
                open.1.remove(&self.client);
            }
        }
    }
}

impl EventStreams {
    fn new(limits: &ServeLimits) -> EventStreams {
        EventStreams {
            max: limits.max_event_streams.max(1),
            max_per_client: limits.max_event_streams_per_client.max(1),
            open: Mutex::new((0, HashMap::new())),
        }
    }

    /// Middleware: `GET /api/events` within the caps, else 429 or 503.
    async fn limit(self: Arc<Self>, req: Request, next: Next) -> Response {
        if req.method() != Method::GET || req.uri().path() != "/api/events" {
            return next.run(req).await;
        }
        let client = req
            .extensions()
            .get::<ClientAddr>()
            .map_or(IpAddr::from([0, 0, 0, 0]), |c| c.0.ip());
        let refusal = {
            let mut open = lock(&self.open);
            let of_client = open.1.get(&client).copied().unwrap_or(0);
            if of_client >= self.max_per_client {
                Some((
                    StatusCode::TOO_MANY_REQUESTS,
                    "too_many_requests",
                    format!(
                        "{client} already holds {of_client} event streams (/api/events), the most one client may \
                         hold: close one (another dashboard tab?) and try again"
                    ),
                ))
            } else if open.0 >= self.max {
                Some((
                    StatusCode::SERVICE_UNAVAILABLE,
                    "unavailable",
                    format!(
                        "the daemon already serves {} event streams (/api/events), the most it holds at once \
                         (the rest of its connections are kept for ordinary requests): try again later",
                        open.0
                    ),
                ))
            } else {
                open.0 += 1;
                *open.1.entry(client).or_insert(0) += 1;
                None
            }
        };
        if let Some((status, code, message)) = refusal {
            tracing::warn!(%client, %status, "event stream refused: {message}");
            return (
                status,
                [(header::RETRY_AFTER, "10")],
                Json(ErrorBody {
                    error: ErrorDetail { code, message },
                }),
            )
                .into_response();
        }
        let slot = EventStreamSlot {
            streams: Arc::clone(&self),
            client,
        };
        guarded(next.run(req).await, slot)
    }
}

/// Middleware: the request body must arrive within `timeout`, else 408.
async fn limit_body_time(timeout: Duration, req: Request, next: Next) -> Response {
    let expired = Arc::new(AtomicBool::new(false));
    let req = req.map(|body| {
        Body::new(TimedBody {
            inner: body,
            deadline: Box::pin(tokio::time::sleep(timeout)),
            timeout,
            expired: Arc::clone(&expired),
        })
    });
    let response = next.run(req).await;
    if !expired.load(Ordering::Relaxed) {
        return response;
    }
    tracing::warn!(
        timeout_s = timeout.as_secs_f64(),
        "request body too slow; closing the connection"
    );
    (
        StatusCode::REQUEST_TIMEOUT,
        [(axum::http::header::CONNECTION, "close")],
        Json(ErrorBody {
            error: ErrorDetail {
                code: "request_timeout",
                message: format!(
                    "the request body did not arrive within {} s of its headers",
                    timeout.as_secs_f64()
                ),
            },
        }),
    )
        .into_response()
}

/// A request body that fails once its deadline passes.
struct TimedBody {
    inner: Body,
    deadline: Pin<Box<tokio::time::Sleep>>,
    timeout: Duration,
    expired: Arc<AtomicBool>,
}

/// The error a [`TimedBody`] ends with.
#[derive(Debug, thiserror::Error)]
#[error("the request body did not arrive within {0:?}")]
struct BodyTimeout(Duration);

impl http_body::Body for TimedBody {
    type Data = Bytes;
    type Error = axum::Error;

    fn poll_frame(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Result<Frame<Bytes>, axum::Error>>> {
        let this = &mut *self;
        if let Poll::Ready(frame) = Pin::new(&mut this.inner).poll_frame(cx) {
            return Poll::Ready(frame);
        }
        if this.deadline.as_mut().poll(cx).is_ready() {
            this.expired.store(true, Ordering::Relaxed);
            return Poll::Ready(Some(Err(axum::Error::new(BodyTimeout(this.timeout)))));
        }
        Poll::Pending
    }

    fn is_end_stream(&self) -> bool {
        self.inner.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.inner.size_hint()
    }
}
