//! Camera images of a render through the daemon's API (a whole daemon on
//! loopback): queued as jobs with progress events, refused beyond the work
//! limit, downloaded as EXR and read back by the `exr` crate, a pixel probe
//! checked against the radiometer render of a CYLINDER target (independent
//! paths: the radiometer's Sobol field samples, not the camera's pixels),
//! and the ΔE00 map's properties.

use crate::common;

use std::collections::HashMap;
use std::path::Path;
use std::time::Duration;

use common::{events, get_json, post_json, request, wait_for, Daemon, TOKEN};
use glam::DVec3;
use lightbooth::render::load_scene;
use serde_json::Value;

/// The default render of a scene (what comparisons and the CIELAB white
/// reuse), complete.
async fn default_render(d: &Daemon, scene: &str) -> (i64, Value) {
    let (status, v) = post_json(d.addr, &format!("/api/scenes/{scene}/renders"), TOKEN, "{}").await;
    assert_eq!(status, 202, "{v}");
    let id = v["render_id"].as_i64().unwrap();
    let row = common::poll_until(d.addr, &format!("/api/renders/{id}"), Duration::from_secs(600), |r| {
        r["state"] != "queued" && r["state"] != "running"
    })
    .await;
    assert_eq!(row["state"], "complete", "{row}");
    (id, row)
}

/// Queues an image and waits for its end on the event stream; returns its
/// id and the progress events seen.
async fn image(d: &Daemon, render: i64, body: &str) -> (i64, Vec<Value>) {
    let mut rx = events(d.addr).await;
    let (status, v) = post_json(d.addr, &format!("/api/renders/{render}/images"), TOKEN, body).await;
    assert_eq!(status, 202, "{body}: {v}");
    let id = v["image_id"].as_i64().unwrap();
    let mut progress = Vec::new();
    let end = wait_for(&mut rx, "image_finished", Duration::from_secs(300), |name, e| {
        if name == "image_progress" && e["image_id"] == id {
            progress.push(e.clone());
        }
        name == "image_finished" && e["image_id"] == id
    })
    .await;
    assert_eq!(end["state"], "complete", "{end}");
    (id, progress)
}

/// Where a world point lands in the scene camera scaled to `width` × `height`
/// (pixel coordinates, x from the left, y from the top): the pinhole
/// projection written out here, not the daemon's.
fn project(camera: &lightbooth::render::scene::Camera, width: u32, height: u32, p: DVec3) -> (f64, f64) {
    let forward = (camera.look_at - camera.position).normalize();
    let right = forward.cross(camera.up).normalize();
    let up = right.cross(forward);
    let d = p - camera.position;
    let tan_half = (camera.fov_deg.to_radians() / 2.0).tan();
    let aspect = width as f64 / height as f64;
    let px = d.dot(right) / d.dot(forward) / (tan_half * aspect);
    let py = d.dot(up) / d.dot(forward) / tan_half;
    ((px + 1.0) / 2.0 * width as f64, (1.0 - py) / 2.0 * height as f64)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn camera_images_queue_report_progress_download_probe_and_compare() {
    let d = Daemon::start(0.0).await;
    let (render, _) = default_render(&d, "cylinder").await;

    // Beyond the work limit: refused, naming the limit, nothing queued.
    let (status, v) = post_json(
        d.addr,
        &format!("/api/renders/{render}/images"),
        TOKEN,
        r#"{"coding":"spectral","width":320,"max_spp":4096}"#,
    )
    .await;
    assert_eq!(status, 400, "{v}");
    let message = v["error"]["message"].as_str().unwrap();
    assert!(
        message.contains("MAX_IMAGE_WORK") && message.contains("max_spp"),
        "{message}"
    );
    for (body, field) in [
        (r#"{"coding":"nstep0"}"#, "coding"),
        (r#"{"coding":"rgb","width":4}"#, "width"),
        (r#"{"coding":"rgb","max_spp":0}"#, "max_spp"),
        (r#"{"coding":"rgb","time_budget_s":601}"#, "time_budget_s"),
    ] {
        let (status, v) = post_json(d.addr, &format!("/api/renders/{render}/images"), TOKEN, body).await;
        assert_eq!(status, 400, "{body}: {v}");
        let m = v["error"]["message"].as_str().unwrap();
        assert!(m.contains(&format!("field `{field}`")), "{body}: {m}");
    }
    let (_, listed) = get_json(d.addr, &format!("/api/renders/{render}/images")).await;
    assert_eq!(
        listed.as_array().unwrap().len(),
        0,
        "a refused request left an image: {listed}"
    );

    // A spectral image: progress events after each pass, then complete.
    let body = r#"{"coding":"spectral","min_spp":16,"max_spp":64}"#;
    let (spectral, progress) = image(&d, render, body).await;
    assert!(!progress.is_empty(), "no image_progress event");
    let last = progress.last().unwrap();
    assert_eq!(last["render_id"], render);
    assert_eq!(last["pixels_done"], last["pixels"], "{last}");
    assert!(last["paths"].as_u64().unwrap() > 0 && last["elapsed_seconds"].as_f64().unwrap() > 0.0);
    let (_, info) = get_json(d.addr, &format!("/api/images/{spectral}")).await;
    assert_eq!(info["state"], "complete", "{info}");
    let (w, h) = (
        info["settings"]["width"].as_u64().unwrap() as u32,
        info["settings"]["height"].as_u64().unwrap() as u32,
    );
    assert_eq!((w, h), (96, 72), "the default size keeps the camera's 4:3");
    assert_eq!(info["observer"], "judd-vos-1978");
    // The same request again is the same image.
    let (status, again) = post_json(d.addr, &format!("/api/renders/{render}/images"), TOKEN, body).await;
    assert_eq!(status, 202);
    assert_eq!(
        (again["image_id"].as_i64(), again["reused"].as_bool()),
        (Some(spectral), Some(true))
    );

    // The EXR, read back by the `exr` crate: names, size, values against the probe.
    let (status, exr_bytes) = request(d.addr, "GET", &format!("/api/images/{spectral}/image.exr"), None, None).await;
    assert_eq!(status, 200);
    let dir = tempfile::tempdir().unwrap();
    let exr_path = dir.path().join("image.exr");
    std::fs::write(&exr_path, &exr_bytes).unwrap();
    let read = exr::prelude::read_all_flat_layers_from_file(&exr_path).unwrap();
    let layer = &read.layer_data[0];
    assert_eq!((layer.size.0, layer.size.1), (w as usize, h as usize));
    let channels: HashMap<String, Vec<f32>> = layer
        .channel_data
        .list
        .iter()
        .map(|c| match &c.sample_data {
            exr::prelude::FlatSamples::F32(v) => (c.name.to_string(), v.clone()),
            other => panic!("{}: not f32: {other:?}", c.name),
        })
        .collect();
    assert_eq!(channels.len(), 2 * (401 + 6) + 1);
    for name in [
        "S0.380,000000nm",
        "S0.550,000000nm",
        "S0.780,000000nm",
        "X",
        "Y",
        "Z",
        "L",
        "M",
        "S",
        "SE.Y",
        "SE.S0.550,000000nm",
        "paths",
    ] {
        assert!(channels.contains_key(name), "no channel {name}");
    }
    let (_, px) = get_json(d.addr, &format!("/api/images/{spectral}/pixel?x=40&y=30")).await;
    assert_eq!(
        px["Y"]["mean"].as_f64().unwrap() as f32,
        channels["Y"][30 * w as usize + 40]
    );
    assert_eq!(
        px["mean"][170].as_f64().unwrap() as f32,
        channels["S0.550,000000nm"][30 * w as usize + 40]
    );
    assert_eq!(px["wavelengths_nm"][170], 550.0);
    let (status, _) = request(
        d.addr,
        "GET",
        &format!("/api/images/{spectral}/pixel?x={w}&y=0"),
        None,
        None,
    )
    .await;
    assert_eq!(status, 400, "a probe outside the image");

    // ΔE00 maps: a coding against itself is 0 everywhere; rgb against
    // spectral differs somewhere (the rgb coding's known failure).
    let (rgb, _) = image(&d, render, r#"{"coding":"rgb","min_spp":16,"max_spp":64}"#).await;
    let (status, same) = get_json(d.addr, &format!("/api/images/{spectral}/delta-e?against={spectral}")).await;
    assert_eq!(status, 200, "{same}");
    assert_eq!(same["max"], 0.0);
    assert_eq!(same["values"].as_array().unwrap().len(), (w * h) as usize);
    assert!(
        same["white_source"].as_str().unwrap().contains("h21"),
        "{}",
        same["white_source"]
    );
    let (_, diff) = get_json(d.addr, &format!("/api/images/{rgb}/delta-e?against={spectral}")).await;
    let values: Vec<f64> = diff["values"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(values.iter().all(|v| v.is_finite() && *v >= 0.0));
    assert!(
        diff["max"].as_f64().unwrap() > 0.5,
        "rgb and spectral agree everywhere: {}",
        diff["max"]
    );
    assert!(diff["scale_max"].as_f64().unwrap() >= diff["max"].as_f64().unwrap());
    let (status, png) = request(
        d.addr,
        "GET",
        &format!("/api/images/{rgb}/delta-e.png?against={spectral}"),
        None,
        None,
    )
    .await;
    assert_eq!(status, 200);
    assert_eq!(&png[1..4], b"PNG");
    let (status, png) = request(d.addr, "GET", &format!("/api/images/{rgb}/display.png"), None, None).await;
    assert_eq!((status, &png[1..4]), (200, &b"PNG"[..]));
    d.stop().await;
}

/// A running image stops when cancelled and ends `cancelled`; its pixels are refused (409).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cancelled_camera_image_ends_cancelled_without_pixels() {
    let d = Daemon::start(0.0).await;
    let (status, v) = post_json(
        d.addr,
        "/api/scenes/white/renders",
        TOKEN,
        r#"{"codings":"rgb","samples":64}"#,
    )
    .await;
    assert_eq!(status, 202, "{v}");
    let render = v["render_id"].as_i64().unwrap();
    let mut rx = events(d.addr).await;
    let (status, v) = post_json(
        d.addr,
        &format!("/api/renders/{render}/images"),
        TOKEN,
        r#"{"coding":"nstep3","min_spp":1,"max_spp":4096}"#,
    )
    .await;
    assert_eq!(status, 202, "{v}");
    let id = v["image_id"].as_i64().unwrap();
    wait_for(&mut rx, "image_progress", Duration::from_secs(300), |name, e| {
        name == "image_progress" && e["image_id"] == id
    })
    .await;
    let (status, v) = post_json(d.addr, &format!("/api/images/{id}/cancel"), TOKEN, "{}").await;
    assert_eq!(status, 202, "{v}");
    let end = wait_for(&mut rx, "image_finished", Duration::from_secs(60), |name, e| {
        name == "image_finished" && e["image_id"] == id
    })
    .await;
    assert_eq!(end["state"], "cancelled", "{end}");
    let (status, _) = get_json(d.addr, &format!("/api/images/{id}/pixel?x=0&y=0")).await;
    assert_eq!(status, 409);
    d.stop().await;
}

/// Independent truth for the probe: on WHITE's Spectralon standard (5 cm,
/// matte, lit along its normal: a uniform region about 3.7 × 2.7 pixels in
/// the default image, 13.6 mm per pixel), the 2 × 2 box of pixels centred
/// where the radiometer's target lands (the camera looks at it: the
/// image's centre) has the XYZ of the radiometer render of that target (its
/// own paths and sampler) within their combined standard errors.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pixel_probe_on_the_white_standard_matches_the_radiometer_render_within_se() {
    let d = Daemon::start(0.0).await;
    let (render, row) = default_render(&d, "white").await;
    let (id, _) = image(&d, render, r#"{"coding":"spectral","min_spp":64,"max_spp":64}"#).await;
    let (_, info) = get_json(d.addr, &format!("/api/images/{id}")).await;
    let (w, h) = (
        info["settings"]["width"].as_u64().unwrap() as u32,
        info["settings"]["height"].as_u64().unwrap() as u32,
    );
    let scene = load_scene(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/white.toml"))).unwrap();
    let camera = scene.camera.clone().unwrap();
    let t = scene.target_list.iter().find(|t| t.id == "patch").unwrap();
    let (x, y) = project(&camera, w, h, t.point);
    let (x0, y0) = ((x - 1.0).round() as u32, (y - 1.0).round() as u32);
    println!("patch lands at ({x:.2}, {y:.2}) of {w} × {h}");
    let (status, p) = get_json(d.addr, &format!("/api/images/{id}/pixel?x={x0}&y={y0}&w=2&h=2")).await;
    assert_eq!(status, 200, "{p}");
    let rendered = &row["result"]["targets"][0]["codings"]["spectral"];
    let y_se = rendered["Y_se"].as_f64().unwrap();
    for (k, name) in ["X", "Y", "Z"].into_iter().enumerate() {
        let cam = p[name]["mean"].as_f64().unwrap();
        let cam_se = p[name]["se"].as_f64().unwrap();
        let rad = rendered["XYZ"][k].as_f64().unwrap();
        // The render stores the SE of Y only: X and Z get Y's relative SE.
        let rad_se = y_se / rendered["XYZ"][1].as_f64().unwrap() * rad;
        // The lit patch is almost noise-free (SE ~ 0.01 %), so the box and
        // the 1° field seeing slightly different parts of the spot's beam
        // shows: 0.1 % of the value is allowed for that non-uniformity
        // (0.04 % seen), far below what a wrong pixel or channel gives
        // (a box reaching the 3 % card beside the patch read 17 % low).
        let uniformity = 1e-3 * rad;
        let z = (cam - rad) / (cam_se.powi(2) + rad_se.powi(2) + uniformity.powi(2)).sqrt();
        println!("{name}: camera box {cam:.4} ± {cam_se:.4}, radiometer {rad:.4} ± {rad_se:.4}, z {z:+.2}");
        assert!(cam_se > 0.0 && cam_se < 0.05 * cam, "{name}: SE {cam_se} of {cam}");
        assert!(z.abs() < 4.0, "{name}: z = {z}");
    }
    // The chromaticity is the mean XYZ's.
    let (xx, yy, zz) = (
        p["X"]["mean"].as_f64().unwrap(),
        p["Y"]["mean"].as_f64().unwrap(),
        p["Z"]["mean"].as_f64().unwrap(),
    );
    assert!((p["chromaticity_x"].as_f64().unwrap() - xx / (xx + yy + zz)).abs() < 1e-12);
    d.stop().await;
}

/// The bug (issue 32): camera-image ids started again at 1 after a restart,
/// so image 2 from before answered 404 and the next new image was image 1
/// again: an id a script or the viewer held silently pointed at another
/// image. Ids never repeat across restarts, and an image lost with the
/// restart says so.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn after_a_restart_image_ids_started_again_at_one() {
    let dir = tempfile::tempdir().unwrap();
    let db = format!("sqlite://{}", dir.path().join("lab.sqlite").display());
    let body = r#"{"coding":"rgb","width":8,"max_spp":8}"#;
    let d = Daemon::start_on(0.0, &db).await;
    let (status, v) = post_json(
        d.addr,
        "/api/scenes/white/renders",
        TOKEN,
        r#"{"codings":"rgb","samples":64}"#,
    )
    .await;
    assert_eq!(status, 202, "{v}");
    let render = v["render_id"].as_i64().unwrap();
    let row = common::poll_until(
        d.addr,
        &format!("/api/renders/{render}"),
        Duration::from_secs(300),
        |r| r["state"] != "queued" && r["state"] != "running",
    )
    .await;
    assert_eq!(row["state"], "complete", "{row}");
    let (before, _) = image(&d, render, body).await;
    d.stop().await;

    let d = Daemon::start_on(0.0, &db).await;
    let (status, lost) = get_json(d.addr, &format!("/api/images/{before}")).await;
    assert_eq!(status, 404, "{lost}");
    let message = lost["error"]["message"].as_str().unwrap_or_default();
    assert!(
        message.starts_with(&format!("image {before} was lost with the daemon's restart")),
        "the 404 says why: {lost}"
    );
    let (status, _) = get_json(d.addr, &format!("/api/images/{before}/pixel?x=0&y=0")).await;
    assert_eq!(status, 404);
    let (after, _) = image(&d, render, body).await;
    assert_ne!(
        after, before,
        "the same request after the restart is a new image with a new id"
    );
    assert!(
        after < 1 << 53,
        "ids stay exact as doubles (JavaScript, MATLAB): {after}"
    );
    let (status, _) = get_json(d.addr, &format!("/api/images/{after}")).await;
    assert_eq!(status, 200);
    d.stop().await;
}

/// Issue 48, part 1 through the daemon: one request with a list of
/// `codings` renders them from the same paths, an image each with its own
/// id, the last the reference. The ΔE00 map of a coding against its
/// reference carries the paired difference's noise, below the noise two
/// independent renders would have; two codings of which neither is the
/// reference, or two images of separate requests, say their noise is each
/// image's own. The same request reuses the set; cancelling one image
/// cancels the set; a request naming both `coding` and `codings`, a coding
/// twice or a reference outside the list is refused naming the field.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn codings_asked_together_are_rendered_from_the_same_paths_with_a_paired_delta_e() {
    let d = Daemon::start(0.0).await;
    let (render, _) = default_render(&d, "white").await;
    let url = format!("/api/renders/{render}/images");
    for (body, field) in [
        (r#"{"coding":"rgb","codings":["rgb"]}"#, "fields `coding`, `codings`"),
        (r#"{"codings":[]}"#, "field `codings`"),
        (r#"{"codings":["rgb","nstep9","rgb"]}"#, "field `codings`[2]"),
        (r#"{"codings":["rgb","nstepx"]}"#, "field `codings`[1]"),
        (
            r#"{"codings":["rgb","nstep9"],"reference":"spectral"}"#,
            "field `reference`",
        ),
        (r#"{"width":16}"#, "field `coding`"),
    ] {
        let (status, v) = post_json(d.addr, &url, TOKEN, body).await;
        assert_eq!(status, 400, "{body}: {v}");
        let m = v["error"]["message"].as_str().unwrap();
        assert!(m.contains(field), "{body}: {m}");
    }
    let body = r#"{"codings":["rgb","nstep9","spectral"],"width":24,"min_spp":16,"max_spp":32}"#;
    let mut rx = events(d.addr).await;
    let (status, v) = post_json(d.addr, &url, TOKEN, body).await;
    assert_eq!(status, 202, "{v}");
    let ids: Vec<i64> = v["images"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["image_id"].as_i64().unwrap())
        .collect();
    let codings: Vec<&str> = v["images"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["coding"].as_str().unwrap())
        .collect();
    assert_eq!(codings, ["rgb", "nstep9", "spectral"]);
    assert_eq!(
        v["image_id"].as_i64(),
        Some(ids[2]),
        "the answer's image is the reference"
    );
    let mut ended = Vec::new();
    wait_for(&mut rx, "image_finished", Duration::from_secs(300), |name, e| {
        if name == "image_finished" && ids.contains(&e["image_id"].as_i64().unwrap_or(0)) {
            assert_eq!(e["state"], "complete", "{e}");
            ended.push(e["image_id"].as_i64().unwrap());
        }
        ended.len() == 3
    })
    .await;
    for (id, coding) in ids.iter().zip(&codings) {
        let (_, info) = get_json(d.addr, &format!("/api/images/{id}")).await;
        assert_eq!(info["settings"]["coding"], *coding, "{info}");
        assert_eq!(info["set"], serde_json::json!(ids), "{info}");
        assert_eq!(info["reference_id"].as_i64(), Some(ids[2]));
        assert_eq!(info["settings"]["reference"], "spectral");
    }
    let (status, again) = post_json(d.addr, &url, TOKEN, body).await;
    assert_eq!(status, 202);
    assert_eq!(again["reused"], true);
    assert_eq!(again["image_id"].as_i64(), Some(ids[2]));

    // Against the reference: the paired noise, below the independent one.
    let (status, m) = get_json(d.addr, &format!("/api/images/{}/delta-e?against={}", ids[1], ids[2])).await;
    assert_eq!(status, 200, "{m}");
    let paired = &m["paired"];
    let (np, ni, se) = (
        paired["noise_paired"].as_f64().unwrap(),
        paired["noise_independent"].as_f64().unwrap(),
        paired["se_mean"].as_f64().unwrap(),
    );
    println!(
        "nstep9 against spectral: mean ΔE00 {}, paired noise {np:.4}, independent {ni:.4}, SE of the mean {se:.5}",
        m["mean"]
    );
    assert!(np > 0.0 && np < ni, "paired {np}, independent {ni}");
    assert!(
        se > 0.0 && se < np,
        "SE of the mean {se} against the per-pixel noise {np}"
    );
    assert!(
        m["noise"].as_str().unwrap().starts_with("rendered from the same paths"),
        "{}",
        m["noise"]
    );
    // The reference on the left gives the same.
    let (_, flipped) = get_json(d.addr, &format!("/api/images/{}/delta-e?against={}", ids[2], ids[1])).await;
    assert_eq!(flipped["paired"], m["paired"]);
    // Neither is the reference: no paired noise is kept for that pair.
    let (_, m) = get_json(d.addr, &format!("/api/images/{}/delta-e?against={}", ids[0], ids[1])).await;
    assert!(m["paired"].is_null(), "{}", m["paired"]);
    assert!(m["noise"]
        .as_str()
        .unwrap()
        .starts_with("rendered from independent paths"));
    // A spectral image of its own request: independent paths.
    let (alone, _) = image(
        &d,
        render,
        r#"{"coding":"spectral","width":24,"min_spp":16,"max_spp":32}"#,
    )
    .await;
    assert!(!ids.contains(&alone));
    let (_, m) = get_json(d.addr, &format!("/api/images/{}/delta-e?against={alone}", ids[1])).await;
    assert!(m["paired"].is_null(), "{}", m["paired"]);

    // Cancelling one image of a running set cancels the set.
    let mut rx = events(d.addr).await;
    let (status, v) = post_json(
        d.addr,
        &url,
        TOKEN,
        r#"{"codings":["nstep3","rgb"],"width":16,"min_spp":1,"max_spp":4096}"#,
    )
    .await;
    assert_eq!(status, 202, "{v}");
    let set: Vec<i64> = v["images"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["image_id"].as_i64().unwrap())
        .collect();
    wait_for(&mut rx, "image_progress", Duration::from_secs(300), |name, e| {
        name == "image_progress" && e["image_id"] == set[0]
    })
    .await;
    let (status, v) = post_json(d.addr, &format!("/api/images/{}/cancel", set[0]), TOKEN, "{}").await;
    assert_eq!(status, 202, "{v}");
    let mut cancelled = Vec::new();
    wait_for(&mut rx, "image_finished", Duration::from_secs(60), |name, e| {
        if name == "image_finished" && set.contains(&e["image_id"].as_i64().unwrap_or(0)) {
            assert_eq!(e["state"], "cancelled", "{e}");
            cancelled.push(e["image_id"].as_i64().unwrap());
        }
        cancelled.len() == 2
    })
    .await;
    d.stop().await;
}
