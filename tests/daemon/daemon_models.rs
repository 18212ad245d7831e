//! Each model beside the PR-650 and the CS-2000 as a booth's instrument
//! (`serve --mock colorcal`, `cs100a`, `ls100`, `cr250`, `cr300`): a
//! five-sample measurement from the API, every sample stored with what the
//! instrument gives (a spectrum, XYZ or a luminance), and — where it gives
//! a colour in the daemon's observer — compared with every coding. Truth:
//! the WHITE scene's patch reads about 34 cd/m² (booth-scenes.md).

use crate::common;

use std::time::Duration;

use common::{events, get_json, post_json, wait_for, Daemon, TOKEN};
use lightbooth::colorimetry::Observer;
use lightbooth::instrument::colorcal::ColorCalSettings;
use lightbooth::instrument::cr250::{self, Cr250Settings};
use lightbooth::instrument::ls100::{self, Ls100Settings};
use lightbooth::instrument::InstrumentSettings;
use serde_json::Value;

/// The daemon's event stream (`/api/events`), as [`events`] reads it.
type Events = tokio::sync::mpsc::UnboundedReceiver<(String, Value)>;

/// A five-sample measurement of WHITE's patch; the finished measurement.
async fn five_samples(d: &Daemon) -> (i64, Value, Events) {
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
    let mut sample_events = 0;
    wait_for(
        &mut ev,
        "the measurement to finish",
        Duration::from_secs(120),
        |name, v| {
            if name == "sample" && v["measurement_id"] == id {
                sample_events += 1;
            }
            name == "measurement_finished" && v["measurement_id"] == id
        },
    )
    .await;
    assert_eq!(sample_events, 5, "a progress event per sample");
    let (_, done) = get_json(d.addr, &format!("/api/measurements/{id}")).await;
    assert_eq!(done["state"], "complete", "{done}");
    let samples = done["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 5, "every sample stored: {done}");
    let y = done["Y"].as_f64().unwrap_or(f64::NAN);
    assert!((25.0..45.0).contains(&y), "Y = {y}: {done}");
    (id, done, ev)
}

/// Waits for the comparison and checks it has every coding.
async fn compared_with_every_coding(d: &Daemon, id: i64, ev: &mut Events) {
    wait_for(ev, "the comparison", Duration::from_secs(300), |name, v| {
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
}

/// The colorimeters in a CIE 1931 booth (their own observer): each
/// sample's XYZ kept, no spectrum, compared with every coding.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn colorimeter_booths_in_their_observer_compare_every_coding() {
    for settings in [
        InstrumentSettings::ColorCal(ColorCalSettings::default()),
        InstrumentSettings::Ls100(Ls100Settings::for_model(ls100::Model::Cs100a)),
    ] {
        let d = Daemon::start_instrument_in(0.0, settings, Observer::Cie1931).await;
        let (_, health) = get_json(d.addr, "/api/health").await;
        assert_eq!(health["instrument"]["measures"], "XYZ", "{health}");
        let (id, done, mut ev) = five_samples(&d).await;
        assert!(done["radiance"].is_null(), "{done}");
        assert_eq!(done["observer"], "cie-1931");
        for s in done["samples"].as_array().unwrap() {
            assert_eq!(s["instrument_XYZ"].as_array().map(Vec::len), Some(3), "{s}");
        }
        // A colorimeter's XYZ stays in its observer: asked in its own, its
        // own XYZ; in another, refused, saying why.
        let (status, own) = get_json(d.addr, &format!("/api/measurements/{id}/colorimetry?observer=cie-1931")).await;
        assert_eq!(status, 200, "{own}");
        assert_eq!(own["recomputed_from_spectrum"], false);
        assert_eq!(own["x"], done["x"], "{own}");
        let (status, refused) = get_json(
            d.addr,
            &format!("/api/measurements/{id}/colorimetry?observer=cie-2015-10"),
        )
        .await;
        assert_eq!(status, 409, "{refused}");
        let message = refused["error"]["message"].as_str().unwrap_or_default();
        assert!(
            message.contains("cannot be recomputed in another observer"),
            "{refused}"
        );
        compared_with_every_coding(&d, id, &mut ev).await;
        d.stop().await;
    }
}

/// A luminance meter's booth: Y per sample and the measurement's Y (the
/// meter's own, in its CIE 1931 V(λ)), no x, y; compared with every coding
/// in luminance alone (its own rows: no colour, so no x, y or ΔE), each
/// ratio the rendered Y over the meter's. The WHITE scene's renders agree
/// with the simulator's 34 cd/m² patch to a few per cent (booth-scenes.md),
/// so every coding's ratio is near 1.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_ls100_booth_keeps_each_samples_luminance_and_compares_it() {
    let settings = InstrumentSettings::Ls100(Ls100Settings::for_model(ls100::Model::Ls100));
    let d = Daemon::start_instrument_in(0.0, settings, Observer::Cie1931).await;
    let (_, health) = get_json(d.addr, "/api/health").await;
    assert_eq!(health["instrument"]["measures"], "luminance", "{health}");
    let (id, done, mut ev) = five_samples(&d).await;
    assert!(done["x"].is_null() && done["XYZ"].is_null(), "{done}");
    assert_eq!(done["observer"], "cie-1931");
    for s in done["samples"].as_array().unwrap() {
        assert!(s["instrument_Y"].as_f64().is_some(), "{s}");
    }
    wait_for(
        &mut ev,
        "the luminance comparison",
        Duration::from_secs(300),
        |name, v| name == "comparison_ready" && v["measurement_id"] == id,
    )
    .await;
    let (_, c) = get_json(d.addr, "/api/scenes/white/comparisons").await;
    assert!(
        !c["rows"].as_array().unwrap().iter().any(|r| r["measurement_id"] == id),
        "no colour comparison: {c}"
    );
    let (status, rows) = get_json(d.addr, &format!("/api/measurements/{id}/luminance-comparisons")).await;
    assert_eq!(status, 200, "{rows}");
    let rows = rows.as_array().unwrap();
    let mut codings: Vec<&str> = rows.iter().map(|r| r["coding"].as_str().unwrap()).collect();
    codings.sort_unstable();
    assert_eq!(
        codings,
        ["nstep27", "nstep3", "nstep81", "nstep9", "rgb", "spectral", "srgb"],
        "{rows:?}"
    );
    let measured = done["Y"].as_f64().unwrap();
    for r in rows {
        assert_eq!(r["observer"], "cie-1931", "{r}");
        assert_eq!(r["measured_Y"].as_f64(), Some(measured), "{r}");
        let (rendered, ratio) = (r["rendered_Y"].as_f64().unwrap(), r["Y_ratio"].as_f64().unwrap());
        assert!((ratio - rendered / measured).abs() < 1e-12, "{r}");
        assert!((0.8..1.2).contains(&ratio), "{r}");
        assert!(r["Y_beyond_noise"].is_boolean() && r.get("dE00").is_none(), "{r}");
    }
    // The measurement's page shows these rows, luminances only.
    common::run_browser_script("luminance_comparison.mjs", d.addr, common::screenshot_dir())
        .await
        .unwrap_or_else(|e| panic!("{e}"));
    d.stop().await;
}

/// `serve --mock ls100` and `--mock cs100a` with the default observer
/// (Judd–Vos): each meter's measurement is compared in its own observer
/// (CIE 1931, whose ȳ is V(λ)), the renders weighted with it, never left
/// uncompared — the CS-100A's colour with every coding, the LS-100's
/// luminance alone — and every row and summary names that observer.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn meters_in_a_judd_vos_daemon_are_compared_in_their_own_observer() {
    // The CS-100A: colour, every coding, summarised in CIE 1931.
    let settings = InstrumentSettings::Ls100(Ls100Settings::for_model(ls100::Model::Cs100a));
    let d = Daemon::start_instrument(0.0, settings).await;
    let (_, health) = get_json(d.addr, "/api/health").await;
    assert_eq!(health["observer"], "judd-vos-1978", "{health}");
    let (id, _, mut ev) = five_samples(&d).await;
    compared_with_every_coding(&d, id, &mut ev).await;
    let (_, c) = get_json(d.addr, "/api/scenes/white/comparisons").await;
    assert_eq!(c["observer"], "cie-1931", "{c}");
    for r in c["rows"].as_array().unwrap() {
        assert_eq!(r["observer"], "cie-1931", "{r}");
    }
    let (status, csv) = common::request(d.addr, "GET", "/api/scenes/white/comparisons.csv", None, None).await;
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&csv));
    let mut reader = csv::Reader::from_reader(csv.as_slice());
    let observer_column = reader.headers().unwrap().iter().position(|h| h == "observer");
    let observer_column = observer_column.expect("an observer column");
    let records: Vec<csv::StringRecord> = reader.records().map(Result::unwrap).collect();
    assert_eq!(records.len(), 7, "a row per coding");
    for r in &records {
        assert_eq!(r.get(observer_column), Some("cie-1931"), "{r:?}");
    }
    d.stop().await;

    // The LS-100: luminance alone, every coding, in CIE 1931.
    let settings = InstrumentSettings::Ls100(Ls100Settings::for_model(ls100::Model::Ls100));
    let d = Daemon::start_instrument(0.0, settings).await;
    let (id, _, mut ev) = five_samples(&d).await;
    wait_for(
        &mut ev,
        "the luminance comparison",
        Duration::from_secs(300),
        |name, v| name == "comparison_ready" && v["measurement_id"] == id,
    )
    .await;
    let (status, rows) = get_json(d.addr, &format!("/api/measurements/{id}/luminance-comparisons")).await;
    assert_eq!(status, 200, "{rows}");
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 7, "{rows:?}");
    for r in rows {
        assert_eq!(r["observer"], "cie-1931", "{r}");
        assert!((0.8..1.2).contains(&r["Y_ratio"].as_f64().unwrap()), "{r}");
    }
    // The scene page says why its table and charts are empty; Calibrate names the LS-100.
    common::run_browser_script("instrument_words.mjs", d.addr, common::screenshot_dir())
        .await
        .unwrap_or_else(|e| panic!("{e}"));
    d.stop().await;
}

/// A ColorCAL measurement left without a comparison (refused by an older
/// daemon, or taken as it stopped) is compared when the next daemon
/// starts, in the ColorCAL's observer, with nothing asked.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_measurement_left_uncompared_is_compared_at_start_up() {
    let dir = tempfile::tempdir().unwrap();
    let url = format!("sqlite://{}", dir.path().join("lab.sqlite").display());
    let colorcal = || InstrumentSettings::ColorCal(ColorCalSettings::default());
    let d = Daemon::start_instrument_on(0.0, colorcal(), &url).await;
    let (id, _, mut ev) = five_samples(&d).await;
    compared_with_every_coding(&d, id, &mut ev).await;
    d.stop().await;
    // As an older daemon left it: complete, no comparison.
    let pool = sqlx::SqlitePool::connect(&url).await.unwrap();
    sqlx::query("DELETE FROM comparisons WHERE measurement_id = $1")
        .bind(id)
        .execute(&pool)
        .await
        .unwrap();
    pool.close().await;

    let d = Daemon::start_instrument_on(0.0, colorcal(), &url).await;
    let path = format!("/api/measurements/{id}/comparisons");
    let c = common::poll_until(d.addr, &path, Duration::from_secs(120), |v| {
        v.as_array().is_some_and(|rows| !rows.is_empty())
    })
    .await;
    let rows = c.as_array().unwrap();
    assert_eq!(rows.len(), 7, "every coding: {c}");
    assert!(rows.iter().all(|r| r["observer"] == "cie-1931"), "{c}");
    d.stop().await;
}

/// The Colorimetry Research spectroradiometers in the default (Judd–Vos)
/// booth: each sample's spectrum on the instrument's own grid.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cr250_and_cr300_booths_measure_five_samples_and_compare_every_coding() {
    for model in [cr250::Model::Cr250, cr250::Model::Cr300] {
        let settings = InstrumentSettings::Cr250(Cr250Settings::for_model(model));
        let d = Daemon::start_instrument(0.0, settings).await;
        let (_, health) = get_json(d.addr, "/api/health").await;
        assert_eq!(health["instrument"]["measures"], "spectrum", "{health}");
        let (id, done, mut ev) = five_samples(&d).await;
        let n = done["wavelength_nm"].as_array().unwrap().len();
        for s in done["samples"].as_array().unwrap() {
            assert_eq!(s["radiance"].as_array().map(Vec::len), Some(n), "{s}");
        }
        compared_with_every_coding(&d, id, &mut ev).await;
        d.stop().await;
    }
}
