//! Load benchmark of the REST API on loopback (not a test): with 10 000
//! stored measurements (five raw samples each), fire single-measurement
//! fetches and listings at a fixed rate (open loop: requests start on
//! schedule whether or not earlier ones finished) and report p50/p99
//! latency. The goal is p99 < 10 ms for a fetch at 200 requests/s.
//!
//! `cargo bench --bench api_load [-- RATE SECONDS]` (defaults 200 and 10).

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};

use lightbooth::service::{app, AppState, InstrumentStatus, ServiceConfig};
use lightbooth::store::{now, Store};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::sync::{broadcast, mpsc, watch};

const MEASUREMENTS: i64 = 10_000;

async fn fill(store: &Store) {
    let spectrum: Vec<f64> = (0..101).map(|i| 1e-3 + 1e-6 * i as f64).collect();
    let json = serde_json::to_string(&spectrum).unwrap();
    let wl = serde_json::to_string(&(0..101).map(|i| 380.0 + 4.0 * i as f64).collect::<Vec<_>>()).unwrap();
    let mut tx = store
        .sqlite_pool()
        .expect("the benchmark fills an SQLite store")
        .begin()
        .await
        .unwrap();
    for m in 0..MEASUREMENTS {
        let scene = ["white", "red", "green", "blue", "cylinder"][(m % 5) as usize];
        let id: i64 = sqlx::query_scalar(
            "INSERT INTO measurements (scene, target, samples_requested, settings_json, state, created_at, started_at, \
             finished_at, wavelength_json, radiance_json, radiance_sd_json, luminance_cd_m2, x, y, luminance_cv) \
             VALUES (?, 'patch', 5, '{}', 'complete', ?, ?, ?, ?, ?, ?, 34.0, 0.31, 0.33, 0.002) RETURNING id",
        )
        .bind(scene)
        .bind(now())
        .bind(now())
        .bind(now())
        .bind(&wl)
        .bind(&json)
        .bind(&json)
        .fetch_one(&mut *tx)
        .await
        .unwrap();
        for k in 0..5 {
            sqlx::query(
                "INSERT INTO samples (measurement_id, idx, taken_at, code, message, usable, radiance_json, \
                 luminance_cd_m2) VALUES (?, ?, ?, 0, 'OK', 1, ?, 34.0)",
            )
            .bind(id)
            .bind(k)
            .bind(now())
            .bind(&json)
            .execute(&mut *tx)
            .await
            .unwrap();
        }
    }
    tx.commit().await.unwrap();
}

async fn get(addr: SocketAddr, path: &str) -> Duration {
    let start = Instant::now();
    let mut s = TcpStream::connect(addr).await.unwrap();
    s.write_all(format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n").as_bytes())
        .await
        .unwrap();
    let mut buf = Vec::new();
    s.read_to_end(&mut buf).await.unwrap();
    assert!(
        buf.starts_with(b"HTTP/1.1 200"),
        "{}",
        String::from_utf8_lossy(&buf[..buf.len().min(200)])
    );
    start.elapsed()
}

fn percentile(sorted: &[Duration], p: f64) -> f64 {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i].as_secs_f64() * 1e3
}

async fn run(addr: SocketAddr, rate: f64, seconds: f64, path: impl Fn(u64) -> String) -> Vec<Duration> {
    let n = (rate * seconds) as u64;
    let period = Duration::from_secs_f64(1.0 / rate);
    let start = tokio::time::Instant::now();
    let mut tasks = Vec::with_capacity(n as usize);
    for i in 0..n {
        tokio::time::sleep_until(start + period * i as u32).await;
        let p = path(i);
        tasks.push(tokio::spawn(async move { get(addr, &p).await }));
    }
    let mut out = Vec::new();
    for t in tasks {
        out.push(t.await.unwrap());
    }
    out.sort();
    out
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let rate: f64 = args.first().and_then(|a| a.parse().ok()).unwrap_or(200.0);
    let seconds: f64 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(10.0);
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async move {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(&format!("sqlite://{}", dir.path().join("load.sqlite").display()))
            .await
            .unwrap();
        let t = Instant::now();
        fill(&store).await;
        eprintln!(
            "stored {MEASUREMENTS} measurements × 5 samples in {:.1} s",
            t.elapsed().as_secs_f64()
        );
        let (jobs, _jobs_rx) = mpsc::channel(64);
        let (_status_tx, status) = watch::channel(InstrumentStatus::Idle {
            model: "PR-650".into(),
            serial: None,
            port: "-".into(),
        });
        let (_down_tx, shutting_down) = watch::channel(false);
        let state = AppState {
            store,
            config: Arc::new(ServiceConfig {
                booth: Default::default(),
                token: "0123456789abcdef0123".into(),
                loopback_only: true,
                scenes_dir: "scenes".into(),
                codings: vec![],
                instrument: lightbooth::instrument::Pr650Settings::default().capabilities(),
                observer: lightbooth::colorimetry::Observer::JuddVos,
            }),
            jobs,
            status,
            events: broadcast::channel(16).0,
            renders: None,
            mock: None,
            measurement_cancel: None,
            shutting_down,
        };
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        tokio::spawn(async move { axum::serve(listener, app(state)).await });
        // Warm up connections and the page cache.
        for i in 1..=200 {
            get(addr, &format!("/api/measurements/{i}")).await;
        }
        let fetch = run(addr, rate, seconds, |i| {
            format!("/api/measurements/{}", 1 + (i * 7919) % MEASUREMENTS as u64)
        })
        .await;
        println!(
            "fetch one measurement (5 samples): {} requests at {rate}/s: p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
            fetch.len(),
            percentile(&fetch, 0.5),
            percentile(&fetch, 0.99),
            percentile(&fetch, 1.0)
        );
        let list = run(addr, rate, seconds, |i| {
            format!("/api/measurements?limit=50&offset={}", (i * 50) % 9000)
        })
        .await;
        println!(
            "list 50 measurements: {} requests at {rate}/s: p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
            list.len(),
            percentile(&list, 0.5),
            percentile(&list, 0.99),
            percentile(&list, 1.0)
        );
    });
}
