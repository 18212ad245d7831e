//! Load benchmark of the heavy GETs (issue 46; not a test): a whole daemon
//! in-process with the simulated PR-650 and display (a fresh SQLite file),
//! an oddity experiment of OBSERVERS simulated observers × 3
//! approximations (every trial of the study's design, posted through the
//! API) and WHITE's patch measured and compared; then POLLERS clients
//! polling the experiment's and the scene's heavy GETs (analysis, its CSV
//! and MAT, thresholds, the psychometric figure, the figure of the
//! experiment, the scene's comparisons, CSV, MAT, a chart, the scenes'
//! overview) for SECONDS, while `/api/health` is asked every 100 ms and a
//! 40-sample measurement is taken. Reports `/api/health` p50/p99, each heavy
//! GET's first (cold) answer and p50 under load, the answers that were not
//! 200 or never came (each poll gives up after 60 s), and the 40-sample
//! measurement's duration alone and under load (the mock's speed given).
//! Goals: health p99 ≤ 50 ms, a kept scene page's data ≤ 200 ms.
//!
//! ```text
//! cargo bench --bench heavy_gets [-- --observers N --pollers P --seconds S --mock-speed X] [--json]
//!     defaults: 200 observers, 200 pollers, 20 s, mock speed 0.05
//! ```

#[path = "../tests/common/mod.rs"]
mod common;

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::calibrated::calibrated_booth;
use common::{get_json, post_json, Daemon, TOKEN};
use lightbooth::psychophysics::design::{Configuration, Stimulus};
use lightbooth::psychophysics::observer::SimulatedObserver;
use lightbooth::psychophysics::oddity::OddityModel;
use lightbooth::random::SplitMix64;
use serde_json::json;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

/// How long one poll waits for its answer before it counts as unanswered.
const GIVE_UP: Duration = Duration::from_secs(60);

/// What to run, from the command line.
struct Options {
    observers: usize,
    pollers: usize,
    seconds: f64,
    mock_speed: f64,
    json: bool,
}

fn options() -> Options {
    let mut o = Options {
        observers: 200,
        pollers: 200,
        seconds: 20.0,
        mock_speed: 0.05,
        json: false,
    };
    let mut args = std::env::args().skip(1);
    let number = |flag: &str, v: Option<String>| -> f64 {
        let v = v.unwrap_or_else(|| panic!("{flag} needs a number"));
        v.parse().unwrap_or_else(|_| panic!("{flag} {v}: not a number"))
    };
    while let Some(a) = args.next() {
        match a.as_str() {
            "--json" => o.json = true,
            "--observers" => o.observers = number("--observers", args.next()) as usize,
            "--pollers" => o.pollers = number("--pollers", args.next()) as usize,
            "--seconds" => o.seconds = number("--seconds", args.next()),
            "--mock-speed" => o.mock_speed = number("--mock-speed", args.next()),
            // `cargo bench` passes `--bench`.
            _ => {}
        }
    }
    o
}

/// One `GET` with `Connection: close`: its latency and status (`None`:
/// no answer within [`GIVE_UP`], or the connection failed).
async fn get(addr: SocketAddr, path: &str) -> (Duration, Option<u16>) {
    let start = Instant::now();
    let answer = tokio::time::timeout(GIVE_UP, async {
        let mut s = TcpStream::connect(addr).await.ok()?;
        s.write_all(format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n").as_bytes())
            .await
            .ok()?;
        let mut buf = Vec::new();
        s.read_to_end(&mut buf).await.ok()?;
        let head = String::from_utf8_lossy(&buf[..buf.len().min(16)]).to_string();
        head.split_whitespace().nth(1)?.parse::<u16>().ok()
    })
    .await
    .ok()
    .flatten();
    (start.elapsed(), answer)
}

/// The `p` quantile (nearest rank) of latencies, in ms.
fn percentile(latencies: &[Duration], p: f64) -> f64 {
    if latencies.is_empty() {
        return f64::NAN;
    }
    let mut sorted = latencies.to_vec();
    sorted.sort();
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i].as_secs_f64() * 1e3
}

/// A measurement of `samples` posted now: its seconds from creation to
/// its end (as the daemon recorded them), or what went wrong (an
/// overloaded daemon refuses the request: "pool timed out").
async fn measurement_seconds(addr: SocketAddr, samples: u32) -> Result<f64, String> {
    let (s, started) = post_json(
        addr,
        "/api/measurements",
        TOKEN,
        &json!({ "samples": samples }).to_string(),
    )
    .await;
    if s != 202 {
        return Err(format!("POST /api/measurements: {s} {started}"));
    }
    let id = started["id"].as_i64().unwrap();
    let deadline = Instant::now() + Duration::from_secs(900);
    loop {
        let (s, m) = get_json(addr, &format!("/api/measurements/{id}")).await;
        if s == 200 && !matches!(m["state"].as_str(), Some("queued") | Some("running")) {
            if m["state"] != "complete" {
                return Err(format!("measurement {id}: {m}"));
            }
            return Ok(m["finished_at"].as_f64().unwrap() - m["created_at"].as_f64().unwrap());
        }
        if Instant::now() > deadline {
            return Err(format!("measurement {id} did not end in 900 s"));
        }
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
}

/// The configuration a trial names (`OON`: the approximation on the right).
fn configuration(letters: &str) -> Configuration {
    let mut c = [Stimulus::Original; 3];
    for (i, l) in letters.chars().enumerate() {
        if l == 'N' {
            c[i] = Stimulus::Approximation;
        }
    }
    Configuration(c)
}

/// Every trial of one simulated observer (σ = 0.3 ΔE00) through the API.
async fn run_session(
    addr: SocketAddr,
    experiment: i64,
    observer_id: String,
    shown: Arc<Vec<(String, f64)>>,
    seed: u64,
) {
    let observer = SimulatedObserver::new(0.3, OddityModel::Differencing).unwrap();
    let mut rng = SplitMix64(seed);
    let (s, mut view) = post_json(
        addr,
        &format!("/api/experiments/{experiment}/sessions"),
        TOKEN,
        &json!({ "observer": observer_id }).to_string(),
    )
    .await;
    assert_eq!(s, 200, "{view}");
    let sid = view["session"]["id"].as_i64().unwrap();
    let (s, v) = post_json(
        addr,
        &format!("/api/experiment-sessions/{sid}/display"),
        TOKEN,
        &json!({ "frame_ms": 16.7, "client": "bench" }).to_string(),
    )
    .await;
    assert_eq!(s, 200, "{v}");
    while let Some(next) = view["next"].as_object().cloned() {
        let name = next["approximation"].as_str().unwrap();
        let de = shown.iter().find(|(n, _)| n == name).unwrap().1;
        let response = observer.respond(
            configuration(next["configuration"].as_str().unwrap()),
            de / observer.sigma(),
            &mut rng,
        );
        let body = json!({
            "position": next["position"], "response": response as u8, "reaction_ms": 600.0,
            "stimulus_frames": 18, "dropped_frames": 0, "dropped_in_stimulus": false,
            "frame_intervals_ms": vec![16.7; 100],
        });
        let (s, v) = post_json(
            addr,
            &format!("/api/experiment-sessions/{sid}/trials"),
            TOKEN,
            &body.to_string(),
        )
        .await;
        assert_eq!(s, 200, "{v}");
        view = v;
    }
}

/// One heavy GET's figures.
#[derive(Default)]
struct PathFigures {
    cold_ms: f64,
    /// The first answer's status (`None`: none within [`GIVE_UP`]).
    cold_status: Option<u16>,
    latencies: Vec<Duration>,
    not_200: usize,
    unanswered: usize,
}

fn main() {
    let o = options();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async move {
        let d = Daemon::start(o.mock_speed).await;
        let addr = d.addr;
        let t = Instant::now();
        let (profile, measurement) = calibrated_booth(&d).await;
        let (s, e) = post_json(
            addr,
            "/api/experiments",
            TOKEN,
            &json!({
                "measurement_id": measurement, "display_profile_id": profile,
                "approximations": ["nstep3", "nstep9", "nstep81"], "output": "8bit", "seed": 9,
            })
            .to_string(),
        )
        .await;
        assert_eq!(s, 201, "{e}");
        let experiment = e["id"].as_i64().unwrap();
        let shown: Arc<Vec<(String, f64)>> = Arc::new(
            e["check"]["approximations"]
                .as_array()
                .unwrap()
                .iter()
                .map(|c| (c["name"].as_str().unwrap().to_string(), c["delta_e00_shown"].as_f64().unwrap()))
                .collect(),
        );
        // Eight sessions at a time.
        for chunk in (0..o.observers).collect::<Vec<_>>().chunks(8) {
            let sessions: Vec<_> = chunk
                .iter()
                .map(|&k| tokio::spawn(run_session(addr, experiment, format!("sim{k}"), shown.clone(), 7 + k as u64)))
                .collect();
            for s in sessions {
                s.await.unwrap();
            }
        }
        let setup_seconds = t.elapsed().as_secs_f64();
        eprintln!("set up {} observers × 3 approximations in {setup_seconds:.0} s", o.observers);

        let alone = measurement_seconds(addr, 40).await.expect("a measurement with nothing else to do");
        eprintln!("a 40-sample measurement alone: {alone:.1} s");

        let paths: Vec<String> = vec![
            format!("/api/experiments/{experiment}/analysis"),
            format!("/api/experiments/{experiment}/analysis.csv"),
            format!("/api/experiments/{experiment}/analysis.mat"),
            format!("/api/experiments/{experiment}/thresholds.csv"),
            format!("/api/experiments/{experiment}/psychometric.svg"),
            format!("/api/experiments/figure.svg?ids={experiment}"),
            "/api/scenes/white/comparisons".into(),
            "/api/scenes/white/comparisons.csv".into(),
            "/api/scenes/white/comparisons.mat".into(),
            "/api/scenes/white/charts/de.svg".into(),
            "/api/scene-overview".into(),
        ];
        let figures: Arc<Mutex<BTreeMap<String, PathFigures>>> = Arc::new(Mutex::new(BTreeMap::new()));
        // The first answer of each, one at a time (with a daemon that keeps
        // results: the one computation; without: a computation like every other).
        for p in &paths {
            let (latency, status) = get(addr, p).await;
            let mut f = figures.lock().unwrap();
            let f = f.entry(p.clone()).or_default();
            f.cold_ms = latency.as_secs_f64() * 1e3;
            f.cold_status = status;
        }

        let stop = Arc::new(AtomicBool::new(false));
        let pollers: Vec<_> = (0..o.pollers)
            .map(|k| {
                let (stop, figures, path) = (stop.clone(), figures.clone(), paths[k % paths.len()].clone());
                tokio::spawn(async move {
                    while !stop.load(Ordering::Relaxed) {
                        let (latency, status) = get(addr, &path).await;
                        let mut f = figures.lock().unwrap();
                        let f = f.entry(path.clone()).or_default();
                        match status {
                            Some(200) => f.latencies.push(latency),
                            Some(_) => f.not_200 += 1,
                            None => f.unanswered += 1,
                        }
                    }
                })
            })
            .collect();
        let health = {
            let stop = stop.clone();
            tokio::spawn(async move {
                let mut latencies = Vec::new();
                let mut failed = 0;
                while !stop.load(Ordering::Relaxed) {
                    let (latency, status) = get(addr, "/api/health").await;
                    if status == Some(200) {
                        latencies.push(latency);
                    } else {
                        failed += 1;
                    }
                    tokio::time::sleep(Duration::from_millis(100)).await;
                }
                (latencies, failed)
            })
        };
        let loaded = tokio::spawn(async move { measurement_seconds(addr, 40).await });
        tokio::time::sleep(Duration::from_secs_f64(o.seconds)).await;
        let under_load = loaded.await.unwrap();
        stop.store(true, Ordering::Relaxed);
        let (health, health_failed) = health.await.unwrap();
        for p in pollers {
            p.await.unwrap();
        }
        let report = {
            let figures = figures.lock().unwrap();
            json!({
            "engine": "sqlite",
            "observers": o.observers,
            "approximations": 3,
            "pollers": o.pollers,
            "seconds": o.seconds,
            "mock_speed": o.mock_speed,
            "setup_seconds": setup_seconds,
            "health": {
                "requests": health.len() + health_failed,
                "failed": health_failed,
                "p50_ms": percentile(&health, 0.5),
                "p99_ms": percentile(&health, 0.99),
                "max_ms": percentile(&health, 1.0),
            },
            "measurement_40_samples_seconds": {
                "alone": alone,
                "under_load": under_load.as_ref().ok(),
                "under_load_error": under_load.as_ref().err(),
            },
            "heavy_gets": figures.iter().map(|(p, f)| json!({
                "path": p,
                "cold_ms": f.cold_ms,
                "cold_status": f.cold_status,
                "answers": f.latencies.len(),
                "p50_ms": percentile(&f.latencies, 0.5),
                "p99_ms": percentile(&f.latencies, 0.99),
                "not_200": f.not_200,
                "unanswered": f.unanswered,
            })).collect::<Vec<_>>(),
        })
        };
        if o.json {
            println!("{}", serde_json::to_string_pretty(&report).unwrap());
        } else {
            let h = &report["health"];
            println!(
                "{} observers × 3, {} pollers for {} s, mock speed {}",
                o.observers, o.pollers, o.seconds, o.mock_speed
            );
            println!(
                "/api/health: {} requests, p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms, {} failed",
                h["requests"], h["p50_ms"], h["p99_ms"], h["max_ms"], h["failed"]
            );
            match &under_load {
                Ok(t) => println!("40-sample measurement: {alone:.1} s alone, {t:.1} s under load"),
                Err(e) => println!("40-sample measurement: {alone:.1} s alone; under load: {e}"),
            }
            for f in report["heavy_gets"].as_array().unwrap() {
                println!(
                    "{:<48} cold {:>9.1} ms ({}); {:>6} answers, p50 {:>9.1} ms, p99 {:>9.1} ms; {} not 200, {} unanswered",
                    f["path"].as_str().unwrap(),
                    f["cold_ms"].as_f64().unwrap(),
                    f["cold_status"],
                    f["answers"],
                    f["p50_ms"].as_f64().unwrap_or(f64::NAN),
                    f["p99_ms"].as_f64().unwrap_or(f64::NAN),
                    f["not_200"],
                    f["unanswered"]
                );
            }
        }
        d.stop().await;
    });
}
