//! A minimal HTTP/1.1 client over a real loopback socket, for tests that
//! talk to a running daemon exactly as MATLAB or a browser would.

#![allow(dead_code)]

pub mod booths;
pub mod calibrated;
pub mod pr655_wire;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use lightbooth::daemon::{self, DaemonOptions};
use lightbooth::instrument::Pr650Settings;
use serde_json::Value;
use tokio::io::{AsyncBufReadExt, AsyncReadExt, AsyncWriteExt, BufReader};
use tokio::net::TcpStream;
use tokio::sync::mpsc;

/// One request with `Connection: close`; returns the status and the body.
pub async fn request(
    addr: SocketAddr,
    method: &str,
    path: &str,
    token: Option<&str>,
    json: Option<&str>,
) -> (u16, Vec<u8>) {
    let body = json.map(|j| ("application/json", j.as_bytes()));
    let (status, _, body) = request_raw(addr, method, path, token, body).await;
    (status, body)
}

/// A request with any body (its content type and bytes); the status, the
/// response's head (status line and header fields) and its body.
pub async fn request_raw(
    addr: SocketAddr,
    method: &str,
    path: &str,
    token: Option<&str>,
    body: Option<(&str, &[u8])>,
) -> (u16, String, Vec<u8>) {
    let mut stream = TcpStream::connect(addr).await.expect("connect to the daemon");
    let mut head = format!("{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n");
    if let Some(t) = token {
        head.push_str(&format!("Authorization: Bearer {t}\r\n"));
    }
    if let Some((content_type, bytes)) = body {
        head.push_str(&format!(
            "Content-Type: {content_type}\r\nContent-Length: {}\r\n",
            bytes.len()
        ));
    }
    head.push_str("\r\n");
    stream.write_all(head.as_bytes()).await.unwrap();
    if let Some((_, bytes)) = body {
        stream.write_all(bytes).await.unwrap();
    }
    let mut raw = Vec::new();
    stream.read_to_end(&mut raw).await.unwrap();
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a complete response");
    let head = String::from_utf8_lossy(&raw[..split]).to_string();
    let status: u16 = head.split_whitespace().nth(1).unwrap().parse().unwrap();
    let mut body = raw[split + 4..].to_vec();
    if head.to_ascii_lowercase().contains("transfer-encoding: chunked") {
        body = dechunk(&body);
    }
    (status, head, body)
}

fn dechunk(mut data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    while let Some(eol) = data.windows(2).position(|w| w == b"\r\n") {
        let size = usize::from_str_radix(std::str::from_utf8(&data[..eol]).unwrap().trim(), 16).unwrap_or(0);
        if size == 0 {
            break;
        }
        out.extend_from_slice(&data[eol + 2..eol + 2 + size]);
        data = &data[eol + 2 + size + 2..];
    }
    out
}

pub async fn get_json(addr: SocketAddr, path: &str) -> (u16, Value) {
    let (status, body) = request(addr, "GET", path, None, None).await;
    (status, serde_json::from_slice(&body).unwrap_or(Value::Null))
}

pub async fn post_json(addr: SocketAddr, path: &str, token: &str, json: &str) -> (u16, Value) {
    let (status, body) = request(addr, "POST", path, Some(token), Some(json)).await;
    (status, serde_json::from_slice(&body).unwrap_or(Value::Null))
}

/// Follows `/api/events`; yields (event name, data) pairs.
pub async fn events(addr: SocketAddr) -> mpsc::UnboundedReceiver<(String, Value)> {
    let mut stream = TcpStream::connect(addr).await.unwrap();
    let req = format!("GET /api/events HTTP/1.1\r\nHost: {addr}\r\nAccept: text/event-stream\r\n\r\n");
    stream.write_all(req.as_bytes()).await.unwrap();
    let (tx, rx) = mpsc::unbounded_channel();
    tokio::spawn(async move {
        let mut lines = BufReader::new(stream).lines();
        let mut name = String::new();
        while let Ok(Some(line)) = lines.next_line().await {
            if let Some(n) = line.strip_prefix("event: ") {
                name = n.trim().to_string();
            } else if let Some(d) = line.strip_prefix("data: ") {
                if let Ok(v) = serde_json::from_str(d) {
                    if tx.send((name.clone(), v)).is_err() {
                        return;
                    }
                }
            }
        }
    });
    rx
}

/// Waits (bounded) for the first event matching `pred`.
pub async fn wait_for(
    rx: &mut mpsc::UnboundedReceiver<(String, Value)>,
    what: &str,
    limit: Duration,
    mut pred: impl FnMut(&str, &Value) -> bool,
) -> Value {
    let deadline = tokio::time::Instant::now() + limit;
    loop {
        let left = deadline.saturating_duration_since(tokio::time::Instant::now());
        match tokio::time::timeout(left, rx.recv()).await {
            Ok(Some((name, v))) if pred(&name, &v) => return v,
            Ok(Some(_)) => continue,
            Ok(None) => panic!("the event stream ended while waiting for {what}"),
            Err(_) => panic!("no {what} within {limit:?}"),
        }
    }
}

/// Polls `path` until `pred` holds (bounded).
pub async fn poll_until(addr: SocketAddr, path: &str, limit: Duration, mut pred: impl FnMut(&Value) -> bool) -> Value {
    let deadline = tokio::time::Instant::now() + limit;
    loop {
        let (_, v) = get_json(addr, path).await;
        if pred(&v) {
            return v;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "{path} never reached the expected state: {v}"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// The write token of [`Daemon`].
pub const TOKEN: &str = "test-token-0123456789abcdef";

/// The less common settings of [`Daemon`]: `None` is the default.
#[derive(Default)]
struct Extra {
    /// `serve --scenes` (default: the repository's `scenes/`).
    scenes_dir: Option<PathBuf>,
    /// `serve --observer` (default: Judd–Vos).
    observer: Option<lightbooth::colorimetry::Observer>,
}

/// A whole daemon in-process on loopback with the simulated PR-650, a
/// fresh SQLite file and the write token [`TOKEN`].
pub struct Daemon {
    pub addr: SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<anyhow::Result<()>>,
    pub dir: tempfile::TempDir,
}

impl Daemon {
    /// Starts it; returns once the instrument is idle.
    pub async fn start(mock_speed: f64) -> Daemon {
        Daemon::start_bound(mock_speed, "127.0.0.1:0").await
    }

    /// Starts it listening on `bind` (e.g. `0.0.0.0:0`, so reads need the
    /// token); `addr` is then the loopback address of the same port.
    pub async fn start_bound(mock_speed: f64, bind: &str) -> Daemon {
        Daemon::start_with(mock_speed, bind, None, None, None).await
    }

    /// Starts it on the database at `db_url` (e.g. a PostgreSQL database)
    /// instead of a fresh SQLite file.
    pub async fn start_on(mock_speed: f64, db_url: &str) -> Daemon {
        Daemon::start_with(mock_speed, "127.0.0.1:0", Some(db_url), None, None).await
    }

    /// Starts the daemon of booth `booth` (`serve --booth`) on the database
    /// at `db_url`, shared with other booths' daemons.
    pub async fn start_booth(mock_speed: f64, db_url: &str, booth: &str) -> Daemon {
        Daemon::start_with(mock_speed, "127.0.0.1:0", Some(db_url), None, Some(booth)).await
    }

    /// Starts the daemon of booth `booth` on the PostgreSQL database at
    /// `db_url`, leaving its comparisons, renders and studies to render
    /// workers (`serve --renders workers`).
    pub async fn start_for_workers(mock_speed: f64, db_url: &str, booth: &str) -> Daemon {
        Daemon::start_full(
            mock_speed,
            "127.0.0.1:0",
            Some(db_url),
            None,
            Some(booth),
            lightbooth::lab::render::worker_queue::RenderPlace::Workers,
            Extra::default(),
        )
        .await
    }

    /// Starts it with the scene files of the folder `scenes` (`serve
    /// --scenes`) instead of the repository's `scenes/`.
    pub async fn start_with_scenes(mock_speed: f64, scenes: &std::path::Path) -> Daemon {
        Daemon::start_full(
            mock_speed,
            "127.0.0.1:0",
            None,
            None,
            None,
            Default::default(),
            Extra {
                scenes_dir: Some(scenes.to_path_buf()),
                ..Extra::default()
            },
        )
        .await
    }

    /// Starts it with another instrument model (simulated, as `--mock` does).
    pub async fn start_instrument(mock_speed: f64, instrument: lightbooth::instrument::InstrumentSettings) -> Daemon {
        Daemon::start_with(mock_speed, "127.0.0.1:0", None, Some(instrument), None).await
    }

    /// Starts it with another instrument model on the database at `db_url`
    /// (e.g. one a daemon before it left).
    pub async fn start_instrument_on(
        mock_speed: f64,
        instrument: lightbooth::instrument::InstrumentSettings,
        db_url: &str,
    ) -> Daemon {
        Daemon::start_with(mock_speed, "127.0.0.1:0", Some(db_url), Some(instrument), None).await
    }

    /// Starts it with another instrument model, its comparisons in `observer`
    /// (`serve --observer`; a colorimeter's XYZ are compared only in its own).
    pub async fn start_instrument_in(
        mock_speed: f64,
        instrument: lightbooth::instrument::InstrumentSettings,
        observer: lightbooth::colorimetry::Observer,
    ) -> Daemon {
        let extra = Extra {
            observer: Some(observer),
            ..Extra::default()
        };
        Daemon::start_full(
            mock_speed,
            "127.0.0.1:0",
            None,
            Some(instrument),
            None,
            Default::default(),
            extra,
        )
        .await
    }

    async fn start_with(
        mock_speed: f64,
        bind: &str,
        db_url: Option<&str>,
        instrument: Option<lightbooth::instrument::InstrumentSettings>,
        booth: Option<&str>,
    ) -> Daemon {
        Daemon::start_full(
            mock_speed,
            bind,
            db_url,
            instrument,
            booth,
            Default::default(),
            Extra::default(),
        )
        .await
    }

    async fn start_full(
        mock_speed: f64,
        bind: &str,
        db_url: Option<&str>,
        instrument: Option<lightbooth::instrument::InstrumentSettings>,
        booth: Option<&str>,
        renders: lightbooth::lab::render::worker_queue::RenderPlace,
        extra: Extra,
    ) -> Daemon {
        let dir = tempfile::tempdir().unwrap();
        let token_file = dir.path().join("token");
        std::fs::write(&token_file, TOKEN).unwrap();
        let listener = tokio::net::TcpListener::bind(bind).await.unwrap();
        let bound = listener.local_addr().unwrap();
        let addr = SocketAddr::from(([127, 0, 0, 1], bound.port()));
        let settings = Pr650Settings {
            // Short timeouts: a fault must end a measurement quickly, never hang.
            command_timeout_ms: 2_000,
            measure_timeout_ms: 5_000,
            gap_timeout_ms: 500,
            ..Pr650Settings::default()
        };
        let options = DaemonOptions {
            booth: booth.map_or_else(Default::default, |b| b.parse().unwrap()),
            bind: bound,
            allowed_hosts: Vec::new(),
            db_url: db_url
                .map(str::to_string)
                .unwrap_or_else(|| format!("sqlite://{}", dir.path().join("lab.sqlite").display())),
            mock: true,
            mock_speed,
            mock_faults: Vec::new(),
            instrument: instrument.unwrap_or(lightbooth::instrument::InstrumentSettings::Pr650(settings)),
            scenes_dir: extra
                .scenes_dir
                .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes")),
            // Shared across tests: converged spectra are keyed by scene content.
            cache_dir: PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("converged-cache"),
            token_file: Some(token_file),
            default_token_file: dir.path().join("unused-token"),
            codings: ["rgb", "srgb", "nstep3", "nstep9", "nstep27", "nstep81", "spectral"]
                .map(String::from)
                .to_vec(),
            render_samples: 2048,
            // The dashboard's camera preview at 16 paths per pixel (the
            // least it takes): a preview, never a measured number; the
            // default's 20 M paths cost each render about 30 s of CPU.
            preview_paths: 1,
            observer: extra.observer.unwrap_or(lightbooth::colorimetry::Observer::JuddVos),
            mock_world: None,
            heartbeat: daemon::DEFAULT_HEARTBEAT,
            lease: daemon::DEFAULT_LEASE,
            renders,
        };
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let task = tokio::spawn(daemon::run(listener, options, async move {
            let _ = stopped.await;
        }));
        // Wait until the instrument is up (health answers without a token
        // only on loopback; bound elsewhere, wait for the port to answer at all).
        if bound.ip().is_loopback() {
            poll_until(addr, "/api/health", Duration::from_secs(20), |v| {
                v["instrument"]["state"] == "idle"
            })
            .await;
        } else {
            let deadline = tokio::time::Instant::now() + Duration::from_secs(20);
            while request(addr, "GET", "/api/health", Some(TOKEN), None).await.0 != 200 {
                assert!(tokio::time::Instant::now() < deadline, "the daemon never answered");
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
        }
        Daemon {
            addr,
            stop: Some(stop),
            task,
            dir,
        }
    }

    /// Stops it gracefully (bounded) and hands back its folder (database
    /// included) for inspection.
    pub async fn stop_keeping_files(mut self) -> tempfile::TempDir {
        let _ = self.stop.take().unwrap().send(());
        tokio::time::timeout(Duration::from_secs(30), &mut self.task)
            .await
            .expect("shutdown in time")
            .unwrap()
            .unwrap();
        self.dir
    }

    /// Stops it gracefully (bounded).
    pub async fn stop(mut self) {
        let _ = self.stop.take().unwrap().send(());
        tokio::time::timeout(Duration::from_secs(30), self.task)
            .await
            .expect("shutdown in time")
            .unwrap()
            .unwrap();
    }
}

/// Where browser tests put their screenshots: `<target>/screenshots/`, an
/// artefact a reviewer can look at.
pub fn screenshot_dir() -> PathBuf {
    let shots = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .map(|t| t.join("screenshots"))
        .unwrap_or_else(|| PathBuf::from("target/screenshots"));
    std::fs::create_dir_all(&shots).unwrap();
    shots
}

/// Runs `tests/browser/SCRIPT` (playwright-core driving headless Chromium;
/// `tests/setup.sh` installs both) against the daemon at `addr` with the
/// write token and the screenshot folder `shots` as its arguments. `Err`
/// carries the script's output when it fails.
pub async fn run_browser_script(script: &str, addr: SocketAddr, shots: PathBuf) -> Result<(), String> {
    let browser_dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser");
    assert!(
        browser_dir.join("node_modules/playwright-core").exists(),
        "playwright-core is not installed: run tests/setup.sh (it installs chromium and the npm package)"
    );
    let script = script.to_string();
    let out = tokio::task::spawn_blocking(move || {
        std::process::Command::new("node")
            .current_dir(&browser_dir)
            .args([
                script.as_str(),
                &format!("http://{addr}"),
                TOKEN,
                shots.to_str().unwrap(),
            ])
            .output()
            .expect("run node (install Node.js 20+)")
    })
    .await
    .unwrap();
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "browser test failed:\n{}\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}

/// A new, empty database on the test PostgreSQL server `tests/setup.sh`
/// starts (its URL in `$LIGHTBOOTH_TEST_PG` or `target/pg-url`), with a
/// name no other test uses; its URL. Fails saying to run `tests/setup.sh`
/// when there is no server.
pub async fn fresh_postgres_database() -> String {
    use sqlx::{ConnectOptions, Connection};
    use std::str::FromStr;
    let admin = std::env::var("LIGHTBOOTH_TEST_PG").unwrap_or_else(|_| {
        let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/pg-url");
        std::fs::read_to_string(&file)
            .unwrap_or_else(|e| {
                panic!(
                    "no test PostgreSQL server: run tests/setup.sh ({}: {e})",
                    file.display()
                )
            })
            .trim()
            .to_string()
    });
    let mut conn = sqlx::postgres::PgConnectOptions::from_str(&admin)
        .unwrap()
        .connect()
        .await
        .unwrap_or_else(|e| panic!("the test PostgreSQL server does not answer ({e}): run tests/setup.sh"));
    let name = format!(
        "lbi_{}_{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos()
    );
    sqlx::query(&format!("CREATE DATABASE {name}"))
        .execute(&mut conn)
        .await
        .unwrap();
    conn.close().await.ok();
    let (base, query) = admin.split_once('?').unwrap_or((&admin, ""));
    let root = &base[..base
        .rfind('/')
        .filter(|&i| i > base.find("://").unwrap() + 2)
        .unwrap_or(base.len())];
    if query.is_empty() {
        format!("{root}/{name}")
    } else {
        format!("{root}/{name}?{query}")
    }
}

/// A measurement's mean luminance (cd/m²) and its standard error, from its
/// samples' spread (`GET /api/measurements/{id}`'s `samples[].Y`).
#[derive(Clone, Copy, Debug)]
pub struct SampleLuminance {
    pub mean: f64,
    pub se: f64,
}

impl SampleLuminance {
    pub fn relative_se(self) -> f64 {
        self.se / self.mean
    }
}

pub fn luminance_of_samples(m: &Value) -> SampleLuminance {
    let y: Vec<f64> = m["samples"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["Y"].as_f64().unwrap())
        .collect();
    let n = y.len() as f64;
    assert!(n >= 2.0, "a standard error needs two samples or more: {m}");
    let mean = y.iter().sum::<f64>() / n;
    let var = y.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    SampleLuminance {
        mean,
        se: (var / n).sqrt(),
    }
}
