//! The HTTP server against slow and hostile clients, on a real loopback
//! socket, and authorisation when the daemon is bound off loopback: header
//! and body read timeouts, a bounded number of connections, graceful
//! shutdown with idle connections open, the dashboard's token on reads, and
//! the bearer scheme's case.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use axum::body::Body;
use axum::http::{Request, StatusCode};
use http_body_util::BodyExt;
use lightbooth::service::{app, serve_with_limits, AppState, InstrumentStatus, ServeLimits, ServiceConfig};
use lightbooth::store::Store;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{broadcast, mpsc, watch};
use tower::ServiceExt;

const TOKEN: &str = "0123456789abcdef0123456789abcdef";

struct Harness {
    state: AppState,
    _jobs: mpsc::Receiver<lightbooth::service::MeasurementJob>,
    _status: watch::Sender<InstrumentStatus>,
    shutdown: watch::Sender<bool>,
    _dir: tempfile::TempDir,
}

async fn harness(loopback_only: bool) -> Harness {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(&format!("sqlite://{}", dir.path().join("api.sqlite").display()))
        .await
        .unwrap();
    let (jobs, jobs_rx) = mpsc::channel(4);
    let (status_tx, status_rx) = watch::channel(InstrumentStatus::Idle {
        model: "PR-650".into(),
        serial: None,
        port: "/dev/pts/9".into(),
    });
    let (events, _) = broadcast::channel(64);
    let (shutdown_tx, shutdown_rx) = watch::channel(false);
    let state = AppState {
        store,
        config: Arc::new(ServiceConfig {
            booth: Default::default(),
            token: TOKEN.into(),
            loopback_only,
            scenes_dir: "scenes".into(),
            codings: vec!["rgb".into(), "spectral".into()],
            instrument: lightbooth::instrument::Pr650Settings::default().capabilities(),
            observer: lightbooth::colorimetry::Observer::JuddVos,
        }),
        jobs,
        status: status_rx,
        events,
        renders: None,
        mock: None,
        measurement_cancel: None,
        shutting_down: shutdown_rx,
    };
    Harness {
        state,
        _jobs: jobs_rx,
        _status: status_tx,
        shutdown: shutdown_tx,
        _dir: dir,
    }
}

/// A server on a loopback port with `limits`; stopped by sending on the returned sender.
struct Server {
    addr: SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<std::io::Result<()>>,
    harness: Harness,
}

async fn start(limits: ServeLimits) -> Server {
    let harness = harness(true).await;
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let task = tokio::spawn(serve_with_limits(listener, harness.state.clone(), limits, async move {
        let _ = stopped.await;
    }));
    Server {
        addr,
        stop: Some(stop),
        task,
        harness,
    }
}

impl Server {
    /// Graceful shutdown, bounded.
    async fn stop(mut self) {
        let _ = self.harness.shutdown.send(true);
        let _ = self.stop.take().unwrap().send(());
        tokio::time::timeout(Duration::from_secs(20), self.task)
            .await
            .expect("graceful shutdown in time")
            .unwrap()
            .unwrap();
    }
}

/// Reads until the server closes the connection; returns what it sent.
async fn read_until_closed(stream: &mut TcpStream) -> Vec<u8> {
    let mut out = Vec::new();
    let mut buf = [0u8; 4096];
    loop {
        match stream.read(&mut buf).await {
            Ok(0) | Err(_) => return out,
            Ok(n) => out.extend_from_slice(&buf[..n]),
        }
    }
}

/// One complete GET on a fresh connection; the status.
async fn get_status(addr: SocketAddr, path: &str) -> u16 {
    let mut s = TcpStream::connect(addr).await.unwrap();
    s.write_all(format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n").as_bytes())
        .await
        .unwrap();
    let raw = read_until_closed(&mut s).await;
    String::from_utf8_lossy(&raw)
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0)
}

/// Connections the server has accepted on `port` and holds open, from the
/// kernel's table: established sockets with that local port and an inode
/// (a connection still in the listen backlog has none).
fn accepted_connections(port: u16) -> usize {
    let table = std::fs::read_to_string("/proc/net/tcp").expect("read /proc/net/tcp");
    table
        .lines()
        .skip(1)
        .filter(|line| {
            let f: Vec<&str> = line.split_whitespace().collect();
            let local_port = f[1].rsplit(':').next().and_then(|p| u16::from_str_radix(p, 16).ok());
            local_port == Some(port) && f[3] == "01" && f[9] != "0"
        })
        .count()
}

fn limits(max_connections: usize) -> ServeLimits {
    ServeLimits {
        max_connections,
        header_timeout: Duration::from_secs(1),
        body_timeout: Duration::from_secs(1),
    }
}

/// Regression: a connection whose request head never arrived was held open forever.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn slow_client_headers_that_never_arrive_are_cut_off_after_the_header_timeout() {
    let server = start(limits(64)).await;
    for partial in [&b""[..], b"GET /api/health HTTP/1.1\r\nHost: x\r\n"] {
        let mut idle = TcpStream::connect(server.addr).await.unwrap();
        idle.write_all(partial).await.unwrap();
        // Bounded: before the fix this waited forever.
        let closed = tokio::time::timeout(Duration::from_secs(10), read_until_closed(&mut idle)).await;
        assert!(
            closed.is_ok(),
            "a connection that sent {partial:?} was still open 10 s later (header timeout 1 s)"
        );
    }
    // A keep-alive connection idle after its first request is closed the same way.
    let mut keep = TcpStream::connect(server.addr).await.unwrap();
    keep.write_all(b"GET /api/health HTTP/1.1\r\nHost: x\r\n\r\n")
        .await
        .unwrap();
    let answer = tokio::time::timeout(Duration::from_secs(10), read_until_closed(&mut keep))
        .await
        .expect("an idle keep-alive connection is closed after the header timeout");
    assert!(
        answer.starts_with(b"HTTP/1.1 200"),
        "{}",
        String::from_utf8_lossy(&answer)
    );
    server.stop().await;
}

/// Regression: a request whose body never arrived held its connection forever.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn slow_client_body_that_never_arrives_gets_408_and_the_connection_closes() {
    let server = start(limits(64)).await;
    let mut s = TcpStream::connect(server.addr).await.unwrap();
    s.write_all(
        format!(
            "POST /api/sessions HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {TOKEN}\r\n\
             Content-Type: application/json\r\nContent-Length: 100\r\n\r\n{{\"operator\":"
        )
        .as_bytes(),
    )
    .await
    .unwrap();
    let raw = tokio::time::timeout(Duration::from_secs(10), read_until_closed(&mut s))
        .await
        .expect("the server gave up on the body and closed the connection");
    let text = String::from_utf8_lossy(&raw);
    assert!(text.starts_with("HTTP/1.1 408"), "{text}");
    assert!(text.contains("\"error\"") && text.contains("body"), "{text}");
    server.stop().await;
}

/// Regression: 1100 idle connections stopped the API (every one held a file
/// descriptor). The server holds at most `max_connections` at once; the rest
/// wait in the listen backlog, and a normal request is still answered once
/// the header timeout has cleared the idle ones.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn many_idle_connections_stay_within_the_limit_and_the_api_still_answers() {
    let max = 50;
    let server = start(limits(max)).await;
    let port = server.addr.port();
    let mut idle = Vec::new();
    for _ in 0..300 {
        idle.push(TcpStream::connect(server.addr).await.unwrap());
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    let held = accepted_connections(port);
    assert!(
        (1..=max).contains(&held),
        "the server holds {held} connections; the limit is {max}"
    );
    // A normal request behind 300 idle connections: answered once the header
    // timeout (1 s) has closed the idle ones ahead of it, batch by batch.
    let status = tokio::time::timeout(Duration::from_secs(30), get_status(server.addr, "/api/health"))
        .await
        .expect("a normal request is answered despite 300 idle connections");
    assert_eq!(status, 200);
    assert!(accepted_connections(port) <= max);
    // Graceful shutdown is not held up by idle connections.
    let _more: Vec<TcpStream> = {
        let mut v = Vec::new();
        for _ in 0..20 {
            v.push(TcpStream::connect(server.addr).await.unwrap());
        }
        v
    };
    drop(idle);
    server.stop().await;
}

async fn send(state: &AppState, req: Request<Body>) -> (StatusCode, String) {
    let response = app(state.clone()).oneshot(req).await.unwrap();
    let status = response.status();
    let bytes = response.into_body().collect().await.unwrap().to_bytes();
    (status, String::from_utf8_lossy(&bytes).into_owned())
}

/// Regression: `Authorization: BEARER x` was refused; the scheme is
/// case-insensitive (RFC 7235 §2.1).
#[tokio::test]
async fn bearer_scheme_in_any_case_is_accepted() {
    let h = harness(false).await;
    for scheme in ["Bearer", "bearer", "BEARER", "bEaReR"] {
        let req = Request::get("/api/measurements")
            .header("authorization", format!("{scheme} {TOKEN}"))
            .body(Body::empty())
            .unwrap();
        let (status, body) = send(&h.state, req).await;
        assert_eq!(status, StatusCode::OK, "{scheme}: {body}");
    }
    for wrong in [format!("Basic {TOKEN}"), format!("Bearer{TOKEN}"), "Bearer".to_string()] {
        let req = Request::get("/api/measurements")
            .header("authorization", wrong.clone())
            .body(Body::empty())
            .unwrap();
        assert_eq!(send(&h.state, req).await.0, StatusCode::UNAUTHORIZED, "{wrong}");
    }
}

/// Regression: bound off loopback, the dashboard's reads (fetches, chart
/// `<img>`s, downloads, the event stream) sent no token and all got 401.
/// The dashboard sends `Authorization: Bearer` on its fetches and keeps the
/// token in a `SameSite=Strict` cookie, which is accepted for reads only:
/// writes still need the header, so a cross-site form cannot write.
#[tokio::test]
async fn off_loopback_dashboard_reads_carry_the_token_and_writes_still_need_the_header() {
    let h = harness(false).await;
    let cookie = format!("other=1; lightbooth_token={TOKEN}");
    for path in ["/api/health", "/api/measurements", "/api/events"] {
        let bare = Request::get(path).body(Body::empty()).unwrap();
        assert_eq!(
            send(&h.state, bare).await.0,
            StatusCode::UNAUTHORIZED,
            "{path} without a token"
        );
        let with_cookie = Request::get(path)
            .header("cookie", &cookie)
            .body(Body::empty())
            .unwrap();
        let response = app(h.state.clone()).oneshot(with_cookie).await.unwrap();
        assert_eq!(response.status(), StatusCode::OK, "{path} with the dashboard's cookie");
    }
    let wrong_cookie = Request::get("/api/measurements")
        .header("cookie", "lightbooth_token=not-the-token-at-all")
        .body(Body::empty())
        .unwrap();
    assert_eq!(send(&h.state, wrong_cookie).await.0, StatusCode::UNAUTHORIZED);
    // The token in a query string is not accepted (it would end up in logs and Referer headers).
    let query = Request::get(format!("/api/measurements?token={TOKEN}"))
        .body(Body::empty())
        .unwrap();
    assert_eq!(send(&h.state, query).await.0, StatusCode::UNAUTHORIZED);
    // A write with only the cookie (what a cross-site form would send) is refused.
    let write = Request::post("/api/sessions")
        .header("cookie", &cookie)
        .header("content-type", "application/json")
        .body(Body::from("{}"))
        .unwrap();
    assert_eq!(send(&h.state, write).await.0, StatusCode::UNAUTHORIZED);
}
