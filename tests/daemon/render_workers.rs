//! Render workers (`lightbooth worker`) beside a booth's daemon started with
//! `serve --renders workers`, on a real PostgreSQL database (the server
//! `tests/setup.sh` starts). Each worker is the built binary, run in an
//! empty folder: it has no `scenes/` and renders from the scene bundles the
//! daemon stored. A comparison waits for a worker and then arrives with
//! its event; a render asked through the booth's API runs on a worker and
//! a cancel reaches it; a worker killed (SIGKILL) mid-render has the render
//! finished by another worker, never marked interrupted.

use crate::common;

use crate::common::booths;

use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

use common::{get_json, poll_until, post_json, Daemon, TOKEN};
use lightbooth::store::{Store, WorkerJobKind};
use serde_json::Value;

async fn measure(addr: std::net::SocketAddr, scene: &str, target: &str) -> i64 {
    let (status, m) = post_json(
        addr,
        "/api/measurements",
        TOKEN,
        &format!(r#"{{"scene":"{scene}","target":"{target}","samples":2}}"#),
    )
    .await;
    assert_eq!(status, 202, "{m}");
    let id = m["id"].as_i64().unwrap();
    let done = poll_until(addr, &format!("/api/measurements/{id}"), Duration::from_secs(60), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(done["state"], "complete", "{done}");
    id
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_booth_leaving_renders_to_workers_gets_its_comparisons_from_a_worker_without_its_scenes() {
    let db = common::fresh_postgres_database().await;
    let booth = Daemon::start_for_workers(0.0, &db, "north").await;
    let store = Store::open_as_tool(&db).await.unwrap();
    let mut events = common::events(booth.addr).await;
    let m = measure(booth.addr, "white", "patch").await;

    // No worker yet: the comparison waits in the queue, and the daemon does
    // not render it itself.
    let job = store
        .worker_job_of(WorkerJobKind::Comparison, m)
        .await
        .unwrap()
        .expect("queued");
    assert_eq!(job.state, "queued");
    // A negative claim, watched over a window (the bug, issue 46: this was
    // a bare sleep that ignored the status and passed on any body that was
    // not an array): no render starts and no comparison arrives, the job
    // stays queued, and the API answers 200 with an empty array.
    let window = tokio::time::Instant::now() + Duration::from_secs(1);
    while let Ok(Some((name, v))) = tokio::time::timeout_at(window, events.recv()).await {
        assert!(
            name != "render_started" && !(name == "comparison_ready" && v["measurement_id"] == m),
            "the daemon rendered without a worker: {name} {v}"
        );
    }
    let still = store
        .worker_job_of(WorkerJobKind::Comparison, m)
        .await
        .unwrap()
        .expect("queued");
    assert_eq!(still.state, "queued", "claimed without a worker: {still:?}");
    let (status, rows) = get_json(booth.addr, &format!("/api/measurements/{m}/comparisons")).await;
    assert_eq!(status, 200, "{rows}");
    assert_eq!(rows.as_array().expect("an array of comparisons").len(), 0, "{rows}");

    let worker = booths::spawn_worker(&db, 2.0, 10.0).await;
    let ready = common::wait_for(&mut events, "comparison_ready", Duration::from_secs(120), |name, v| {
        name == "comparison_ready" && v["measurement_id"] == m
    })
    .await;
    assert_eq!(ready["scene"], "white");
    let (_, rows) = get_json(booth.addr, &format!("/api/measurements/{m}/comparisons")).await;
    let codings: Vec<&str> = rows
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["coding"].as_str().unwrap())
        .collect();
    assert_eq!(codings.len(), 7, "every coding of the daemon's configuration: {rows}");
    for c in ["rgb", "srgb", "nstep81", "spectral"] {
        assert!(codings.contains(&c), "{c} in {codings:?}");
    }
    // The render behind it is the worker's, of the daemon's scene content.
    let render_id = rows[0]["render_id"].as_i64().unwrap();
    let render = store.get_render(render_id).await.unwrap().unwrap();
    assert_eq!(render.state, "complete");
    let by: Option<i64> = with_daemon_of_render(&db, render_id).await;
    assert_eq!(by, Some(worker.id), "rendered by the worker");
    let job = store.worker_job(job.id).await.unwrap().unwrap();
    assert_eq!(
        (job.state.as_str(), job.worker_id, job.attempts),
        ("done", Some(worker.id), 1)
    );

    // A study asked of the booth runs on the worker too, with its report.
    let (status, s) = post_json(
        booth.addr,
        "/api/studies",
        TOKEN,
        r#"{"scenes":"white","against":"measurements","seeds":1}"#,
    )
    .await;
    assert_eq!(status, 202, "{s}");
    let study = s["id"].as_i64().unwrap();
    let finished = common::wait_for(&mut events, "study_finished", Duration::from_secs(180), |name, v| {
        name == "study_finished" && v["study_id"] == study
    })
    .await;
    assert_eq!(finished["ok"], true, "{finished}");
    let (_, row) = get_json(booth.addr, &format!("/api/studies/{study}")).await;
    assert_eq!(row["state"], "complete", "{row}");
    assert!(!row["files"].as_array().unwrap().is_empty(), "{row}");
    let job = store.worker_job_of(WorkerJobKind::Study, study).await.unwrap().unwrap();
    assert_eq!((job.state.as_str(), job.worker_id), ("done", Some(worker.id)));
    booth.stop().await;
}

/// The `daemon_id` of a render row.
async fn with_daemon_of_render(db: &str, render_id: i64) -> Option<i64> {
    use sqlx::Connection;
    let mut conn = sqlx::PgConnection::connect(db).await.unwrap();
    sqlx::query_scalar("SELECT daemon_id FROM renders WHERE id = $1")
        .bind(render_id)
        .fetch_one(&mut conn)
        .await
        .unwrap()
}

/// A render of WHITE long enough to kill or cancel a worker in: 2²⁰ paths
/// per coding, then each coding alone (several seconds on a 2-core machine).
async fn start_long_render(addr: std::net::SocketAddr) -> i64 {
    let (status, r) = post_json(addr, "/api/scenes/white/renders", TOKEN, r#"{"samples":1048576}"#).await;
    assert_eq!(status, 202, "{r}");
    r["render_id"].as_i64().unwrap()
}

async fn wait_for_job(store: &Store, render: i64, what: &str, mut pred: impl FnMut(&Value) -> bool) -> Value {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(120);
    loop {
        let job = store.worker_job_of(WorkerJobKind::Render, render).await.unwrap();
        let r = store.get_render(render).await.unwrap().unwrap();
        let v = serde_json::json!({
            "job_state": job.as_ref().map(|j| j.state.clone()),
            "worker_id": job.as_ref().and_then(|j| j.worker_id),
            "attempts": job.as_ref().map(|j| j.attempts),
            "render_state": r.state,
            "render_error": r.error,
        });
        if pred(&v) {
            return v;
        }
        assert!(tokio::time::Instant::now() < deadline, "never {what}: {v}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_render_asked_of_a_booth_runs_on_a_worker_and_a_cancel_reaches_it() {
    let db = common::fresh_postgres_database().await;
    let booth = Daemon::start_for_workers(0.0, &db, "north").await;
    let store = Store::open_as_tool(&db).await.unwrap();
    let mut events = common::events(booth.addr).await;
    let worker = booths::spawn_worker(&db, 2.0, 10.0).await;

    let long = start_long_render(booth.addr).await;
    wait_for_job(&store, long, "running on the worker", |v| {
        v["render_state"] == "running" && v["worker_id"] == worker.id
    })
    .await;
    let (status, body) = post_json(booth.addr, &format!("/api/renders/{long}/cancel"), TOKEN, "").await;
    assert!(status < 300, "{status} {body}");
    let ended = wait_for_job(&store, long, "cancelled", |v| v["job_state"] == "cancelled").await;
    assert_eq!(ended["render_state"], "cancelled", "{ended}");
    let finished = common::wait_for(&mut events, "render_finished", Duration::from_secs(30), |name, v| {
        name == "render_finished" && v["render_id"] == long
    })
    .await;
    assert_eq!(finished["ok"], false, "{finished}");

    // The worker is free again: a small render completes, with its event.
    let (status, r) = post_json(booth.addr, "/api/scenes/red/renders", TOKEN, r#"{"samples":256}"#).await;
    assert_eq!(status, 202, "{r}");
    let small = r["render_id"].as_i64().unwrap();
    let finished = common::wait_for(&mut events, "render_finished", Duration::from_secs(120), |name, v| {
        name == "render_finished" && v["render_id"] == small
    })
    .await;
    assert_eq!(finished["ok"], true, "{finished}");
    let (_, row) = get_json(booth.addr, &format!("/api/renders/{small}")).await;
    assert_eq!(row["state"], "complete", "{row}");
    booth.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_killed_mid_render_has_the_render_finished_by_another_never_interrupted() {
    let db = common::fresh_postgres_database().await;
    let booth = Daemon::start_for_workers(0.0, &db, "north").await;
    let store = Store::open_as_tool(&db).await.unwrap();
    let mut first = booths::spawn_worker(&db, 0.3, 1.5).await;
    let render = start_long_render(booth.addr).await;
    wait_for_job(&store, render, "running on the first worker", |v| {
        v["render_state"] == "running" && v["worker_id"] == first.id
    })
    .await;
    first.kill(); // SIGKILL: no stopped_at, the lease runs out

    let second = booths::spawn_worker(&db, 2.0, 10.0).await;
    let taken = wait_for_job(&store, render, "taken by the second worker", |v| {
        v["worker_id"] == second.id
    })
    .await;
    assert_eq!(taken["attempts"], 2, "{taken}");
    let done = wait_for_job(&store, render, "done", |v| {
        v["job_state"] != "running" && v["job_state"] != "queued"
    })
    .await;
    assert_eq!(done["job_state"], "done", "{done}");
    assert_eq!(done["render_state"], "complete", "{done}");
    assert_eq!(done["render_error"], Value::Null, "{done}");
    booth.stop().await;
}

/// Render workers share a PostgreSQL database; on an SQLite file the
/// daemon renders itself, and both commands say so instead of starting.
#[test]
fn workers_on_an_sqlite_file_are_refused_with_what_to_do() {
    let dir = tempfile::tempdir().unwrap();
    let db = format!("sqlite://{}", dir.path().join("lab.sqlite").display());
    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .args(["worker", "--db", &db])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("PostgreSQL database (--db postgres://"), "{err}");

    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let token = dir.path().join("token");
    std::fs::write(&token, TOKEN).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .current_dir(&root)
        .args([
            "serve",
            "--mock",
            "--bind",
            "127.0.0.1:0",
            "--renders",
            "workers",
            "--db",
            &db,
        ])
        .arg("--token-file")
        .arg(&token)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--renders workers needs a database shared with the render workers"),
        "{err}"
    );

    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .current_dir(&root)
        .args(["serve", "--mock", "--renders", "elsewhere"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("`elsewhere` is neither `here`"), "{err}");
}

/// Issue 48, part 1: a camera image set asked of a booth that leaves its
/// renders to workers is cut into batches of paths that two workers
/// render, and merged. The images are the ones one machine renders from
/// the same paths (rendered here in the test process from the repository's
/// scene file, with the image's own settings: the same means within f32
/// rounding, the same standard errors within 0.1 %), both workers took
/// batches, and no batch row is left in the database.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_image_on_two_workers_is_merged_into_one_machines_render_of_the_same_paths() {
    use lightbooth::render::camera::{render_camera_images, CameraSettings};
    use sqlx::Connection;

    let db = common::fresh_postgres_database().await;
    let booth = Daemon::start_for_workers(0.0, &db, "north").await;
    let first = booths::spawn_worker(&db, 2.0, 10.0).await;
    let second = booths::spawn_worker(&db, 2.0, 10.0).await;
    let (status, r) = post_json(booth.addr, "/api/scenes/white/renders", TOKEN, r#"{"samples":64}"#).await;
    assert_eq!(status, 202, "{r}");
    let render = r["render_id"].as_i64().unwrap();
    let row = poll_until(
        booth.addr,
        &format!("/api/renders/{render}"),
        Duration::from_secs(300),
        |r| r["state"] != "queued" && r["state"] != "running",
    )
    .await;
    assert_eq!(row["state"], "complete", "{row}");

    let mut events = common::events(booth.addr).await;
    let body = r#"{"codings":["rgb","nstep9"],"width":96,"min_spp":32,"max_spp":512}"#;
    let (status, v) = post_json(booth.addr, &format!("/api/renders/{render}/images"), TOKEN, body).await;
    assert_eq!(status, 202, "{v}");
    let ids: Vec<i64> = v["images"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["image_id"].as_i64().unwrap())
        .collect();
    let mut ended = Vec::new();
    common::wait_for(&mut events, "image_finished", Duration::from_secs(300), |name, e| {
        if name == "image_finished" && ids.contains(&e["image_id"].as_i64().unwrap_or(0)) {
            assert_eq!(e["state"], "complete", "{e}");
            ended.push(e.clone());
        }
        ended.len() == 2
    })
    .await;

    let mut conn = sqlx::PgConnection::connect(&db).await.unwrap();
    let jobs: Vec<(Option<i64>, String)> =
        sqlx::query_as("SELECT worker_id, state FROM worker_jobs WHERE kind = 'image' ORDER BY id")
            .fetch_all(&mut conn)
            .await
            .unwrap();
    assert_eq!(jobs.len(), 16, "512 paths in passes of 32: 16 batches: {jobs:?}");
    assert!(jobs.iter().all(|(_, s)| s == "done"), "{jobs:?}");
    let by = |w: i64| jobs.iter().filter(|(id, _)| *id == Some(w)).count();
    println!(
        "batches: {} on worker {}, {} on worker {}",
        by(first.id),
        first.id,
        by(second.id),
        second.id
    );
    assert!(
        by(first.id) > 0 && by(second.id) > 0,
        "both workers render batches: {jobs:?}"
    );
    let left: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM image_batches")
        .fetch_one(&mut conn)
        .await
        .unwrap();
    assert_eq!(left, 0, "merged batches leave no row");

    // One machine's render of the same paths, here.
    let (_, info) = get_json(booth.addr, &format!("/api/images/{}", ids[1])).await;
    let s = &info["settings"];
    let scene = lightbooth::render::load_scene(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/white.toml"
    )))
    .unwrap();
    let mut camera = scene.camera.clone().unwrap();
    camera.width = s["width"].as_u64().unwrap() as u32;
    camera.height = s["height"].as_u64().unwrap() as u32;
    let settings = CameraSettings {
        codings: vec!["rgb".parse().unwrap(), "nstep9".parse().unwrap()],
        reference: Some("nstep9".parse().unwrap()),
        se_every_coding: false,
        observer: serde_json::from_value(info["observer"].clone()).unwrap(),
        transport: lightbooth::render::integrator::Transport {
            max_bounces: serde_json::from_value(s["max_bounces"].clone()).unwrap(),
            russian_roulette_from: serde_json::from_value(s["russian_roulette_from"].clone()).unwrap(),
            light_sampler: Default::default(),
        },
        seed: s["seed"].as_u64().unwrap(),
        min_spp: 32,
        first_sample: 0,
        max_spp: 512,
        target_relative_se: None,
        time_budget: None,
    };
    let here =
        tokio::task::spawn_blocking(move || render_camera_images(&scene, &camera, &settings, None, None).unwrap())
            .await
            .unwrap();
    let (status, exr_bytes) = common::request(
        booth.addr,
        "GET",
        &format!("/api/images/{}/image.exr", ids[1]),
        None,
        None,
    )
    .await;
    assert_eq!(status, 200);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("image.exr");
    std::fs::write(&path, &exr_bytes).unwrap();
    let read = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    let channel = |name: &str| -> Vec<f32> {
        let c = read.layer_data[0]
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .unwrap_or_else(|| panic!("no channel {name}"));
        match &c.sample_data {
            exr::prelude::FlatSamples::F32(v) => v.clone(),
            other => panic!("{name}: not f32: {other:?}"),
        }
    };
    let mine = &here.images[1];
    let k = mine.xyz_index() + lightbooth::render::camera::Y;
    let (y, se) = (channel("Y"), channel("SE.Y"));
    let (mut worst_mean, mut worst_se) = (0.0f64, 0.0f64);
    for (p, (m, e)) in mine.plane(k).iter().zip(mine.se_plane(k)).enumerate() {
        let scale = (m.abs() as f64).max(1e-3);
        worst_mean = worst_mean.max((y[p] - m).abs() as f64 / scale);
        worst_se = worst_se.max((se[p] - e).abs() as f64 / (e as f64).max(1e-4 * scale));
    }
    println!(
        "merged on workers against one machine: Y within {worst_mean:.1e}, SE(Y) within {worst_se:.1e} (relative)"
    );
    assert!(worst_mean < 1e-5, "Y differs by {worst_mean} (relative)");
    assert!(worst_se < 1e-3, "SE(Y) differs by {worst_se} (relative)");

    // Cancelled while its batches wait or run: the image ends cancelled,
    // its jobs end and no batch row is left.
    let body = r#"{"coding":"nstep3","width":96,"min_spp":1,"max_spp":4096}"#;
    let (status, v) = post_json(booth.addr, &format!("/api/renders/{render}/images"), TOKEN, body).await;
    assert_eq!(status, 202, "{v}");
    let id = v["image_id"].as_i64().unwrap();
    let deadline = tokio::time::Instant::now() + Duration::from_secs(60);
    while sqlx::query_scalar::<_, i64>("SELECT COUNT(*) FROM worker_jobs WHERE kind = 'image' AND state = 'running'")
        .fetch_one(&mut conn)
        .await
        .unwrap()
        == 0
    {
        assert!(
            tokio::time::Instant::now() < deadline,
            "no batch of the long image started"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let (status, v) = post_json(booth.addr, &format!("/api/images/{id}/cancel"), TOKEN, "{}").await;
    assert_eq!(status, 202, "{v}");
    let end = common::wait_for(&mut events, "image_finished", Duration::from_secs(60), |name, e| {
        name == "image_finished" && e["image_id"] == id
    })
    .await;
    assert_eq!(end["state"], "cancelled", "{end}");
    let deadline = tokio::time::Instant::now() + Duration::from_secs(60);
    loop {
        let (unfinished, rows): (i64, i64) = sqlx::query_as(
            "SELECT (SELECT COUNT(*) FROM worker_jobs WHERE kind = 'image' AND state IN ('queued', 'running')), \
             (SELECT COUNT(*) FROM image_batches)",
        )
        .fetch_one(&mut conn)
        .await
        .unwrap();
        if unfinished == 0 && rows == 0 {
            break;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "{unfinished} batch jobs unfinished, {rows} rows left after the cancel"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    booth.stop().await;
}
