//! The store against a real SQLite file.

use super::*;

async fn temp_store() -> (tempfile::TempDir, Store, String) {
    let dir = tempfile::tempdir().unwrap();
    let url = format!("sqlite://{}", dir.path().join("t.sqlite").display());
    let store = Store::open(&url).await.unwrap();
    (dir, store, url)
}

fn new_measurement() -> NewMeasurement {
    NewMeasurement {
        session_id: None,
        scene: Some("white".into()),
        target: Some("patch".into()),
        samples: 5,
        settings_json: serde_json::json!({"port": "/dev/null"}),
        note: String::new(),
    }
}

fn sample(index: usize, usable: bool) -> NewSample {
    NewSample {
        index,
        taken_at: now(),
        code: if usable { 0 } else { 18 },
        message: "ok".into(),
        usable,
        radiance: usable.then(|| vec![0.01, 0.02, 0.03]),
        luminance_cd_m2: usable.then_some(34.0),
    }
}

#[tokio::test]
async fn a_measurement_keeps_every_sample_and_its_average() {
    let (_dir, store, _) = temp_store().await;
    let id = store.create_measurement(&new_measurement()).await.unwrap();
    let inst = store
        .upsert_instrument("PR-650", Some("60931502"), "/dev/pts/3")
        .await
        .unwrap();
    assert_eq!(
        store
            .upsert_instrument("PR-650", Some("60931502"), "/dev/pts/4")
            .await
            .unwrap(),
        inst
    );
    store.mark_running(id, Some(inst)).await.unwrap();
    for i in 0..5 {
        store.insert_sample(id, &sample(i, i != 2)).await.unwrap();
    }
    let avg = Average {
        wavelength_nm: vec![380.0, 384.0, 388.0],
        radiance: vec![0.01, 0.02, 0.03],
        radiance_sd: vec![0.0, 0.001, 0.0],
        luminance_cd_m2: 34.0,
        x: 0.31,
        y: 0.33,
        luminance_cv: 0.002,
        xyz: Some([30.0, 34.0, 20.0]),
        observer: Some(crate::colorimetry::Observer::JuddVos),
    };
    store.complete_measurement(id, &avg).await.unwrap();
    let m = store.get_measurement(id).await.unwrap().unwrap();
    // The instrument's CIE 1931 x,y and lightbooth's own (with its observer)
    // are separate, named fields.
    assert_eq!(
        (m.summary.instrument_x, m.summary.instrument_y),
        (Some(0.31), Some(0.33))
    );
    assert_eq!(m.summary.observer, Some(crate::colorimetry::Observer::JuddVos));
    assert!((m.summary.x.unwrap() - 30.0 / 84.0).abs() < 1e-12);
    assert_eq!(m.summary.state, MeasurementState::Complete);
    assert_eq!(m.samples.len(), 5);
    assert_eq!(m.summary.samples_taken, 5);
    assert!(!m.samples[2].usable && m.samples[2].radiance.is_none());
    assert_eq!(m.radiance.unwrap(), vec![0.01, 0.02, 0.03]);
    // Completing twice is a conflict, not a silent overwrite.
    assert!(store.complete_measurement(id, &avg).await.is_err());
}

#[tokio::test]
async fn complete_without_an_average_is_refused_by_the_schema() {
    let (_dir, store, _) = temp_store().await;
    let id = store.create_measurement(&new_measurement()).await.unwrap();
    let r = sqlx::query("UPDATE measurements SET state = 'complete' WHERE id = ?")
        .bind(id)
        .execute(store.pool())
        .await;
    assert!(r.is_err(), "a complete measurement must carry its average");
}

#[tokio::test]
async fn reopening_marks_unfinished_measurements_interrupted_and_keeps_their_samples() {
    let (_dir, store, url) = temp_store().await;
    let id = store.create_measurement(&new_measurement()).await.unwrap();
    store.mark_running(id, None).await.unwrap();
    store.insert_sample(id, &sample(0, true)).await.unwrap();
    store.insert_sample(id, &sample(1, true)).await.unwrap();
    let queued = store.create_measurement(&new_measurement()).await.unwrap();
    store.pool().close().await;
    let store = Store::open(&url).await.unwrap();
    let m = store.get_measurement(id).await.unwrap().unwrap();
    assert_eq!(m.summary.state, MeasurementState::Interrupted);
    assert_eq!(m.samples.len(), 2);
    assert!(m.radiance.is_none());
    let q = store.get_measurement(queued).await.unwrap().unwrap();
    assert_eq!(q.summary.state, MeasurementState::Interrupted);
}

#[tokio::test]
async fn listing_filters_and_pages() {
    let (_dir, store, _) = temp_store().await;
    for i in 0..7 {
        let mut m = new_measurement();
        m.scene = Some(if i % 2 == 0 { "white" } else { "red" }.into());
        store.create_measurement(&m).await.unwrap();
    }
    let page = store
        .list_measurements(&MeasurementFilter {
            scene: Some("white".into()),
            limit: Some(2),
            ..Default::default()
        })
        .await
        .unwrap();
    assert_eq!(page.total, 4);
    assert_eq!(page.items.len(), 2);
    assert!(page.items[0].id > page.items[1].id, "newest first");
    let all = store.list_measurements(&MeasurementFilter::default()).await.unwrap();
    assert_eq!(all.total, 7);
}

#[tokio::test]
async fn comparisons_are_all_or_nothing() {
    let (_dir, store, _) = temp_store().await;
    let mid = store.create_measurement(&new_measurement()).await.unwrap();
    let rid = store
        .create_render(&NewRender {
            scene: "white".into(),
            scene_hash: "abc".into(),
            settings_json: serde_json::json!({}),
            codings: vec!["rgb".into(), "spectral".into()],
            seed: 1,
        })
        .await
        .unwrap();
    let row = |coding: &str| NewComparison {
        measurement_id: mid,
        render_id: rid,
        scene: "white".into(),
        target: "patch".into(),
        coding: coding.into(),
        observer: crate::colorimetry::Observer::Cie1931,
        white_source: "D65".into(),
        white: [95.0, 100.0, 108.9],
        measured: [30.0, 32.0, 35.0],
        measured_y_se: 0.04,
        rendered: [31.0, 33.0, 34.0],
        rendered_y_se: 0.05,
        y_ratio: 33.0 / 32.0,
        xy_distance: 0.001,
        de76: 1.2,
        de00: 0.8,
    };
    // The second row duplicates the first: the whole batch must fail.
    assert!(store.insert_comparisons(&[row("rgb"), row("rgb")]).await.is_err());
    assert!(store.comparisons_for_measurement(mid).await.unwrap().is_empty());
    store.insert_comparisons(&[row("rgb"), row("spectral")]).await.unwrap();
    let latest = store.latest_comparisons("white").await.unwrap();
    assert_eq!(latest.len(), 2);
    assert_eq!(latest[0].coding, "rgb");
    // Each row names its observer; |33 − 32| = 1 cd/m² is 16 combined SEs
    // (√(0.05² + 0.04²) = 0.064): beyond noise.
    assert_eq!(latest[0].observer, crate::colorimetry::Observer::Cie1931);
    assert_eq!(latest[0].measured_Y_se, Some(0.04));
    assert_eq!(latest[0].Y_beyond_noise, Some(true));
    let json = serde_json::to_value(&latest[0]).unwrap();
    assert_eq!(json["observer"], "cie-1931");
    // A white update rewrites the white and ΔE of exactly the named rows.
    store
        .update_comparison_whites(&[(latest[0].id, "measurement 9".into(), [30.0, 32.0, 35.0], 2.5, 1.5)])
        .await
        .unwrap();
    let rows = store.comparisons_of_scene("white").await.unwrap();
    let changed = rows.iter().find(|r| r.id == latest[0].id).unwrap();
    assert_eq!(
        (changed.white_source.as_str(), changed.white_Y, changed.dE76),
        ("measurement 9", 32.0, 2.5)
    );
    let other = rows.iter().find(|r| r.id == latest[1].id).unwrap();
    assert_eq!(other.white_source, "D65");
}

fn new_render() -> NewRender {
    NewRender {
        scene: "white".into(),
        scene_hash: "0123456789abcdef".into(),
        settings_json: serde_json::json!({"samples": 2048}),
        codings: vec!["rgb".into()],
        seed: 1,
    }
}

#[tokio::test]
async fn renders_and_studies_left_running_by_a_crash_are_interrupted_when_the_store_reopens() {
    let (_dir, store, url) = temp_store().await;
    let running = store.create_render(&new_render()).await.unwrap();
    assert!(store.start_job(Job::Render, running).await.unwrap());
    let queued = store.create_render(&new_render()).await.unwrap();
    let done = store.create_render(&new_render()).await.unwrap();
    store.start_job(Job::Render, done).await.unwrap();
    store
        .finish_render(done, Ok((&serde_json::json!({"targets": []}), 1.0)))
        .await
        .unwrap();
    let study = store
        .create_study(&serde_json::json!({"scenes": "white"}))
        .await
        .unwrap();
    assert!(store.start_job(Job::Study, study).await.unwrap());
    store.pool().close().await;

    let store = Store::open(&url).await.unwrap();
    for id in [running, queued] {
        let r = store.get_render(id).await.unwrap().unwrap();
        assert_eq!(r.state, "interrupted");
        assert!(r.error.unwrap().contains("retry it with POST /api/renders/{id}/retry"));
    }
    assert_eq!(store.get_render(done).await.unwrap().unwrap().state, "complete");
    let s = store.get_study(study).await.unwrap().unwrap();
    assert_eq!(s.state, "interrupted");
    assert!(s.error.unwrap().contains("/api/studies/{id}/retry"));
    // An ended job does not start again.
    assert!(!store.start_job(Job::Render, running).await.unwrap());
}

#[tokio::test]
async fn job_states_move_only_forward() {
    let (_dir, store, _) = temp_store().await;
    let id = store.create_render(&new_render()).await.unwrap();
    assert_eq!(
        store.job_state(Job::Render, id).await.unwrap().as_deref(),
        Some("queued")
    );
    assert!(store
        .end_job(Job::Render, id, JobEnd::Cancelled, "by a test")
        .await
        .unwrap());
    assert!(
        !store.start_job(Job::Render, id).await.unwrap(),
        "a cancelled render never runs"
    );
    assert!(!store.end_job(Job::Render, id, JobEnd::Failed, "late").await.unwrap());
    assert_eq!(
        store.job_state(Job::Render, id).await.unwrap().as_deref(),
        Some("cancelled")
    );
    // A cancelled study keeps no report even if its run finishes afterwards.
    let study = store.create_study(&serde_json::json!({})).await.unwrap();
    store.start_job(Job::Study, study).await.unwrap();
    store
        .end_job(Job::Study, study, JobEnd::Cancelled, "by a test")
        .await
        .unwrap();
    let files = vec![("index.html".to_string(), b"<html>".to_vec())];
    assert!(store
        .complete_study(study, &serde_json::json!({}), 1.0, &files)
        .await
        .is_err());
    assert!(store.get_study(study).await.unwrap().unwrap().files.is_empty());
}

/// Migration 0005 rebuilds `renders` and `studies` (wider state checks):
/// every row, the comparisons that reference renders, and every study file
/// must survive it.
#[tokio::test]
async fn job_state_migration_keeps_renders_comparisons_and_study_files() {
    let dir = tempfile::tempdir().unwrap();
    let old = dir.path().join("migrations");
    std::fs::create_dir(&old).unwrap();
    let all = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("migrations");
    for entry in std::fs::read_dir(&all).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        if name.as_str() < "0005" {
            std::fs::copy(&path, old.join(&name)).unwrap();
        }
    }
    let url = format!("sqlite://{}", dir.path().join("old.sqlite").display());
    {
        let options = SqliteConnectOptions::from_str(&url)
            .unwrap()
            .create_if_missing(true)
            .foreign_keys(true);
        let pool = SqlitePool::connect_with(options).await.unwrap();
        sqlx::migrate::Migrator::new(old.as_path())
            .await
            .unwrap()
            .run(&pool)
            .await
            .unwrap();
        for sql in [
            "INSERT INTO measurements (id, samples_requested, settings_json, state, created_at) \
             VALUES (1, 5, '{}', 'failed', 0)",
            "INSERT INTO renders (id, scene, scene_hash, settings_json, codings, seed, state, created_at, result_json, preview_png) \
             VALUES (7, 'white', 'h', '{}', 'rgb', 1, 'complete', 0, '{}', x'89504e47')",
            "INSERT INTO renders (id, scene, scene_hash, settings_json, codings, seed, state, created_at) \
             VALUES (8, 'white', 'h', '{}', 'rgb', 1, 'running', 0)",
            "INSERT INTO comparisons (measurement_id, render_id, scene, target, coding, white_source, white_x, white_y, \
             white_z, measured_x, measured_y, measured_z, rendered_x, rendered_y, rendered_z, rendered_y_se, y_ratio, \
             xy_distance, de76, de00, created_at) VALUES (1, 7, 'white', 'patch', 'rgb', 'w', 1, 1, 1, 1, 1, 1, 1, 1, 1, \
             0, 1, 0, 0, 0, 0)",
            "INSERT INTO studies (id, request_json, state, created_at, result_json) VALUES (3, '{}', 'complete', 0, '{}')",
            "INSERT INTO study_files (study_id, name, content) VALUES (3, 'index.html', x'3c68746d6c3e')",
        ] {
            sqlx::query(sql).execute(&pool).await.unwrap();
        }
        pool.close().await;
    }
    let store = Store::open(&url).await.unwrap();
    let kept = store.get_render(7).await.unwrap().unwrap();
    assert_eq!(kept.state, "complete");
    assert_eq!(store.render_preview(7).await.unwrap().unwrap(), b"\x89PNG".to_vec());
    assert_eq!(store.get_render(8).await.unwrap().unwrap().state, "interrupted");
    assert_eq!(store.comparisons_for_measurement(1).await.unwrap().len(), 1);
    let study = store.get_study(3).await.unwrap().unwrap();
    assert_eq!(study.files, vec!["index.html".to_string()]);
    assert_eq!(
        store.study_file(3, "index.html").await.unwrap().unwrap(),
        b"<html>".to_vec()
    );
    let violations = sqlx::query("PRAGMA foreign_key_check")
        .fetch_all(store.pool())
        .await
        .unwrap();
    assert!(violations.is_empty(), "no dangling references after the rebuild");
}
