//! The HTTP server against slow and hostile clients, on a real loopback
//! socket, and authorisation when the daemon is bound off loopback: header
//! and body read timeouts, a bounded number of connections (idle ones given
//! up first), capped event streams, graceful shutdown with idle connections
//! open, the dashboard's read-only cookie, the bearer scheme's case, the
//! `Host` check against DNS rebinding, and bodies announced too large.

use crate::common;

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use axum::body::Body;
use axum::http::{Request, StatusCode};
use http_body_util::BodyExt;
use lightbooth::http::{app, serve_with_limits, AppState, ServeLimits, ServiceConfig};
use lightbooth::lab::measure::booth_instrument::BoothInstrument;
use lightbooth::lab::measure::queue::InstrumentStatus;
use lightbooth::lab::LabHandle;
use lightbooth::store::Store;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpSocket, TcpStream};
use tokio::sync::{mpsc, watch};
use tokio_util::sync::CancellationToken;
use tower::ServiceExt;

const TOKEN: &str = "0123456789abcdef0123456789abcdef";

struct Harness {
    state: AppState,
    _jobs: mpsc::Receiver<lightbooth::lab::measure::queue::MeasurementJob>,
    _status: watch::Sender<InstrumentStatus>,
    shutdown: CancellationToken,
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
        measures: "spectrum".into(),
        serial: None,
        port: "/dev/pts/9".into(),
    });
    let events = lightbooth::lab::events::EventSink::bus(64);
    let shutdown = CancellationToken::new();
    let instrument = BoothInstrument::new(
        store.clone(),
        jobs,
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
            loopback_only,
            allowed_hosts: Default::default(),
        }),
        events,
        mock: None,
        shutting_down: shutdown.clone(),
    };
    Harness {
        state,
        _jobs: jobs_rx,
        _status: status_tx,
        shutdown,
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
        self.harness.shutdown.cancel();
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
        header_timeout: Duration::from_secs(1),
        body_timeout: Duration::from_secs(1),
        ..ServeLimits::with_connections(max_connections)
    }
}

/// Regression: a connection whose request head never arrived was held open forever.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn slow_client_headers_that_never_arrive_are_cut_off_after_the_header_timeout() {
    let server = start(limits(64)).await;
    for partial in [&b""[..], b"GET /api/health HTTP/1.1\r\nHost: localhost\r\n"] {
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
    keep.write_all(b"GET /api/health HTTP/1.1\r\nHost: localhost\r\n\r\n")
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
            "POST /api/sessions HTTP/1.1\r\nHost: localhost\r\nAuthorization: Bearer {TOKEN}\r\n\
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

/// The read-only cookie the daemon sets for `POST /api/read-cookie` with the write token.
async fn read_cookie(state: &AppState) -> (String, String) {
    let req = Request::post("/api/read-cookie")
        .header("authorization", format!("Bearer {TOKEN}"))
        .body(Body::empty())
        .unwrap();
    let response = app(state.clone()).oneshot(req).await.unwrap();
    assert_eq!(response.status(), StatusCode::NO_CONTENT);
    let set = response.headers()["set-cookie"].to_str().unwrap().to_string();
    let pair = set.split(';').next().unwrap().to_string();
    (set, pair)
}

/// Regression: bound off loopback, the dashboard's reads (fetches, chart
/// `<img>`s, downloads, the event stream) sent no token and all got 401.
/// The dashboard sends `Authorization: Bearer` on its fetches and gets a
/// read-only cookie for the rest, accepted for reads only: writes still
/// need the header, so a cross-site form cannot write.
#[tokio::test]
async fn off_loopback_dashboard_reads_carry_the_token_and_writes_still_need_the_header() {
    let h = harness(false).await;
    let (_, pair) = read_cookie(&h.state).await;
    let cookie = format!("other=1; {pair}");
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
        .header("cookie", "lightbooth_read=not-the-token-at-all")
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

/// Regression: the dashboard kept the write token in the cookie
/// `lightbooth_token` (path /api); cookies are not bound to a port, so every
/// other web service on the host under /api received the write token. The
/// cookie now holds a read-only token: never the write token, never a
/// write, and the write token is no longer accepted from a cookie.
#[tokio::test]
async fn write_token_leaks_via_cookie_no_more_and_the_read_cookie_cannot_write() {
    let h = harness(false).await;
    let (set, pair) = read_cookie(&h.state).await;
    assert!(!set.contains(TOKEN), "the write token is in Set-Cookie: {set}");
    for attribute in ["Path=/api", "HttpOnly", "SameSite=Strict"] {
        assert!(set.contains(attribute), "{attribute} missing: {set}");
    }
    let (name, read) = pair.split_once('=').unwrap();
    assert!(name.starts_with("lightbooth_read"), "{name}");
    assert_eq!(read.len(), 64);
    // Getting the cookie needs the write token in the header.
    let bare = Request::post("/api/read-cookie").body(Body::empty()).unwrap();
    assert_eq!(send(&h.state, bare).await.0, StatusCode::UNAUTHORIZED);
    // The write token sent as the old cookie no longer opens anything.
    let old = Request::get("/api/measurements")
        .header("cookie", format!("lightbooth_token={TOKEN}"))
        .body(Body::empty())
        .unwrap();
    assert_eq!(send(&h.state, old).await.0, StatusCode::UNAUTHORIZED);
    // A request carrying only the read cookie, or the read token as a bearer, cannot write.
    for (header, value) in [("cookie", pair.clone()), ("authorization", format!("Bearer {read}"))] {
        for (path, body) in [("/api/sessions", "{}"), ("/api/measurements", r#"{"samples":2}"#)] {
            let write = Request::post(path)
                .header(header, &value)
                .header("content-type", "application/json")
                .body(Body::from(body))
                .unwrap();
            let (status, text) = send(&h.state, write).await;
            assert_eq!(status, StatusCode::UNAUTHORIZED, "{header} on POST {path}: {text}");
        }
    }
    // A cookie named after the write token's value is not the read token either.
    let forged = Request::get("/api/measurements")
        .header("cookie", format!("{name}={TOKEN}"))
        .body(Body::empty())
        .unwrap();
    assert_eq!(send(&h.state, forged).await.0, StatusCode::UNAUTHORIZED);
}

/// One raw request with `Host: host`; the status and the whole answer.
async fn raw_with_host(addr: SocketAddr, path: &str, host: &str) -> (u16, String) {
    let mut s = TcpStream::connect(addr).await.unwrap();
    s.write_all(format!("GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n").as_bytes())
        .await
        .unwrap();
    let raw = String::from_utf8_lossy(&read_until_closed(&mut s).await).into_owned();
    let status = raw.split_whitespace().nth(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    (status, raw)
}

/// Regression: on loopback, `Host: attacker.example` read every measurement,
/// so a DNS-rebinding page in the operator's browser could too. Only the
/// daemon's own addresses, `localhost` names and the allow-list are answered.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn host_header_unchecked_on_loopback_lets_dns_rebinding_read() {
    let d = common::Daemon::start(0.0).await;
    let port = d.addr.port();
    for host in [
        "attacker.example",
        &format!("attacker.example:{port}"),
        "localhost.attacker.example",
    ] {
        for path in ["/api/measurements", "/api/events", "/"] {
            let (status, raw) = raw_with_host(d.addr, path, host).await;
            assert_eq!(status, 421, "Host {host} on {path}: {raw}");
            assert!(
                raw.contains("misdirected_request")
                    && raw.contains("attacker.example")
                    && raw.contains("--allowed-host"),
                "{raw}"
            );
        }
    }
    for host in [
        format!("127.0.0.1:{port}"),
        format!("localhost:{port}"),
        "localhost".into(),
        format!("[::1]:{port}"),
    ] {
        let (status, raw) = raw_with_host(d.addr, "/api/measurements", &host).await;
        assert_eq!(status, 200, "Host {host}: {raw}");
    }
    d.stop().await;
    // A name of the allow-list is answered (the daemon's own check, without a socket).
    let mut h = harness(true).await;
    let mut config = (*h.state.config).clone();
    config.allowed_hosts =
        lightbooth::http::hosts::AllowedHosts::new("127.0.0.1:8650".parse().unwrap(), &["booth1.lab".into()]).unwrap();
    h.state.config = Arc::new(config);
    for (host, expected) in [
        ("booth1.lab:8650", StatusCode::OK),
        ("booth2.lab:8650", StatusCode::MISDIRECTED_REQUEST),
    ] {
        let req = Request::get("/api/measurements")
            .header("host", host)
            .body(Body::empty())
            .unwrap();
        assert_eq!(send(&h.state, req).await.0, expected, "{host}");
    }
}

/// Regression: a 1 GB `Content-Length` waited 10 s (the body timeout) for
/// a 408; it is refused with 413 before any of the body is read.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_1_gb_content_length_waits_for_a_408_instead_of_an_immediate_413() {
    let server = start(limits(16)).await;
    let mut s = TcpStream::connect(server.addr).await.unwrap();
    s.write_all(
        format!(
            "POST /api/sessions HTTP/1.1\r\nHost: {}\r\nAuthorization: Bearer {TOKEN}\r\n\
             Content-Type: application/json\r\nContent-Length: 1000000000\r\n\r\n{{",
            server.addr
        )
        .as_bytes(),
    )
    .await
    .unwrap();
    let raw = tokio::time::timeout(Duration::from_secs(10), read_until_closed(&mut s))
        .await
        .expect("answered and closed");
    let text = String::from_utf8_lossy(&raw);
    assert!(text.starts_with("HTTP/1.1 413"), "{text}");
    assert!(
        text.contains("payload_too_large") && text.contains("1000000000"),
        "{text}"
    );
    server.stop().await;
}

/// Opens an event stream from `local` (a loopback address) and returns the
/// connection and the status of its answer.
async fn open_stream(server: SocketAddr, local: [u8; 4]) -> (TcpStream, u16) {
    let socket = TcpSocket::new_v4().unwrap();
    socket.bind(SocketAddr::from((local, 0))).unwrap();
    let mut s = socket.connect(server).await.unwrap();
    s.write_all(format!("GET /api/events HTTP/1.1\r\nHost: {server}\r\n\r\n").as_bytes())
        .await
        .unwrap();
    let mut head = Vec::new();
    let mut byte = [0u8; 1];
    while !head.ends_with(b"\r\n\r\n") {
        match tokio::time::timeout(Duration::from_secs(10), s.read(&mut byte)).await {
            Ok(Ok(1)) => head.push(byte[0]),
            other => panic!("no answer head: {other:?} after {:?}", String::from_utf8_lossy(&head)),
        }
    }
    let status = String::from_utf8_lossy(&head)
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    (s, status)
}

/// Regression: event streams were unbounded, so a client could take every
/// connection with them. Beyond the cap per client the answer is 429, beyond
/// the cap in all 503, and a closed stream frees its place.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn event_streams_beyond_the_caps_get_429_per_client_and_503_in_all() {
    let server = start(ServeLimits {
        max_event_streams: 3,
        max_event_streams_per_client: 2,
        ..limits(64)
    })
    .await;
    let a = [127, 0, 0, 1];
    let b = [127, 0, 0, 2];
    let (a1, s) = open_stream(server.addr, a).await;
    assert_eq!(s, 200);
    let (_a2, s) = open_stream(server.addr, a).await;
    assert_eq!(s, 200);
    let (_a3, s) = open_stream(server.addr, a).await;
    assert_eq!(s, 429, "a third stream from one client");
    let (_b1, s) = open_stream(server.addr, b).await;
    assert_eq!(s, 200);
    let (_b2, s) = open_stream(server.addr, b).await;
    assert_eq!(s, 503, "a fourth stream in all");
    drop(a1);
    tokio::time::sleep(Duration::from_millis(300)).await;
    let (_b3, s) = open_stream(server.addr, b).await;
    assert_eq!(s, 200, "a closed stream frees its place");
    // Ordinary requests are unaffected.
    assert_eq!(get_status(server.addr, "/api/health").await, 200);
    server.stop().await;
}

/// Raises this process's descriptor limit to hold a flood's sockets (both
/// ends live in the test process).
fn raise_descriptor_limit(wanted: u64) {
    #[cfg(target_os = "linux")]
    unsafe {
        let mut limit = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        if libc::getrlimit(libc::RLIMIT_NOFILE, &mut limit) == 0 && limit.rlim_cur < wanted {
            limit.rlim_cur = wanted.min(limit.rlim_max);
            libc::setrlimit(libc::RLIMIT_NOFILE, &limit);
        }
    }
}

/// Regression: 512 open `/api/events` streams (no token on loopback, no
/// timeout, each holding one of the 512 connections) stopped the whole API:
/// `/api/health` timed out (4 of 4 probes at 15 s; behind 1 000 idle
/// connections, 11.3 s). With 600 streams from 20 loopback addresses and
/// 1 000 idle connections open on a real daemon, health answers within 1 s
/// (the issue's requirement), and the streams beyond the cap in all are
/// refused with 503.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn event_stream_flood_stops_the_whole_api() {
    raise_descriptor_limit(8192);
    let d = common::Daemon::start(0.0).await;
    let mut streams = Vec::new();
    let mut statuses = std::collections::BTreeMap::<u16, usize>::new();
    // 30 streams from each of 20 loopback addresses: under the cap per
    // client, so the cap in all is what holds.
    for i in 0..600 {
        let (s, status) = open_stream(d.addr, [127, 0, 1, 1 + (i % 20) as u8]).await;
        *statuses.entry(status).or_default() += 1;
        streams.push(s);
    }
    let limits = ServeLimits::default();
    assert_eq!(
        statuses.get(&200).copied(),
        Some(limits.max_event_streams),
        "{statuses:?}"
    );
    assert_eq!(
        statuses.get(&503).copied(),
        Some(600 - limits.max_event_streams),
        "{statuses:?}"
    );
    let mut idle = Vec::new();
    for _ in 0..1000 {
        idle.push(TcpStream::connect(d.addr).await.unwrap());
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    let mut took_ms = Vec::new();
    for probe in 0..5 {
        let started = std::time::Instant::now();
        let status = tokio::time::timeout(Duration::from_secs(20), get_status(d.addr, "/api/health"))
            .await
            .unwrap_or_else(|_| panic!("probe {probe}: /api/health did not answer within 20 s"));
        let took = started.elapsed();
        assert_eq!(status, 200, "probe {probe}");
        assert!(
            took < Duration::from_secs(1),
            "probe {probe}: /api/health took {took:?} behind 600 event streams and 1000 idle connections"
        );
        took_ms.push(took.as_secs_f64() * 1e3);
    }
    took_ms.sort_by(f64::total_cmp);
    println!(
        "flood: 600 /api/events streams ({statuses:?}) and 1000 idle connections; /api/health in {:.1} ms median of 5 (max {:.1} ms)",
        took_ms[2], took_ms[4]
    );
    drop(idle);
    drop(streams);
    d.stop().await;
}

/// Regression: `POST /api/studies` accepted the same scene 5 000 times (it
/// ran for minutes, and ten copies ended `failed` on a UNIQUE constraint);
/// a repeated scene is refused naming it, as renders refuse repeated
/// codings, and the list is bounded.
#[tokio::test]
async fn a_study_of_the_same_scene_5000_times_is_accepted() {
    let h = harness(true).await;
    let post = |body: String| {
        Request::post("/api/studies")
            .header("authorization", format!("Bearer {TOKEN}"))
            .header("content-type", "application/json")
            .body(Body::from(body))
            .unwrap()
    };
    let repeated = vec!["white"; 5000].join(",");
    let (status, text) = send(&h.state, post(format!(r#"{{"scenes":"{repeated}"}}"#))).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{text}");
    assert!(text.contains("`scenes`"), "{text}");
    let (status, text) = send(&h.state, post(r#"{"scenes":"cylinder, white,cylinder"}"#.into())).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{text}");
    assert!(text.contains("`cylinder` is named twice"), "{text}");
    let many: Vec<String> = (0..65).map(|i| format!("s{i}")).collect();
    let (status, text) = send(&h.state, post(format!(r#"{{"scenes":"{}"}}"#, many.join(",")))).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{text}");
    assert!(text.contains("at most 64"), "{text}");
}

/// Regression: `/api/images/+1` was accepted as image 1 (Rust's integer
/// parsing takes a sign); ids in paths are plain digits.
#[tokio::test]
async fn path_id_with_a_plus_sign_is_accepted() {
    let h = harness(true).await;
    for path in [
        "/api/images/+1",
        "/api/measurements/+1",
        "/api/measurements/-1",
        "/api/measurements/007",
        "/api/studies/+2/files/index.html",
    ] {
        let (status, text) = send(&h.state, Request::get(path).body(Body::empty()).unwrap()).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{path}: {text}");
        assert!(
            text.contains("path parameter `id`") && text.contains("plain number"),
            "{path}: {text}"
        );
    }
    let (status, text) = send(
        &h.state,
        Request::get("/api/measurements/1").body(Body::empty()).unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::NOT_FOUND, "{text}");
}

/// Regression: `GET /api/renders/{missing}/images` answered 200 `[]`
/// instead of 404.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn images_of_a_missing_render_answer_200_empty() {
    let d = common::Daemon::start(0.0).await;
    let (status, body) = common::get_json(d.addr, "/api/renders/987654/images").await;
    assert_eq!(status, 404, "{body}");
    assert!(body["error"]["message"].as_str().unwrap().contains("987654"), "{body}");
    d.stop().await;
}

/// Regression: the SQLite database was created world-readable (0644 under
/// the usual umask): every user of the booth PC could read every
/// measurement. It is created 0600, and its WAL files follow.
#[cfg(unix)]
#[tokio::test]
async fn database_file_created_world_readable() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lab.sqlite");
    let store = Store::open(&format!("sqlite://{}", path.display())).await.unwrap();
    store.create_session("op", "").await.unwrap();
    for name in ["lab.sqlite", "lab.sqlite-wal", "lab.sqlite-shm"] {
        let file = dir.path().join(name);
        if let Ok(meta) = std::fs::metadata(&file) {
            let mode = meta.permissions().mode() & 0o777;
            assert_eq!(mode, 0o600, "{name} is {mode:04o}");
        } else {
            assert_ne!(name, "lab.sqlite", "no database file");
        }
    }
}

/// One raw request, as written, on a fresh connection; the status and the whole answer.
async fn raw_request(addr: SocketAddr, head: &str) -> (u16, String) {
    let mut s = TcpStream::connect(addr).await.unwrap();
    s.write_all(head.as_bytes()).await.unwrap();
    let raw = String::from_utf8_lossy(&read_until_closed(&mut s).await).into_owned();
    let status = raw.split_whitespace().nth(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    (status, raw)
}

/// Regression (issue 46): an HTTP/1.1 request without `Host`, or with two,
/// was answered 200, and one in absolute form was answered by its `Host`
/// (`localhost`) although it asked for another authority. RFC 9112 §3.2: a
/// server MUST answer 400 to an HTTP/1.1 request lacking `Host` and to any
/// with more than one; §3.2.2: a server MUST accept the absolute form, and
/// its target's authority, not `Host`, is the host asked for (so it is
/// what the DNS-rebinding check judges).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn requests_without_host_or_with_two_were_answered_200() {
    let server = start(limits(16)).await;
    let addr = server.addr;
    let port = addr.port();
    for (what, head) in [
        (
            "no Host",
            "GET /api/health HTTP/1.1\r\nConnection: close\r\n\r\n".to_string(),
        ),
        (
            "two Hosts",
            format!("GET /api/health HTTP/1.1\r\nHost: {addr}\r\nHost: {addr}\r\nConnection: close\r\n\r\n"),
        ),
        (
            "two different Hosts",
            format!(
                "GET /api/measurements HTTP/1.1\r\nHost: {addr}\r\nHost: attacker.example\r\nConnection: close\r\n\r\n"
            ),
        ),
        (
            "absolute form without Host",
            format!("GET http://{addr}/api/health HTTP/1.1\r\nConnection: close\r\n\r\n"),
        ),
    ] {
        let (status, raw) = raw_request(addr, &head).await;
        assert_eq!(status, 400, "{what}: {raw}");
        assert!(raw.contains("Host") && raw.contains("RFC 9112"), "{what}: {raw}");
    }
    // The target's authority is the host asked for: a rebound name is
    // refused whatever `Host` says, and an address of this daemon answered
    // whatever it says.
    let (status, raw) = raw_request(
        addr,
        "GET http://attacker.example/api/measurements HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n",
    )
    .await;
    assert_eq!(status, 421, "{raw}");
    assert!(raw.contains("attacker.example"), "{raw}");
    let (status, raw) = raw_request(
        addr,
        &format!(
            "GET http://localhost:{port}/api/health HTTP/1.1\r\nHost: attacker.example\r\nConnection: close\r\n\r\n"
        ),
    )
    .await;
    assert_eq!(status, 200, "{raw}");
    // HTTP/1.0 has no Host requirement; one Host is the ordinary case.
    let (status, raw) = raw_request(addr, "GET /api/health HTTP/1.0\r\n\r\n").await;
    assert_eq!(status, 200, "{raw}");
    assert_eq!(get_status(addr, "/api/health").await, 200);
    server.stop().await;
}
