//! The daemon driving a (simulated) Konica Minolta CS-2000 as it drives a
//! PR-650 (`serve --mock cs2000`): a five-sample measurement from the API,
//! every sample stored with its 1 nm spectrum and the unit's own XYZ, and the
//! measurement compared with every coding.

use crate::common;

use std::time::Duration;

use common::{events, get_json, post_json, wait_for, Daemon, TOKEN};
use lightbooth::instrument::cs2000::{Cs2000Settings, Model};
use lightbooth::instrument::InstrumentSettings;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cs2000_booth_measures_five_samples_stores_each_and_compares_every_coding() {
    let settings = Cs2000Settings {
        command_timeout_ms: 2_000,
        measure_timeout_ms: 10_000,
        end_margin_ms: 500,
        gap_timeout_ms: 500,
        ..Cs2000Settings::for_model(Model::Cs2000)
    };
    let d = Daemon::start_instrument(0.0, InstrumentSettings::Cs2000(settings)).await;
    let mut ev = events(d.addr).await;
    let (_, health) = get_json(d.addr, "/api/health").await;
    assert_eq!(health["instrument"]["model"], "CS-2000", "{health}");
    assert_eq!(health["instrument"]["serial"], "20101234", "{health}");
    assert_eq!(health["instrument"]["measures"], "spectrum", "{health}");

    let (status, m) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene": "white", "target": "patch", "samples": 5}"#,
    )
    .await;
    assert_eq!(status, 202, "{m}");
    let id = m["id"].as_i64().unwrap();
    let mut sample_events = 0;
    wait_for(
        &mut ev,
        "the measurement to finish",
        Duration::from_secs(120),
        |name, v| {
            if name == "sample" && v["measurement_id"] == id {
                sample_events += 1;
                assert_eq!(v["radiance"].as_array().map(Vec::len), Some(401), "{v}");
            }
            name == "measurement_finished" && v["measurement_id"] == id
        },
    )
    .await;
    assert_eq!(sample_events, 5);
    let (_, done) = get_json(d.addr, &format!("/api/measurements/{id}")).await;
    assert_eq!(done["state"], "complete", "{done}");
    assert_eq!(done["instrument_model"], "CS-2000");
    let nm = done["wavelength_nm"].as_array().unwrap();
    assert_eq!(nm.len(), 401, "the CS-2000's 1 nm grid, not resampled");
    let samples = done["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 5, "every sample stored");
    for s in samples {
        assert_eq!(s["radiance"].as_array().map(Vec::len), Some(401), "{s}");
        let xyz = s["instrument_XYZ"]
            .as_array()
            .expect("the unit's own XYZ kept with the sample");
        assert_eq!(xyz.len(), 3, "{s}");
    }
    // The WHITE scene's patch reads about 34 cd/m² (booth-scenes.md).
    let y = done["Y"].as_f64().unwrap();
    assert!((25.0..45.0).contains(&y), "Y = {y}");

    wait_for(&mut ev, "the comparison", Duration::from_secs(300), |name, v| {
        name == "comparison_ready" && v["measurement_id"] == id
    })
    .await;
    let (_, c) = get_json(d.addr, "/api/scenes/white/comparisons").await;
    let mut codings: Vec<&str> = c["rows"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["measurement_id"] == id)
        .map(|r| r["coding"].as_str().unwrap())
        .collect();
    codings.sort_unstable();
    assert_eq!(
        codings,
        ["nstep27", "nstep3", "nstep81", "nstep9", "rgb", "spectral", "srgb"],
        "{c}"
    );
    // Its pages' words name the CS-2000 (Calibrate, the Measurements filter).
    common::run_browser_script("instrument_words.mjs", d.addr, common::screenshot_dir())
        .await
        .unwrap_or_else(|e| panic!("{e}"));
    d.stop().await;
}

/// `lightbooth serve` as a lab starts it: `--mock cs2000` simulates the
/// model named on the command line; `--instrument auto` finds the one
/// instrument that identifies itself (here a `mock-cr250` on a pty, named
/// with `--probe-port` because sysfs does not list ptys) and drives it with
/// its model's defaults.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn serve_mock_cs2000_and_serve_instrument_auto_drive_the_model_they_name_or_find() {
    use std::io::{BufRead, BufReader};
    use std::process::{Command, Stdio};

    let manifest = env!("CARGO_MANIFEST_DIR");
    let start = |dir: &std::path::Path, args: &[&str]| {
        std::fs::write(dir.join("token"), TOKEN).unwrap();
        std::fs::write(
            dir.join("lightbooth.toml"),
            format!("scenes_dir = \"{manifest}/scenes\"\n"),
        )
        .unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
            .current_dir(dir)
            .args([
                "serve",
                "--bind",
                "127.0.0.1:0",
                "--config",
                "lightbooth.toml",
                "--mock-speed",
                "0",
            ])
            .args(["--db", &format!("sqlite://{}", dir.join("lab.sqlite").display())])
            .args(["--token-file", dir.join("token").to_str().unwrap()])
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let addr: std::net::SocketAddr = loop {
            let line = lines.next().expect("the daemon printed its address").unwrap();
            if let Some(rest) = line.strip_prefix("lightbooth listening on http://") {
                break rest.trim_end_matches('/').parse().unwrap();
            }
        };
        std::thread::spawn(move || for _ in lines {});
        (child, addr)
    };
    let idle = |v: &serde_json::Value| v["instrument"]["state"] == "idle";

    let dir = tempfile::tempdir().unwrap();
    let (mut child, addr) = start(dir.path(), &["--mock", "cs2000"]);
    let health = common::poll_until(addr, "/api/health", Duration::from_secs(30), idle).await;
    assert_eq!(health["instrument"]["model"], "CS-2000", "{health}");
    child.kill().unwrap();
    child.wait().unwrap();

    let mut sim = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .args(["mock-cr250", "--speed", "0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut port = String::new();
    BufReader::new(sim.stdout.take().unwrap()).read_line(&mut port).unwrap();
    let port = port.trim().to_string();
    let dir = tempfile::tempdir().unwrap();
    let (mut child, addr) = start(dir.path(), &["--instrument", "auto", "--probe-port", &port]);
    let health = common::poll_until(addr, "/api/health", Duration::from_secs(30), idle).await;
    assert_eq!(health["instrument"]["model"], "CR-250", "{health}");
    assert_eq!(health["instrument"]["port"], port.as_str(), "{health}");
    assert_eq!(health["instrument"]["measures"], "spectrum", "{health}");
    child.kill().unwrap();
    child.wait().unwrap();
    sim.kill().unwrap();
    sim.wait().unwrap();
}

/// A colorimeter booth (`serve --mock colorcal`): a five-sample measurement
/// from the API keeps each sample's XYZ and no spectrum, its x, y are the
/// instrument's CIE 1931 ones, named; a spectral view of it (chart, CSV,
/// MAT file) and a reflectance from it are refused naming the ColorCAL and
/// what it measures; and with the daemon in Judd–Vos (the default) it is
/// compared with every coding in its own observer, CIE 1931 (renders weighted
/// with it), each row naming it, never mixed with Judd–Vos; a study against
/// it in Judd–Vos is refused before it is queued, saying why.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_colorcal_booth_keeps_xyz_per_sample_and_refuses_what_needs_a_spectrum() {
    use lightbooth::instrument::colorcal::ColorCalSettings;

    let d = Daemon::start_instrument(0.0, InstrumentSettings::ColorCal(ColorCalSettings::default())).await;
    let (_, health) = get_json(d.addr, "/api/health").await;
    assert_eq!(health["instrument"]["measures"], "XYZ", "{health}");
    assert_eq!(health["observer"], "judd-vos-1978", "the daemon's default: {health}");
    // A study that would measure WHITE first with the ColorCAL cannot run in Judd–Vos.
    let (status, refused) = post_json(
        d.addr,
        "/api/studies",
        TOKEN,
        r#"{"scenes": "white", "measure_missing": true}"#,
    )
    .await;
    assert_eq!(status, 409, "{refused}");
    let message = refused["error"]["message"].as_str().unwrap_or_default();
    assert!(
        message.contains("ColorCAL") && message.contains("cie-1931") && message.contains("reference"),
        "{refused}"
    );
    let mut ev = events(d.addr).await;
    let (status, m) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene": "white", "target": "patch", "samples": 5}"#,
    )
    .await;
    assert_eq!(status, 202, "{m}");
    let id = m["id"].as_i64().unwrap();
    let done = common::poll_until(
        d.addr,
        &format!("/api/measurements/{id}"),
        Duration::from_secs(60),
        |v| v["state"] != "queued" && v["state"] != "running",
    )
    .await;
    assert_eq!(done["state"], "complete", "{done}");
    assert!(done["radiance"].is_null() && done["wavelength_nm"].is_null(), "{done}");
    let samples = done["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 5);
    for s in samples {
        assert!(s["radiance"].is_null(), "{s}");
        assert_eq!(s["instrument_XYZ"].as_array().map(Vec::len), Some(3), "{s}");
    }
    let y = done["Y"].as_f64().unwrap();
    assert!((25.0..45.0).contains(&y), "Y = {y}");
    assert_eq!(
        done["observer"], "cie-1931",
        "a colorimeter's XYZ stays in its own observer: {done}"
    );

    for view in ["spectrum.svg", "spectrum.csv", "spectrum.mat"] {
        let (status, body) = get_json(d.addr, &format!("/api/measurements/{id}/{view}")).await;
        assert_eq!(status, 409, "{view}: {body}");
        let text = body.to_string();
        assert!(text.contains("ColorCAL") && text.contains("XYZ only"), "{view}: {text}");
    }
    let (status, body) = post_json(
        d.addr,
        "/api/reflectances",
        TOKEN,
        &format!(r#"{{"sample_measurement_id": {id}, "standard_measurement_id": {id}, "name": "x"}}"#),
    )
    .await;
    assert_eq!(status, 400, "{body}");
    // Judd–Vos daemon, CIE 1931 instrument: compared in the instrument's
    // observer, every row and the scene's summary naming it.
    wait_for(&mut ev, "the comparison", Duration::from_secs(300), |name, v| {
        name == "comparison_ready" && v["measurement_id"] == id
    })
    .await;
    let (status, c) = get_json(d.addr, &format!("/api/measurements/{id}/comparisons")).await;
    assert_eq!(status, 200, "{c}");
    let rows = c.as_array().unwrap();
    assert_eq!(rows.len(), 7, "every coding: {c}");
    for r in rows {
        assert_eq!(r["observer"], "cie-1931", "{r}");
        assert_eq!(r["measured_X"], done["XYZ"][0], "the ColorCAL's own XYZ: {r}");
        assert!(r["dE00"].as_f64().is_some_and(f64::is_finite), "{r}");
    }
    let (status, scene) = get_json(d.addr, "/api/scenes/white/comparisons").await;
    assert_eq!(status, 200, "{scene}");
    assert_eq!(scene["observer"], "cie-1931", "{scene}");
    assert_eq!(scene["codings"].as_array().map(Vec::len), Some(7), "{scene}");
    // WHITE measured: a study against it in Judd–Vos is refused, not failed after a 202.
    let (status, refused) = post_json(d.addr, "/api/studies", TOKEN, r#"{"scenes": "white"}"#).await;
    assert_eq!(status, 409, "{refused}");
    let message = refused["error"]["message"].as_str().unwrap_or_default();
    assert!(
        message.contains(&format!("measurement {id}")) && message.contains("cannot be recomputed in another observer"),
        "{refused}"
    );
    // Its pages' words name the ColorCAL; the scene page shows its comparison.
    common::run_browser_script("instrument_words.mjs", d.addr, common::screenshot_dir())
        .await
        .unwrap_or_else(|e| panic!("{e}"));
    d.stop().await;
}
