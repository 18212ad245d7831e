//! The HTTP server's defences against slow and hostile clients: a bounded
//! number of open connections, and deadlines on a request's head and body.
//!
//! - A connection whose request head (request line and headers) has not
//!   fully arrived within [`ServeLimits::header_timeout`] is closed; this also
//!   closes a keep-alive connection left idle between requests (hyper's
//!   `header_read_timeout`, which starts when it waits for a head).
//! - A request body that has not fully arrived within
//!   [`ServeLimits::body_timeout`] of the head is abandoned: the answer is 408
//!   in the API's JSON error shape, and the connection is closed.
//! - At most [`ServeLimits::max_connections`] connections are served at once
//!   (each holds a file descriptor); further ones wait in the kernel's listen
//!   backlog until a slot frees, instead of exhausting the process's
//!   descriptors. With the timeouts, every slot frees within a bounded time
//!   unless its client is really talking (an event stream stays open).
//!
//! `axum::serve` configures none of this, so [`serve_with_limits`] runs the
//! accept loop itself with hyper's HTTP/1 connection builder, and keeps
//! axum's graceful shutdown: on shutdown it stops accepting, asks every
//! connection to finish its current request and close, and waits for them.

use std::future::Future;
use std::pin::{pin, Pin};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;

use axum::body::{Body, Bytes};
use axum::extract::Request;
use axum::http::StatusCode;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::{Json, Router};
use http_body::{Frame, SizeHint};
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;
use tokio::sync::{watch, Semaphore};

use super::error::{ErrorBody, ErrorDetail};

/// Bounds on what one client can hold of the server.
#[derive(Clone, Debug)]
pub struct ServeLimits {
    /// Connections served at once; more wait in the listen backlog.
    pub max_connections: usize,
    /// Longest wait for a complete request head, and for the next request on
    /// an idle keep-alive connection.
    pub header_timeout: Duration,
    /// Longest time from a request's head to the end of its body.
    pub body_timeout: Duration,
}

impl Default for ServeLimits {
    /// 512 connections (half of the usual 1024-descriptor limit, leaving the
    /// rest to the database, the serial port and the renderer's files); 10 s
    /// for a head or a body, which are at most a few kB and 64 KiB.
    fn default() -> ServeLimits {
        ServeLimits {
            max_connections: 512,
            header_timeout: Duration::from_secs(10),
            body_timeout: Duration::from_secs(10),
        }
    }
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
    let router = router.layer(axum::middleware::from_fn(move |req: Request, next: Next| {
        limit_body_time(body_timeout, req, next)
    }));
    let mut builder = hyper::server::conn::http1::Builder::new();
    builder
        .timer(TokioTimer::new())
        .header_read_timeout(limits.header_timeout);
    let slots = Arc::new(Semaphore::new(limits.max_connections.max(1)));
    // Dropping `stop_tx` tells every connection to shut down gracefully;
    // `done_tx.closed()` resolves when every connection has dropped its `done_rx`.
    let (stop_tx, stop_rx) = watch::channel(());
    let (done_tx, done_rx) = watch::channel(());
    let mut shutdown = pin!(shutdown);
    loop {
        let slot = tokio::select! {
            slot = Arc::clone(&slots).acquire_owned() => slot.expect("the semaphore is never closed"),
            () = &mut shutdown => break,
        };
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
        let service = TowerToHyperService::new(router.clone());
        let builder = builder.clone();
        let mut stop_rx = stop_rx.clone();
        let done_rx = done_rx.clone();
        tokio::spawn(async move {
            let mut connection = pin!(builder.serve_connection(TokioIo::new(stream), service));
            let result = tokio::select! {
                result = connection.as_mut() => result,
                _ = stop_rx.changed() => {
                    connection.as_mut().graceful_shutdown();
                    connection.await
                }
            };
            if let Err(e) = result {
                tracing::debug!(%peer, error = %e, "connection ended");
            }
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
