//! The display calibration through the real daemon with `--mock`: the plan,
//! each colour shown on the simulated display (`POST /api/mock/display`) and
//! measured by the simulated PR-650 on its pty, the profile fitted and
//! stored with its measurement ids, its charts, and bad requests refused
//! with the field named; the same through the ColorCAL MkII's and the
//! LS-100's simulators, and their profile pages in Chromium. Truth: the
//! simulated display's own primaries and γ.

use crate::common;

use std::time::Duration;

use common::{get_json, poll_until, post_json, request, Daemon, TOKEN};
use lightbooth::colorimetry::Observer;
use lightbooth::display::SimulatedDisplay;
use serde_json::{json, Value};

async fn measure_shown(d: &Daemon, drive: &Value) -> i64 {
    let (s, _) = post_json(
        d.addr,
        "/api/mock/display",
        TOKEN,
        &json!({ "drive": drive }).to_string(),
    )
    .await;
    assert_eq!(s, 204);
    let (s, started) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples": 3}"#).await;
    assert_eq!(s, 202, "{started}");
    let id = started["id"].as_i64().unwrap();
    let m = poll_until(
        d.addr,
        &format!("/api/measurements/{id}"),
        Duration::from_secs(60),
        |v| !matches!(v["state"].as_str(), Some("queued") | Some("running")),
    )
    .await;
    assert_eq!(m["state"], "complete", "{m}");
    id
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn calibrating_the_simulated_display_through_the_daemon_recovers_it() {
    let d = Daemon::start(0.0).await;
    let (s, plan) = get_json(d.addr, "/api/display-profiles/plan?steps=8").await;
    assert_eq!(s, 200, "{plan}");
    let mut patches = Vec::new();
    for p in plan["patches"].as_array().unwrap() {
        let id = measure_shown(&d, &p["drive"]).await;
        patches.push(json!({ "drive": p["drive"], "measurement_id": id }));
    }
    let body = json!({ "name": "simulated CRT", "patches": patches }).to_string();
    let (s, row) = post_json(d.addr, "/api/display-profiles", TOKEN, &body).await;
    assert_eq!(s, 201, "{row}");
    let id = row["id"].as_i64().unwrap();

    let (s, stored) = get_json(d.addr, &format!("/api/display-profiles/{id}")).await;
    assert_eq!(s, 200);
    let profile: lightbooth::display::DisplayProfile = serde_json::from_value(stored["profile"].clone()).unwrap();
    assert_eq!(
        profile.measurement_ids.len(),
        patches.len(),
        "provenance: every measurement id"
    );
    let display = SimulatedDisplay::crt().unwrap();
    let truth = display.primary_chromaticities(Observer::JuddVos).unwrap();
    let fitted = profile.primary_chromaticities().unwrap();
    for c in 0..3 {
        let dxy = (fitted[c][0] - truth[c][0]).hypot(fitted[c][1] - truth[c][1]);
        assert!(dxy < 0.002, "primary {c}: Δxy {dxy}");
        let g = profile.transfer[c].gamma / display.gammas()[c];
        assert!((g - 1.0).abs() < 0.01, "channel {c}: γ ratio {g}");
    }
    let (s, list) = get_json(d.addr, "/api/display-profiles").await;
    assert_eq!((s, list[0]["id"].as_i64()), (200, Some(id)));
    for chart in ["primaries.svg", "transfer.svg", "additivity.svg"] {
        let (s, body) = request(
            d.addr,
            "GET",
            &format!("/api/display-profiles/{id}/{chart}"),
            None,
            None,
        )
        .await;
        assert_eq!(s, 200, "{chart}");
        assert!(String::from_utf8_lossy(&body).contains("<svg"), "{chart}");
    }
    let (s, page) = request(d.addr, "GET", "/calibrate", None, None).await;
    assert_eq!(s, 200);
    assert!(String::from_utf8_lossy(&page).contains("calibrate.js"));
    d.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_display_profile_without_a_black_or_from_a_missing_measurement_is_refused_naming_it() {
    let d = Daemon::start(0.0).await;
    let red = measure_shown(&d, &json!([1.0, 0.0, 0.0])).await;
    let body = json!({ "patches": [{ "drive": [1.0, 0.0, 0.0], "measurement_id": red }] }).to_string();
    let (s, e) = post_json(d.addr, "/api/display-profiles", TOKEN, &body).await;
    assert_eq!(s, 400, "{e}");
    assert!(
        e["error"]["message"].as_str().unwrap().contains("no black patch"),
        "{e}"
    );

    let body = json!({ "patches": [{ "drive": [0.0, 0.0, 0.0], "measurement_id": 9999 }] }).to_string();
    let (s, e) = post_json(d.addr, "/api/display-profiles", TOKEN, &body).await;
    assert_eq!(s, 404, "{e}");
    assert!(e["error"]["message"].as_str().unwrap().contains("9999"), "{e}");

    let (s, e) = post_json(d.addr, "/api/mock/display", TOKEN, r#"{"drive": [1.5, 0, 0]}"#).await;
    assert_eq!(s, 400, "{e}");
    assert!(e["error"]["message"].as_str().unwrap().contains("field `drive`"), "{e}");
    let (s, e) = get_json(d.addr, "/api/display-profiles/plan?steps=1").await;
    assert_eq!(s, 400, "{e}");
    assert!(e["error"]["message"].as_str().unwrap().contains("steps"), "{e}");
    let (s, _) = get_json(d.addr, "/api/display-profiles/77").await;
    assert_eq!(s, 404);
    d.stop().await;
}

/// Runs the eight-step plan on the simulated display through the daemon's
/// instrument and posts the profile (`observer` as given); the stored row.
async fn calibrate_through_the_daemon(d: &Daemon) -> Vec<Value> {
    let (s, plan) = get_json(d.addr, "/api/display-profiles/plan?steps=8").await;
    assert_eq!(s, 200, "{plan}");
    let mut patches = Vec::new();
    for p in plan["patches"].as_array().unwrap() {
        let id = measure_shown(d, &p["drive"]).await;
        patches.push(json!({ "drive": p["drive"], "measurement_id": id }));
    }
    patches
}

/// The truth: the simulated display's CIE 1931 Y of a drive.
fn true_luminance(display: &SimulatedDisplay, drive: [f64; 3]) -> f64 {
    lightbooth::colorimetry::xyz_from_radiance(&display.spectrum(drive), Observer::Cie1931)
        .unwrap()
        .y
}

async fn charts_of(d: &Daemon, id: i64) -> Vec<String> {
    let mut out = Vec::new();
    for chart in ["primaries.svg", "transfer.svg", "additivity.svg"] {
        let (s, body) = request(
            d.addr,
            "GET",
            &format!("/api/display-profiles/{id}/{chart}"),
            None,
            None,
        )
        .await;
        let svg = String::from_utf8_lossy(&body).to_string();
        assert_eq!(s, 200, "{chart}: {svg}");
        assert!(svg.contains("<svg"), "{chart}");
        out.push(svg);
    }
    out
}

/// The way most psychophysics labs calibrate: a ColorCAL MkII (its
/// simulator on a pty, `serve --mock colorcal`) reads XYZ of every patch
/// the daemon's simulated display shows. The profile is in the ColorCAL's
/// CIE 1931 observer (another observer is refused rather than mixed), its
/// primaries are the display's own within 0.003 in x, y and its γ within
/// 2 %. Truth: the simulated CRT's spectra and γ (crates/science/src/display/simulated.rs).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_display_is_calibrated_through_the_colorcal_simulator() {
    use lightbooth::instrument::colorcal::ColorCalSettings;
    use lightbooth::instrument::InstrumentSettings;
    let d = Daemon::start_instrument(0.0, InstrumentSettings::ColorCal(ColorCalSettings::default())).await;
    let patches = calibrate_through_the_daemon(&d).await;
    let body = json!({ "name": "CRT by ColorCAL", "observer": "judd-vos-1978", "patches": patches }).to_string();
    let (s, e) = post_json(d.addr, "/api/display-profiles", TOKEN, &body).await;
    assert_eq!(s, 400, "{e}");
    let msg = e["error"]["message"].as_str().unwrap();
    assert!(msg.contains("field `observer`") && msg.contains("cie-1931"), "{msg}");

    let body = json!({ "name": "CRT by ColorCAL", "patches": patches }).to_string();
    let (s, row) = post_json(d.addr, "/api/display-profiles", TOKEN, &body).await;
    assert_eq!(s, 201, "{row}");
    assert_eq!(row["state"], "passed", "{row}");
    assert_eq!(row["profile"]["observer"], "cie-1931");
    assert!(
        row["profile"]["black_xyz"].is_array() && row["profile"]["wavelength_nm"].is_null(),
        "{row}"
    );
    let profile: lightbooth::display::DisplayProfile = serde_json::from_value(row["profile"].clone()).unwrap();
    let display = SimulatedDisplay::crt().unwrap();
    let truth = display.primary_chromaticities(Observer::Cie1931).unwrap();
    let fitted = profile.primary_chromaticities().unwrap();
    for c in 0..3 {
        let dxy = (fitted[c][0] - truth[c][0]).hypot(fitted[c][1] - truth[c][1]);
        assert!(dxy < 0.003, "primary {c}: {:?} against {:?}", fitted[c], truth[c]);
        let g = profile.transfer[c].gamma / display.gammas()[c];
        assert!((g - 1.0).abs() < 0.02, "channel {c}: γ ratio {g}");
    }
    let white = profile.white_xyz().unwrap().y;
    let want = true_luminance(&display, [1.0; 3]);
    assert!((white / want - 1.0).abs() < 0.01, "white Y {white} against {want}");
    let charts = charts_of(&d, row["id"].as_i64().unwrap()).await;
    assert!(
        charts[0].contains("gamut") && charts[0].contains("CIE 1931"),
        "{}",
        charts[0]
    );
    let page = common::run_browser_script("profile_page.mjs", d.addr, common::screenshot_dir()).await;
    d.stop().await;
    page.unwrap_or_else(|e| panic!("{e}"));
}

/// A luminance meter (the LS-100's simulator) calibrates γ only: the
/// profile has each gun's γ within 2 % and each primary's luminance within
/// 1 % of the display's own, says "luminance" in its charts, and has no
/// primaries' colour.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_display_is_calibrated_through_the_ls100_simulator_gamma_only() {
    use lightbooth::instrument::ls100::Ls100Settings;
    use lightbooth::instrument::InstrumentSettings;
    let d = Daemon::start_instrument(0.0, InstrumentSettings::Ls100(Ls100Settings::default())).await;
    let patches = calibrate_through_the_daemon(&d).await;
    let body = json!({ "name": "CRT by LS-100", "patches": patches }).to_string();
    let (s, row) = post_json(d.addr, "/api/display-profiles", TOKEN, &body).await;
    assert_eq!(s, 201, "{row}");
    assert_eq!(row["state"], "passed", "{row}");
    let p = &row["profile"];
    assert!(
        p["luminance_additivity"].is_object() && p["additivity"].is_null(),
        "{p}"
    );
    let profile: lightbooth::display::DisplayProfile = serde_json::from_value(p.clone()).unwrap();
    let display = SimulatedDisplay::crt().unwrap();
    let black = true_luminance(&display, [0.0; 3]);
    let (fitted_black, primaries) = profile.luminances().unwrap();
    assert!(
        (fitted_black / black - 1.0).abs() < 0.02,
        "black {fitted_black} against {black}"
    );
    for c in 0..3 {
        let g = profile.transfer[c].gamma / display.gammas()[c];
        assert!((g - 1.0).abs() < 0.02, "channel {c}: γ ratio {g}");
        let mut drive = [0.0; 3];
        drive[c] = 1.0;
        let want = true_luminance(&display, drive) - black;
        assert!(
            (primaries[c] / want - 1.0).abs() < 0.01,
            "primary {c}: {} cd/m² against {want}",
            primaries[c]
        );
    }
    let e = profile.primary_chromaticities().unwrap_err().to_string();
    assert!(e.contains("luminance meter"), "{e}");
    let charts = charts_of(&d, row["id"].as_i64().unwrap()).await;
    assert!(charts[0].contains("luminance"), "{}", charts[0]);
    assert!(charts[2].contains("additivity in luminance"), "{}", charts[2]);
    let page = common::run_browser_script("profile_page.mjs", d.addr, common::screenshot_dir()).await;
    d.stop().await;
    page.unwrap_or_else(|e| panic!("{e}"));
}
