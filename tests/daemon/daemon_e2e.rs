//! The whole daemon on loopback: a real SQLite file, the simulated PR-650 on
//! a real pty through the real driver, the renderer, the HTTP server. The
//! test plays a MATLAB script and a dashboard: it starts measurements,
//! follows the server-sent events, and reads results back.

use crate::common;

use std::time::Duration;

use common::{events, get_json, poll_until, post_json, wait_for, Daemon, TOKEN};
use serde_json::Value;

fn is_final(v: &Value) -> bool {
    !matches!(v["state"].as_str(), Some("queued") | Some("running") | None)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_measurement_streams_its_samples_and_is_compared_with_every_coding() {
    let d = Daemon::start(0.0).await;
    let mut ev = events(d.addr).await;
    // Unknown scenes and targets are refused with the field named and the choices listed.
    let (status, v) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene":"kitchen","target":"patch"}"#,
    )
    .await;
    assert_eq!(status, 400);
    assert!(
        v["error"]["message"]
            .as_str()
            .unwrap()
            .contains("field `scene`: no scene `kitchen`; available: white, red"),
        "{v}"
    );
    let (status, v) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene":"cylinder","target":"h99"}"#,
    )
    .await;
    assert_eq!(status, 400);
    assert!(v["error"]["message"].as_str().unwrap().contains("h01, h02"), "{v}");
    let (status, _) = get_json(d.addr, "/api/scenes/kitchen").await;
    assert_eq!(status, 404);
    let (status, scenes) = get_json(d.addr, "/api/scenes").await;
    assert_eq!(status, 200);
    assert_eq!(
        scenes.as_array().unwrap().len(),
        7,
        "the five booth scenes, the Cornell box and the material bench"
    );
    let (status, accepted) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene":"white","target":"patch","samples":5}"#,
    )
    .await;
    assert_eq!(status, 202, "{accepted}");
    let id = accepted["id"].as_i64().unwrap();

    let mut sample_events = 0;
    wait_for(
        &mut ev,
        "the measurement to finish",
        Duration::from_secs(120),
        |name, v| {
            if name == "sample" && v["measurement_id"] == id {
                sample_events += 1;
                assert_eq!(
                    v["radiance"].as_array().map(Vec::len),
                    Some(101),
                    "each sample carries its spectrum"
                );
            }
            name == "measurement_finished" && v["measurement_id"] == id
        },
    )
    .await;
    assert_eq!(sample_events, 5);

    let (status, m) = get_json(d.addr, &format!("/api/measurements/{id}")).await;
    assert_eq!(status, 200);
    assert_eq!(m["state"], "complete", "{m}");
    assert_eq!(m["samples"].as_array().unwrap().len(), 5);
    assert_eq!(m["wavelength_nm"].as_array().unwrap().len(), 101);
    // The WHITE scene's Spectralon under the 110 cd spotlight reads about 34 cd/m² (booth-scenes.md).
    let y = m["Y"].as_f64().unwrap();
    assert!((25.0..45.0).contains(&y), "Y = {y}");
    // measurement_list_xy_is_labelled_as_instruments: the instrument's own
    // CIE 1931 x,y are `instrument_x`, `instrument_y`; `x`, `y` are
    // lightbooth's with the daemon's observer, named.
    assert_eq!(m["observer"], "judd-vos-1978", "{m}");
    let (ix, x) = (m["instrument_x"].as_f64().unwrap(), m["x"].as_f64().unwrap());
    assert!(
        ix > 0.3 && x > 0.3 && (ix - x).abs() > 1e-4,
        "instrument {ix} vs Judd–Vos {x}"
    );
    // a_measurements_y_was_the_instruments_cie_1931_luminance: `Y` was the
    // instrument's CIE 1931 luminance shown beside Judd–Vos x, y; now every
    // `Y` is XYZ[1] of the named observer, and the instrument's own is
    // `instrument_Y`.
    let xyz_y = m["XYZ"][1].as_f64().unwrap();
    assert_eq!(y, xyz_y, "Y is XYZ[1] of the observer: {m}");
    // The stored spectrum's colorimetry in any observer: the daemon's own
    // gives the stored x, y; the 10° observers another white point.
    let colorimetry = |observer: &'static str| async move {
        get_json(
            d.addr,
            &format!("/api/measurements/{id}/colorimetry?observer={observer}"),
        )
        .await
    };
    let (status, own) = colorimetry("judd-vos-1978").await;
    assert_eq!(status, 200, "{own}");
    for k in ["x", "y"] {
        assert!(
            (own[k].as_f64().unwrap() - m[k].as_f64().unwrap()).abs() < 1e-12,
            "{own} vs {m}"
        );
    }
    assert_eq!(own["recomputed_from_spectrum"], true);
    for observer in ["cie-1931", "cie-1964-10", "cie-2015-2", "cie-2015-10"] {
        let (status, c) = colorimetry(observer).await;
        assert_eq!(status, 200, "{c}");
        assert_eq!(c["observer"], observer);
        let dx = (c["x"].as_f64().unwrap() - x).abs();
        assert!(dx > 1e-5 && dx < 0.02, "{observer}: x {} vs Judd–Vos {x}", c["x"]);
    }
    let (status, e) = colorimetry("cie-2006").await;
    assert_eq!(status, 400, "{e}");
    let instrument_y = m["instrument_Y"].as_f64().unwrap();
    assert!(
        (instrument_y - y).abs() > 1e-6 && (instrument_y / y - 1.0).abs() < 0.05,
        "the instrument's CIE 1931 Y {instrument_y} is not the Judd–Vos Y {y}"
    );
    for s in m["samples"].as_array().unwrap() {
        let (sy, iy) = (s["Y"].as_f64().unwrap(), s["instrument_Y"].as_f64().unwrap());
        assert!(
            (sy / y - 1.0).abs() < 0.05 && (sy - iy).abs() > 1e-6,
            "a sample's Y is its spectrum's Judd–Vos luminance, not the instrument's: {s}"
        );
    }
    let (_, list) = get_json(d.addr, "/api/measurements").await;
    let listed = &list["items"][0];
    assert_eq!(listed["Y"], m["XYZ"][1], "{listed}");
    assert_eq!(listed["observer"], "judd-vos-1978", "{listed}");
    assert_eq!(listed["instrument_x"], m["instrument_x"]);

    wait_for(&mut ev, "the comparison", Duration::from_secs(300), |name, v| {
        name == "comparison_ready" && v["measurement_id"] == id
    })
    .await;
    let (_, c) = get_json(d.addr, "/api/scenes/white/comparisons").await;
    let codings: Vec<&str> = c["codings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["coding"].as_str().unwrap())
        .collect();
    assert_eq!(
        codings,
        ["rgb", "srgb", "nstep3", "nstep9", "nstep27", "nstep81", "spectral"]
    );
    assert_eq!(c["rows"][0]["white_source"], format!("measurement {id} (white/patch)"));
    // Every comparison names its observer (rows, summaries, the scene).
    assert_eq!(c["observer"], "judd-vos-1978");
    assert_eq!(c["rows"][0]["observer"], "judd-vos-1978");
    assert_eq!(c["codings"][0]["observer"], "judd-vos-1978");
    // The spectral rendering agrees with the (simulated) measurement of its own converged spectrum.
    let spectral = c["codings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["coding"] == "spectral")
        .unwrap();
    assert!(spectral["mean_dE00"].as_f64().unwrap() < 2.0, "{spectral}");
    // Every coding's figures against the PR-650's stated ±4 % (the one
    // figure on record): rms_rel's null — what a systematic scale error
    // drawn from R(−4 %, +4 %) alone gives — has its 95th percentile at
    // 0.95 × 4 % = 3.8 % (closed form of |R(−a, a)|'s quantile); ΔE needs a
    // colour figure, which is not stated, so its third claim is not made.
    for coding in c["codings"].as_array().unwrap() {
        let u = &coding["uncertainty"];
        assert_eq!(u["instrument_model"], "PR-650", "{coding}");
        assert_eq!(u["stated_accuracy"]["luminance_bound_percent"], 4.0, "{u}");
        assert!(u["draws"].as_u64().unwrap() >= 1000, "{u}");
        let null = u["rms_rel"]["null_95th_stated_accuracy"].as_f64().unwrap();
        assert!((null - 0.038).abs() < 0.002, "{null}");
        for t in u["targets"].as_array().unwrap() {
            assert!(t["dE00"]["claims"]["beyond_stated_accuracy"].is_null(), "{t}");
            assert!(t["relative_dY"]["claims"]["beyond_stated_accuracy"].is_boolean(), "{t}");
        }
    }
    assert_eq!(
        spectral["uncertainty"]["rms_rel"]["claims"]["beyond_stated_accuracy"],
        false
    );
    let nstep3 = c["codings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["coding"] == "nstep3")
        .unwrap();
    // Three steps miss WHITE by ΔE*ab 13.6 (the study's table): far beyond
    // the measurement's repeatability.
    assert_eq!(
        nstep3["uncertainty"]["targets"][0]["dE00"]["claims"]["beyond_repeatability"],
        true
    );
    // The simulated PR-650 measured a converged render: its own standard
    // error is in the budget and named (issue 46).
    let truth_se = nstep3["uncertainty"]["simulated_truth_relative_se"].as_f64();
    assert!(truth_se.is_some_and(|se| se > 0.0 && se <= 1e-3), "{truth_se:?}");
    let (status, csv) = common::request(d.addr, "GET", "/api/scenes/white/comparisons.csv", None, None).await;
    assert_eq!(status, 200);
    let csv = String::from_utf8(csv).unwrap();
    let header = csv.lines().next().unwrap();
    for column in [
        "dE00_beyond_stated_accuracy",
        "relative_dY_low95",
        "relative_dY_beyond_repeatability",
        "accuracy_of",
        "truth_se_Y",
    ] {
        assert!(header.split(',').any(|h| h == column), "{column} not in {header}");
    }
    assert!(csv.lines().skip(1).all(|l| l.contains("PR-650")), "{csv}");

    for chart in ["chromaticity", "profile", "rms", "de", "speed"] {
        let (status, body) = common::request(
            d.addr,
            "GET",
            &format!("/api/scenes/white/charts/{chart}.svg"),
            None,
            None,
        )
        .await;
        assert_eq!(status, 200, "{chart}: {}", String::from_utf8_lossy(&body));
        assert!(body.starts_with(b"<svg"));
    }
    let (_, renders) = get_json(d.addr, "/api/scenes/white/renders").await;
    let render_id = renders[0]["id"].as_i64().unwrap();
    assert!(
        renders[0]["result"]["coding_seconds"]["spectral"].as_f64().unwrap() > 0.0,
        "per-coding timings"
    );
    // speed_is_compared_at_fixed_paths: every coding alone at the same fixed
    // paths per target, with rays traced beside the wall time.
    let cost = &renders[0]["result"]["coding_cost"];
    let paths: Vec<i64> = cost
        .as_object()
        .unwrap()
        .values()
        .map(|c| c["paths_per_target"].as_i64().unwrap())
        .collect();
    assert!(paths.len() == 7 && paths.iter().all(|p| *p == paths[0]), "{cost}");
    assert!(cost["spectral"]["rays"].as_i64().unwrap() > cost["spectral"]["paths"].as_i64().unwrap());
    assert!(renders[0]["result"]["cost_definition"]
        .as_str()
        .unwrap()
        .starts_with("fixed paths per target"));
    let (status, png) = common::request(
        d.addr,
        "GET",
        &format!("/api/renders/{render_id}/preview.png"),
        None,
        None,
    )
    .await;
    assert_eq!(status, 200);
    assert!(png.starts_with(b"\x89PNG"), "a PNG preview of the scene");
    let (status, mat) = common::request(
        d.addr,
        "GET",
        &format!("/api/measurements/{id}/spectrum.mat"),
        None,
        None,
    )
    .await;
    assert_eq!(status, 200);
    let parsed = matfile::MatFile::parse(mat.as_slice()).expect("a MAT-file MATLAB can load");
    assert_eq!(parsed.find_by_name("samples").unwrap().size(), &vec![101, 5]);
    d.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cable_pulled_mid_measurement_leaves_it_interrupted_with_its_samples_and_the_next_one_works() {
    // Slow enough (about 0.25 s a sample) to inject the fault between samples.
    let d = Daemon::start(0.05).await;
    let mut ev = events(d.addr).await;
    let (status, first) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples":5}"#).await;
    assert_eq!(status, 202);
    let id = first["id"].as_i64().unwrap();
    wait_for(&mut ev, "two samples", Duration::from_secs(60), |name, v| {
        name == "sample" && v["measurement_id"] == id && v["index"] == 1
    })
    .await;
    let (status, _) = post_json(d.addr, "/api/mock/faults", TOKEN, r#"{"faults":"cable-pull:once"}"#).await;
    assert_eq!(status, 204);
    let m = poll_until(
        d.addr,
        &format!("/api/measurements/{id}"),
        Duration::from_secs(60),
        is_final,
    )
    .await;
    assert_eq!(m["state"], "interrupted", "{m}");
    let kept = m["samples"].as_array().unwrap().len();
    assert!(
        (2..5).contains(&kept),
        "the samples taken before the cable was pulled are kept: {kept}"
    );
    assert!(m["radiance"].is_null(), "an interrupted measurement has no average");
    assert!(m["error"].as_str().unwrap().contains("closed"), "{m}");

    // The daemon reopens the (re-plugged) instrument and the next measurement completes.
    poll_until(d.addr, "/api/health", Duration::from_secs(30), |v| {
        v["instrument"]["state"] == "idle"
    })
    .await;
    let (status, second) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples":3}"#).await;
    assert_eq!(status, 202, "{second}");
    let m2 = poll_until(
        d.addr,
        second["url"].as_str().unwrap(),
        Duration::from_secs(60),
        is_final,
    )
    .await;
    assert_eq!(m2["state"], "complete", "{m2}");
    assert_eq!(m2["samples"].as_array().unwrap().len(), 3);
    d.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_interrupts_the_running_measurement_and_the_queue() {
    let d = Daemon::start(0.2).await;
    let mut ev = events(d.addr).await;
    let (_, running) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples":5}"#).await;
    let (_, queued) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples":5}"#).await;
    let id = running["id"].as_i64().unwrap();
    wait_for(&mut ev, "a first sample", Duration::from_secs(60), |name, v| {
        name == "sample" && v["measurement_id"] == id
    })
    .await;
    let dir = d.stop_keeping_files().await;
    let db = dir.path().join("lab.sqlite");
    let store = lightbooth::store::Store::open(&format!("sqlite://{}", db.display()))
        .await
        .unwrap();
    let m = store.get_measurement(id).await.unwrap().unwrap();
    assert_eq!(m.summary.state, lightbooth::store::MeasurementState::Interrupted);
    assert!(!m.samples.is_empty());
    let q = store
        .get_measurement(queued["id"].as_i64().unwrap())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(q.summary.state, lightbooth::store::MeasurementState::Interrupted);
}

/// CYLINDER's CIELAB white depended on measurement order (140 of 147 rows
/// one white, 7 another) and old rows were never recomputed. Now the scene
/// declares its white (`h21`); measuring other targets first uses the
/// rendering of h21 as a stand-in, and measuring h21 recomputes every row,
/// so all rows of the scene use the same, measured white.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cylinder_rows_all_use_the_white_the_scene_declares() {
    let d = Daemon::start(0.0).await;
    let mut ev = events(d.addr).await;
    let mut ids = Vec::new();
    for target in ["h01", "h10", "h21"] {
        let (status, accepted) = post_json(
            d.addr,
            "/api/measurements",
            TOKEN,
            &format!(r#"{{"scene":"cylinder","target":"{target}","samples":3}}"#),
        )
        .await;
        assert_eq!(status, 202, "{accepted}");
        let id = accepted["id"].as_i64().unwrap();
        wait_for(&mut ev, "a comparison", Duration::from_secs(600), |name, v| {
            name == "comparison_ready" && v["measurement_id"] == id
        })
        .await;
        ids.push(id);
        let (_, c) = get_json(d.addr, "/api/scenes/cylinder/comparisons").await;
        let whites: std::collections::BTreeSet<String> = c["rows"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| format!("{} {}", r["white_source"], r["white_Y"]))
            .collect();
        assert_eq!(whites.len(), 1, "one white for every row: {whites:?}");
        let white = whites.into_iter().next().unwrap();
        if target == "h21" {
            assert!(white.contains(&format!("measurement {id} (cylinder/h21)")), "{white}");
        } else {
            assert!(
                white.contains("not yet measured") && white.contains("cylinder/h21"),
                "{white}"
            );
        }
    }
    // Every row of the scene, not only the newest per target and coding.
    let (_, c) = get_json(d.addr, "/api/scenes/cylinder/comparisons").await;
    let rows = c["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3 * 7);
    for r in rows {
        assert_eq!(
            r["white_source"],
            format!("measurement {} (cylinder/h21)", ids[2]),
            "{r}"
        );
        // ΔE was recomputed with that white: L* of the white itself is 100,
        // so the measured h21 against its own white has ΔE from the rendering only.
        assert!(r["dE76"].as_f64().unwrap().is_finite());
    }
    d.stop().await;
}

/// The Cornell box is the daemon's sixth scene, with the sheet's nine
/// targets, and the simulated PR-650 measures it: the green wall reads green
/// and is compared with every coding. The back wall, the red wall, the short
/// block's top (their spectral radiance peaks above 0.2 W/(sr·m²·nm) at 700
/// nm) and the light (900 000 cd/m²) overload the simulated instrument, as
/// they would a real PR-650 without a neutral-density filter.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_cornell_box_is_listed_and_measurable_with_the_simulated_pr650() {
    let d = Daemon::start(0.0).await;
    let mut ev = events(d.addr).await;
    let (status, scene) = get_json(d.addr, "/api/scenes/cornell_box").await;
    assert_eq!(status, 200, "{scene}");
    assert_eq!(scene["targets"].as_array().map(Vec::len), Some(9), "{scene}");
    let (status, accepted) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene":"cornell_box","target":"green_wall","samples":3}"#,
    )
    .await;
    assert_eq!(status, 202, "{accepted}");
    let id = accepted["id"].as_i64().unwrap();
    wait_for(&mut ev, "a comparison", Duration::from_secs(600), |name, v| {
        name == "comparison_ready" && v["measurement_id"] == id
    })
    .await;
    let (_, m) = get_json(d.addr, &format!("/api/measurements/{id}")).await;
    assert_eq!(m["state"], "complete", "{m}");
    assert!(m["y"].as_f64().unwrap() > 0.5, "the green wall reads green: {m}");
    let (_, c) = get_json(d.addr, "/api/scenes/cornell_box/comparisons").await;
    assert_eq!(c["rows"].as_array().map(Vec::len), Some(7), "{c}");
    d.stop().await;
}

/// The bug (issue 32): two scene measurements posted during a display
/// calibration were queued between its patches; patch 4 ("red 60 %") then
/// read the GREEN scene patch just measured (x 0.3239, y 0.5079), and the
/// profile was stored with red γ 3.18. The calibration holds the
/// instrument: measurements and display changes not naming the hold are
/// refused (409, saying who holds it), so its patches stay clean.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn scene_measurements_posted_during_a_calibration_corrupted_its_patches() {
    let d = Daemon::start(0.0).await;
    let (status, hold) = post_json(
        d.addr,
        "/api/instrument/hold",
        TOKEN,
        r#"{"purpose":"display calibration “lab-lcd”"}"#,
    )
    .await;
    assert_eq!(status, 201, "{hold}");
    let hold = hold["id"].as_i64().unwrap();
    let (_, current) = get_json(d.addr, "/api/instrument/hold").await;
    assert_eq!(current["id"], hold, "{current}");
    let show = format!(r#"{{"drive":[0.6,0,0],"hold":{hold}}}"#);
    let (status, v) = post_json(d.addr, "/api/mock/display", TOKEN, &show).await;
    assert_eq!(status, 204, "{v}");

    // Another client measures the green scene patch and changes the display.
    let (status, refused) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene":"green","target":"patch"}"#,
    )
    .await;
    assert_eq!(status, 409, "a scene measurement during the calibration: {refused}");
    let message = refused["error"]["message"].as_str().unwrap_or_default();
    assert!(
        message.starts_with(
            "a measurement of green/patch refused: the instrument is held by display calibration “lab-lcd”"
        ),
        "{refused}"
    );
    let (status, v) = post_json(d.addr, "/api/mock/display", TOKEN, r#"{"drive":[0,1,0]}"#).await;
    assert_eq!(status, 409, "the display is the calibration's: {v}");
    let (status, v) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples":2}"#).await;
    assert_eq!(status, 409, "a measurement not naming the hold: {v}");

    // The calibration's patch reads the display's red, not the green scene.
    let body = format!(r#"{{"samples":2,"hold":{hold},"note":"display calibration: patch 4 of 24, red 60 %"}}"#);
    let (status, m) = post_json(d.addr, "/api/measurements", TOKEN, &body).await;
    assert_eq!(status, 202, "{m}");
    let url = m["url"].as_str().unwrap().to_string();
    let m = poll_until(d.addr, &url, Duration::from_secs(60), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(m["state"], "complete", "{m}");
    assert_eq!(
        m["hold"],
        serde_json::json!({ "id": hold, "purpose": "display calibration “lab-lcd”" }),
        "the measurement keeps the hold it was taken under"
    );
    let red = lightbooth::display::SimulatedDisplay::crt()
        .unwrap()
        .primary_chromaticities(lightbooth::colorimetry::Observer::JuddVos)
        .unwrap()[0];
    let (x, y) = (m["x"].as_f64().unwrap(), m["y"].as_f64().unwrap());
    assert!(
        (x - red[0]).abs() < 0.05 && (y - red[1]).abs() < 0.05,
        "patch red 60 % at x {x}, y {y}; the display's red primary is at {red:?}"
    );

    // Released: others measure again; the ended hold admits nothing.
    let (status, v) = post_json(d.addr, &format!("/api/instrument/hold/{hold}/release"), TOKEN, "{}").await;
    assert_eq!(status, 200, "{v}");
    let (status, v) = post_json(d.addr, "/api/measurements", TOKEN, &body).await;
    assert_eq!(status, 409, "a measurement of an ended hold: {v}");
    let (status, v) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene":"green","target":"patch","samples":1}"#,
    )
    .await;
    assert_eq!(status, 202, "{v}");
    d.stop().await;
}
