//! Load benchmark of the REST API on loopback (not a test): with many stored
//! complete measurements (three raw samples each, spread over three booths),
//! fire requests at a fixed rate (open loop: requests start on schedule
//! whether or not earlier ones finished) and report p50/p99 latency of each
//! endpoint a dashboard or MATLAB script uses: one measurement with its
//! samples, the first page of the listing, the page filtered by booth and by
//! scene, a deep page (offset 90 % of the rows, and the same depth by the
//! `before_id` cursor), `/api/booths` and
//! `/api/health`. The goal is p99 < 10 ms at 200 requests/s.
//!
//! ```text
//! cargo bench --bench api_load [-- RATE SECONDS] [--json]
//!     SQLite (a fresh file), 10 000 measurements
//! cargo bench --bench api_load -- --postgres [RATE SECONDS] [--json]
//!     a fresh database on the test PostgreSQL server (tests/setup.sh;
//!     `$LIGHTBOOTH_TEST_PG` or target/pg-url), 100 000 measurements
//! cargo bench --bench api_load -- --db postgres://… [--json]
//!     an existing, empty PostgreSQL database
//! --measurements N   how many to store instead
//! ```
//!
//! The rows are bulk-inserted (PostgreSQL: `COPY … FROM STDIN`; SQLite: one
//! transaction), not measured through the daemon: the benchmark times
//! reading them, and the daemons' writing is `booths_scale`'s part.

#[path = "../tests/common/mod.rs"]
mod common;

use std::fmt::Write as _;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};

use lightbooth::http::{app, AppState, ServiceConfig};
use lightbooth::lab::measure::queue::InstrumentStatus;
use lightbooth::store::{now, Booth, Store};
use sqlx::Connection;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::sync::{mpsc, watch};

/// The booths the measurements are spread over, round robin.
const BOOTHS: [&str; 3] = ["north", "south", "east"];
const SCENES: [&str; 5] = ["white", "red", "green", "blue", "cylinder"];
/// Raw samples per stored measurement.
const SAMPLES: i64 = 3;
/// The PR-650's grid: 380–780 nm in 4 nm steps.
const WAVELENGTHS: usize = 101;

/// The stored spectra (all measurements alike: their size, not their
/// values, is what a fetch pays for).
struct Spectra {
    wavelength: String,
    radiance: String,
}

impl Spectra {
    fn new() -> Spectra {
        let radiance: Vec<f64> = (0..WAVELENGTHS).map(|i| 1e-3 + 1.234_567e-6 * i as f64).collect();
        let wavelength: Vec<f64> = (0..WAVELENGTHS).map(|i| 380.0 + 4.0 * i as f64).collect();
        Spectra {
            wavelength: serde_json::to_string(&wavelength).unwrap(),
            radiance: serde_json::to_string(&radiance).unwrap(),
        }
    }
}

/// The instruments of the three booths (one PR-650 each); their ids.
async fn register_instruments(store: &Store) -> Vec<i64> {
    let mut ids = Vec::new();
    for (k, booth) in BOOTHS.iter().enumerate() {
        let booth: Booth = booth.parse().unwrap();
        ids.push(
            store
                .upsert_instrument(&booth, "PR-650", Some(&format!("6500{k}")), "-")
                .await
                .unwrap(),
        );
    }
    ids
}

/// Fills an SQLite store: one transaction of single-row inserts (SQLite
/// has no network round trip per statement).
async fn fill_sqlite(store: &Store, measurements: i64) {
    let s = Spectra::new();
    let instruments = register_instruments(store).await;
    let mut tx = store.sqlite_pool().unwrap().begin().await.unwrap();
    for m in 0..measurements {
        let id: i64 = sqlx::query_scalar(
            "INSERT INTO measurements (booth, instrument_id, scene, target, samples_requested, settings_json, state, \
             created_at, started_at, finished_at, wavelength_json, radiance_json, radiance_sd_json, luminance_cd_m2, x, \
             y, luminance_cv, observer) \
             VALUES (?, ?, ?, 'patch', ?, '{}', 'complete', ?, ?, ?, ?, ?, ?, 34.0, 0.31, 0.33, 0.002, ?) RETURNING id",
        )
        .bind(BOOTHS[(m % 3) as usize])
        .bind(instruments[(m % 3) as usize])
        .bind(SCENES[(m % 5) as usize])
        .bind(SAMPLES)
        .bind(now())
        .bind(now())
        .bind(now())
        .bind(&s.wavelength)
        .bind(&s.radiance)
        .bind(&s.radiance)
        .bind(lightbooth::colorimetry::Observer::JuddVos.name())
        .fetch_one(&mut *tx)
        .await
        .unwrap();
        for k in 0..SAMPLES {
            sqlx::query(
                "INSERT INTO samples (measurement_id, idx, taken_at, code, message, usable, radiance_json, \
                 luminance_cd_m2) VALUES (?, ?, ?, 0, 'OK', 1, ?, 34.0)",
            )
            .bind(id)
            .bind(k)
            .bind(now())
            .bind(&s.radiance)
            .execute(&mut *tx)
            .await
            .unwrap();
        }
    }
    tx.commit().await.unwrap();
}

/// Fills a PostgreSQL database with `COPY … FROM STDIN` (text format) in
/// one transaction: measurements with ids 1..=N (the identity sequence is
/// moved past them), then their samples; then `ANALYZE`, as autovacuum
/// would soon after a bulk load.
async fn fill_postgres(store: &Store, url: &str, measurements: i64) {
    let s = Spectra::new();
    let instruments = register_instruments(store).await;
    let mut conn = sqlx::PgConnection::connect(url).await.unwrap();
    let existing: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM measurements")
        .fetch_one(&mut conn)
        .await
        .unwrap();
    assert_eq!(
        existing, 0,
        "{url} already holds {existing} measurements: the benchmark fills an empty database"
    );
    let mut tx = conn.begin().await.unwrap();
    // Sent in chunks of this many measurements (a few MB each).
    const CHUNK: i64 = 2_000;
    let observer = lightbooth::colorimetry::Observer::JuddVos.name();
    let mut copy = tx
        .copy_in_raw(
            "COPY measurements (id, booth, instrument_id, scene, target, samples_requested, settings_json, state, \
             created_at, started_at, finished_at, wavelength_json, radiance_json, radiance_sd_json, luminance_cd_m2, x, \
             y, luminance_cv, observer) FROM STDIN",
        )
        .await
        .unwrap();
    let t0 = now();
    let mut buf = String::new();
    for id in 1..=measurements {
        let t = t0 - (measurements - id) as f64;
        writeln!(
            buf,
            "{id}\t{}\t{}\t{}\tpatch\t{SAMPLES}\t{{\"samples\":{SAMPLES}}}\tcomplete\t{t}\t{t}\t{}\t{}\t{}\t{}\t34.0\t0.31\t0.33\t0.002\t{observer}",
            BOOTHS[(id % 3) as usize],
            instruments[(id % 3) as usize],
            SCENES[(id % 5) as usize],
            t + 2.0,
            s.wavelength,
            s.radiance,
            s.radiance
        )
        .unwrap();
        if id % CHUNK == 0 || id == measurements {
            copy.send(buf.as_bytes()).await.unwrap();
            buf.clear();
        }
    }
    copy.finish().await.unwrap();
    let mut copy = tx
        .copy_in_raw(
            "COPY samples (measurement_id, idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2) \
             FROM STDIN",
        )
        .await
        .unwrap();
    for id in 1..=measurements {
        let t = t0 - (measurements - id) as f64;
        for k in 0..SAMPLES {
            writeln!(buf, "{id}\t{k}\t{}\t0\tOK\tt\t{}\t34.0", t + k as f64 * 0.5, s.radiance).unwrap();
        }
        if id % CHUNK == 0 || id == measurements {
            copy.send(buf.as_bytes()).await.unwrap();
            buf.clear();
        }
    }
    copy.finish().await.unwrap();
    for table in ["measurements", "samples"] {
        sqlx::query(&format!(
            "SELECT setval(pg_get_serial_sequence('{table}', 'id'), (SELECT MAX(id) FROM {table}))"
        ))
        .execute(&mut *tx)
        .await
        .unwrap();
    }
    tx.commit().await.unwrap();
    sqlx::query("VACUUM ANALYZE measurements")
        .execute(&mut conn)
        .await
        .unwrap();
    sqlx::query("VACUUM ANALYZE samples").execute(&mut conn).await.unwrap();
    conn.close().await.ok();
}

/// One `GET` with `Connection: close`; its latency, and the start of the
/// response when its status is not 200 (an overloaded pool answers 500).
async fn get(addr: SocketAddr, path: &str) -> (Duration, Option<String>) {
    let start = Instant::now();
    let mut s = TcpStream::connect(addr).await.unwrap();
    s.write_all(format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n").as_bytes())
        .await
        .unwrap();
    let mut buf = Vec::new();
    s.read_to_end(&mut buf).await.unwrap();
    let elapsed = start.elapsed();
    if buf.starts_with(b"HTTP/1.1 200") {
        (elapsed, None)
    } else {
        let text = String::from_utf8_lossy(&buf);
        let body = text.split("\r\n\r\n").nth(1).unwrap_or_default();
        let status = text.lines().next().unwrap_or_default();
        (
            elapsed,
            Some(format!("GET {path}: {status} {}", &body[..body.len().min(200)])),
        )
    }
}

/// The `p` quantile (nearest rank) of sorted latencies, in ms.
fn percentile(sorted: &[Duration], p: f64) -> f64 {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i].as_secs_f64() * 1e3
}

/// Open loop: request `i` starts at `i / rate` seconds whether or not the
/// earlier ones finished; the sorted latencies (errors included) and the
/// errors.
async fn run(addr: SocketAddr, rate: f64, seconds: f64, path: impl Fn(u64) -> String) -> (Vec<Duration>, Vec<String>) {
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
    let mut errors = Vec::new();
    for t in tasks {
        let (latency, error) = t.await.unwrap();
        out.push(latency);
        errors.extend(error);
    }
    out.sort();
    (out, errors)
}

/// The path of request `i` of an endpoint's run.
type PathOf = Box<dyn Fn(u64) -> String>;

/// One endpoint's figures.
struct Figures {
    name: &'static str,
    example: String,
    requests: usize,
    p50_ms: f64,
    p99_ms: f64,
    max_ms: f64,
    /// Answers other than 200.
    errors: usize,
    first_error: Option<String>,
}

/// What to run against, from the command line.
struct Options {
    rate: f64,
    seconds: f64,
    json: bool,
    /// `None`: a fresh SQLite file.
    postgres: Option<PostgresTarget>,
    measurements: Option<i64>,
}

enum PostgresTarget {
    /// A fresh database on the test server.
    Fresh,
    Url(String),
}

fn options() -> Options {
    let mut positional = Vec::new();
    let mut o = Options {
        rate: 200.0,
        seconds: 10.0,
        json: false,
        postgres: None,
        measurements: None,
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--json" => o.json = true,
            "--postgres" => o.postgres = Some(PostgresTarget::Fresh),
            "--db" => {
                let url = args.next().expect("--db needs a postgres:// URL");
                assert!(
                    url.starts_with("postgres://") || url.starts_with("postgresql://"),
                    "--db {url}: the benchmark fills a PostgreSQL database (without --db it uses a fresh SQLite file)"
                );
                o.postgres = Some(PostgresTarget::Url(url));
            }
            "--measurements" => {
                let n = args.next().expect("--measurements needs a number");
                o.measurements = Some(n.parse().unwrap_or_else(|_| panic!("--measurements {n}: not a number")));
            }
            // `cargo bench` passes `--bench`.
            s if s.starts_with("--") => {}
            _ => positional.push(a),
        }
    }
    if let Some(r) = positional.first() {
        o.rate = r.parse().unwrap_or_else(|_| panic!("RATE {r}: not a number"));
    }
    if let Some(s) = positional.get(1) {
        o.seconds = s.parse().unwrap_or_else(|_| panic!("SECONDS {s}: not a number"));
    }
    o
}

fn main() {
    let o = options();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async move {
        let dir = tempfile::tempdir().unwrap();
        let (url, measurements) = match &o.postgres {
            None => (
                format!("sqlite://{}", dir.path().join("load.sqlite").display()),
                o.measurements.unwrap_or(10_000),
            ),
            Some(PostgresTarget::Fresh) => (
                common::fresh_postgres_database().await,
                o.measurements.unwrap_or(100_000),
            ),
            Some(PostgresTarget::Url(u)) => (u.clone(), o.measurements.unwrap_or(100_000)),
        };
        let store = Store::open(&url).await.unwrap();
        let t = Instant::now();
        if o.postgres.is_some() {
            fill_postgres(&store, &url, measurements).await;
        } else {
            fill_sqlite(&store, measurements).await;
        }
        let fill_seconds = t.elapsed().as_secs_f64();
        eprintln!(
            "stored {measurements} measurements × {SAMPLES} samples in {} in {fill_seconds:.1} s",
            store.engine_name()
        );
        let (jobs, _jobs_rx) = mpsc::channel(64);
        let (_status_tx, status) = watch::channel(InstrumentStatus::Idle {
            model: "PR-650".into(),
            measures: "spectrum".into(),
            serial: None,
            port: "-".into(),
        });
        let shutting_down = tokio_util::sync::CancellationToken::new();
        let events = lightbooth::lab::events::EventSink::bus(16);
        let instrument = lightbooth::lab::measure::booth_instrument::BoothInstrument::new(
            store.clone(),
            jobs,
            status,
            events.clone(),
            None,
            lightbooth::instrument::Pr650Settings::default().capabilities(),
            "north".parse().unwrap(),
        );
        let state = AppState {
            lab: lightbooth::lab::LabHandle::new(
                store.clone(),
                lightbooth::colorimetry::Observer::JuddVos,
                instrument,
                None,
            ),
            config: Arc::new(ServiceConfig {
                token: "0123456789abcdef0123".into(),
                loopback_only: true,
                allowed_hosts: Default::default(),
            }),
            events,
            mock: None,
            shutting_down,
        };
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        tokio::spawn(async move { axum::serve(listener, app(state)).await });
        // Warm up connections and the page cache.
        for i in 1..=200 {
            let (_, error) = get(addr, &format!("/api/measurements/{i}")).await;
            assert!(error.is_none(), "{error:?}");
        }
        let n = measurements as u64;
        let deep = n * 9 / 10;
        let endpoints: Vec<(&'static str, PathOf)> = vec![
            (
                "fetch one measurement (3 samples)",
                Box::new(move |i| format!("/api/measurements/{}", 1 + (i * 7919) % n)),
            ),
            (
                "first page of measurements (50)",
                Box::new(|_| "/api/measurements".into()),
            ),
            (
                "first page of one booth",
                Box::new(|i| format!("/api/measurements?booth={}", BOOTHS[(i % 3) as usize])),
            ),
            (
                "first page of one scene",
                Box::new(|i| format!("/api/measurements?scene={}", SCENES[(i % 5) as usize])),
            ),
            (
                "deep page (offset 90 %)",
                Box::new(move |i| {
                    format!(
                        "/api/measurements?limit=50&offset={}",
                        deep + (i * 50) % (n / 20).max(1)
                    )
                }),
            ),
            (
                "deep page (cursor before_id 10 %)",
                Box::new(move |i| {
                    format!(
                        "/api/measurements?limit=50&before_id={}",
                        n - deep - (i * 50) % (n / 20).max(1)
                    )
                }),
            ),
            ("booths", Box::new(|_| "/api/booths".into())),
            ("health", Box::new(|_| "/api/health".into())),
        ];
        let mut figures = Vec::new();
        for (name, path) in endpoints {
            let (latencies, errors) = run(addr, o.rate, o.seconds, &path).await;
            let f = Figures {
                name,
                example: path(1),
                requests: latencies.len(),
                p50_ms: percentile(&latencies, 0.5),
                p99_ms: percentile(&latencies, 0.99),
                max_ms: percentile(&latencies, 1.0),
                errors: errors.len(),
                first_error: errors.into_iter().next(),
            };
            let line = format!(
                "{:<36} {} requests at {}/s: p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms, {} errors  ({})",
                f.name, f.requests, o.rate, f.p50_ms, f.p99_ms, f.max_ms, f.errors, f.example
            );
            if o.json {
                eprintln!("{line}");
            } else {
                println!("{line}");
                if let Some(e) = &f.first_error {
                    println!("    first error: {e}");
                }
            }
            figures.push(f);
        }
        if o.json {
            let endpoints: Vec<serde_json::Value> = figures
                .iter()
                .map(|f| {
                    serde_json::json!({
                        "endpoint": f.name, "example": f.example, "requests": f.requests,
                        "p50_ms": f.p50_ms, "p99_ms": f.p99_ms, "max_ms": f.max_ms,
                        "errors": f.errors, "first_error": f.first_error,
                    })
                })
                .collect();
            println!(
                "{}",
                serde_json::to_string_pretty(&serde_json::json!({
                    "engine": store.engine_name(),
                    "measurements": measurements,
                    "samples_per_measurement": SAMPLES,
                    "booths": BOOTHS,
                    "fill_seconds": fill_seconds,
                    "rate_per_second": o.rate,
                    "seconds_per_endpoint": o.seconds,
                    "endpoints": endpoints,
                }))
                .unwrap()
            );
        }
    });
}
