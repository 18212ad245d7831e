//! The store against a real SQLite file and a real PostgreSQL database:
//! every test of the store's behaviour runs on both engines (`sqlite::…`,
//! `postgres::…`; the PostgreSQL ones need `tests/setup.sh`). The tests of
//! one engine's own concerns (SQLite's migration history, the two
//! migration sets' agreement) follow them.

use std::str::FromStr;

use sqlx::sqlite::{SqliteConnectOptions, SqlitePool};

use super::engine::EngineKind;
use super::test_db::{on_both_engines, TestDb};
use super::*;

mod migrations;
mod recovery;

use recovery::*;

on_both_engines!(
    a_measurement_keeps_every_sample_and_its_average,
    complete_without_an_average_is_refused_by_the_schema,
    reopening_marks_unfinished_measurements_interrupted_and_keeps_their_samples,
    listing_filters_and_pages,
    comparisons_are_all_or_nothing,
    renders_and_studies_left_running_by_a_crash_are_interrupted_when_the_store_reopens,
    two_retries_of_one_render_both_queued_a_render,
    job_states_move_only_forward,
    the_queue_reads_only_unfinished_renders_and_studies_oldest_first,
    partial_averages_and_previews_read_back_alike,
    a_cancelled_colorimeter_or_luminance_meter_measurement_had_no_partial_average,
    measurements_and_instruments_name_their_booth_and_list_by_booth_and_model,
    recovery_interrupts_only_the_work_of_gone_daemons_and_rows_naming_none,
    two_daemons_recovering_the_same_gone_daemon_at_once_interrupt_each_row_once,
    booth_counts_follow_every_insert_delete_and_move_of_a_measurement,
    a_page_before_an_id_is_the_page_at_the_matching_offset,
    schema_refused_more_than_99_samples_though_the_limit_is_the_drivers,
    a_booths_white_and_comparisons_are_found_in_that_booth_only,
    a_live_daemons_lease_lapsed_during_a_database_outage_and_a_neighbour_took_its_work,
    a_dead_predecessor_on_this_host_is_recovered_at_once_a_live_one_is_not,
);

/// A fresh database of `engine`, opened (migrated) as a store.
async fn temp_store(engine: EngineKind) -> (TestDb, Store, String) {
    let db = TestDb::new(engine).await;
    let store = Store::open(&db.url).await.unwrap();
    let url = db.url.clone();
    (db, store, url)
}

fn new_measurement() -> NewMeasurement {
    NewMeasurement {
        booth: Booth::default(),
        session_id: None,
        scene: Some("white".into()),
        target: Some("patch".into()),
        samples: 5,
        settings_json: serde_json::json!({"port": "/dev/null"}),
        note: String::new(),
    }
}

/// Two booths in one database: each measurement and instrument keeps its
/// booth; listings filter by booth and by instrument model; the booth list
/// counts each booth's work. Rows from before migration 0009 belong to
/// `default` (tested in `migrations_before_booths_leave_rows_in_the_default_booth`).
async fn measurements_and_instruments_name_their_booth_and_list_by_booth_and_model(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let north: Booth = "north".parse().unwrap();
    let south: Booth = "south".parse().unwrap();
    let pr650 = store
        .upsert_instrument(&north, "PR-650", Some("60931502"), "/dev/pts/3")
        .await
        .unwrap();
    let pr670 = store
        .upsert_instrument(&south, "PR-670", Some("67001234"), "/dev/ttyACM0")
        .await
        .unwrap();
    let mut ids = Vec::new();
    for (booth, instrument) in [(&north, pr650), (&south, pr670), (&south, pr670)] {
        let id = store
            .create_measurement(&NewMeasurement {
                booth: booth.clone(),
                ..new_measurement()
            })
            .await
            .unwrap();
        store.mark_running(id, Some(instrument)).await.unwrap();
        ids.push(id);
    }
    store
        .end_measurement(ids[1], MeasurementState::Failed, "test")
        .await
        .unwrap();
    let page = |booth: Option<&Booth>, model: Option<&str>| {
        let f = MeasurementFilter {
            booth: booth.cloned(),
            instrument_model: model.map(String::from),
            ..Default::default()
        };
        let store = store.clone();
        async move {
            let p = store.list_measurements(&f).await.unwrap();
            assert_eq!(p.total as usize, p.items.len());
            p.items.into_iter().map(|m| (m.id, m.booth)).collect::<Vec<_>>()
        }
    };
    assert_eq!(page(Some(&north), None).await, [(ids[0], "north".to_string())]);
    assert_eq!(
        page(Some(&south), None).await,
        [(ids[2], "south".to_string()), (ids[1], "south".to_string())]
    );
    assert_eq!(page(None, Some("PR-670")).await.len(), 2);
    assert_eq!(page(Some(&north), Some("PR-670")).await, []);
    assert_eq!(page(None, Some("PR-655")).await, []);
    let detail = store.get_measurement(ids[0]).await.unwrap().unwrap();
    assert_eq!(detail.summary.booth, "north");
    assert_eq!(detail.summary.instrument_model.as_deref(), Some("PR-650"));

    let booths = store.list_booths().await.unwrap();
    let summary: Vec<(&str, i64, i64)> = booths
        .iter()
        .map(|b| (b.booth.as_str(), b.measurements, b.unfinished))
        .collect();
    assert_eq!(summary, [("north", 1, 1), ("south", 2, 1)]);
    // An instrument moved to another booth is listed where it was last seen.
    store
        .upsert_instrument(&north, "PR-670", Some("67001234"), "/dev/ttyACM1")
        .await
        .unwrap();
    let instruments = store.list_instruments().await.unwrap();
    assert!(instruments.iter().all(|i| i.booth == "north"), "{instruments:?}");
}

/// The booths' counts (migration 0014's triggers) that `/api/booths` and
/// the listing totals read stay what counting the rows gives, through
/// inserts, a hand-made DELETE and a measurement moved to another booth.
async fn booth_counts_follow_every_insert_delete_and_move_of_a_measurement(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let north: Booth = "north".parse().unwrap();
    let south: Booth = "south".parse().unwrap();
    let mut ids = Vec::new();
    for booth in [&north, &south, &south, &north, &south] {
        let m = NewMeasurement {
            booth: booth.clone(),
            ..new_measurement()
        };
        ids.push(store.create_measurement(&m).await.unwrap());
    }
    let created_at = |id: i64| {
        let store = store.clone();
        async move { store.get_measurement(id).await.unwrap().unwrap().summary.created_at }
    };
    let counts = || async {
        let booths = store.list_booths().await.unwrap();
        let mut out = Vec::new();
        for b in booths {
            let filter = MeasurementFilter {
                booth: Some(b.booth.parse().unwrap()),
                ..Default::default()
            };
            let page = store.list_measurements(&filter).await.unwrap();
            assert_eq!(page.total, b.measurements, "{b:?}: the booth's listing total");
            assert_eq!(page.total as usize, page.items.len());
            out.push((b.booth, b.measurements, b.last_measurement_at));
        }
        let all = store.list_measurements(&MeasurementFilter::default()).await.unwrap();
        assert_eq!(all.total as usize, all.items.len(), "the unfiltered total");
        out
    };
    assert_eq!(
        counts().await,
        [
            ("north".to_string(), 2, Some(created_at(ids[3]).await)),
            ("south".to_string(), 3, Some(created_at(ids[4]).await)),
        ]
    );
    // The newest of south's goes: its newest time falls back to the one before.
    let deleted = store
        .execute_for_test("DELETE FROM measurements WHERE id = $1", ids[4])
        .await
        .unwrap();
    assert_eq!(deleted, 1);
    assert_eq!(
        counts().await,
        [
            ("north".to_string(), 2, Some(created_at(ids[3]).await)),
            ("south".to_string(), 2, Some(created_at(ids[2]).await)),
        ]
    );
    store
        .execute_for_test("UPDATE measurements SET booth = 'east' WHERE id = $1", ids[0])
        .await
        .unwrap();
    assert_eq!(
        counts().await,
        [
            ("east".to_string(), 1, Some(created_at(ids[0]).await)),
            ("north".to_string(), 1, Some(created_at(ids[3]).await)),
            ("south".to_string(), 2, Some(created_at(ids[2]).await)),
        ]
    );
    // A booth whose measurements are all gone is no longer listed.
    store
        .execute_for_test("DELETE FROM measurements WHERE id = $1", ids[0])
        .await
        .unwrap();
    let names: Vec<String> = counts().await.into_iter().map(|(b, _, _)| b).collect();
    assert_eq!(names, ["north", "south"]);
}

/// `before_id` (the cursor of deep pages) gives what `offset` gives, with
/// and without a filter, and the total still counts every match.
async fn a_page_before_an_id_is_the_page_at_the_matching_offset(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let north: Booth = "north".parse().unwrap();
    let mut ids = Vec::new();
    for k in 0..12 {
        let m = NewMeasurement {
            booth: if k % 3 == 0 { north.clone() } else { Booth::default() },
            ..new_measurement()
        };
        ids.push(store.create_measurement(&m).await.unwrap());
    }
    for booth in [None, Some(north)] {
        let filter = MeasurementFilter {
            booth: booth.clone(),
            limit: Some(2),
            ..Default::default()
        };
        let first = store.list_measurements(&filter).await.unwrap();
        let by_offset = store
            .list_measurements(&MeasurementFilter {
                offset: Some(2),
                ..filter.clone()
            })
            .await
            .unwrap();
        let by_cursor = store
            .list_measurements(&MeasurementFilter {
                before_id: Some(first.items[1].id),
                ..filter.clone()
            })
            .await
            .unwrap();
        let item_ids = |p: &MeasurementPage| p.items.iter().map(|m| m.id).collect::<Vec<_>>();
        assert_eq!(item_ids(&by_cursor), item_ids(&by_offset), "booth {booth:?}");
        assert_eq!(item_ids(&by_cursor).len(), 2);
        assert_eq!(by_cursor.total, first.total);
        assert_eq!(first.total, if booth.is_some() { 4 } else { 12 });
    }
    let oldest = store
        .list_measurements(&MeasurementFilter {
            before_id: Some(ids[0]),
            ..Default::default()
        })
        .await
        .unwrap();
    assert!(oldest.items.is_empty());
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
        instrument_xyz: None,
    }
}

async fn a_measurement_keeps_every_sample_and_its_average(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let id = store.create_measurement(&new_measurement()).await.unwrap();
    let inst = store
        .upsert_instrument(&Booth::default(), "PR-650", Some("60931502"), "/dev/pts/3")
        .await
        .unwrap();
    assert_eq!(
        store
            .upsert_instrument(&Booth::default(), "PR-650", Some("60931502"), "/dev/pts/4")
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
        x: Some(0.31),
        y: Some(0.33),
        luminance_cv: 0.002,
        xyz: Some([30.0, 34.0, 20.0]),
        observer: Some(lightbooth_science::colorimetry::Observer::JuddVos),
    };
    store.complete_measurement(id, &avg).await.unwrap();
    let m = store.get_measurement(id).await.unwrap().unwrap();
    // The instrument's CIE 1931 x,y and lightbooth's own (with its observer)
    // are separate, named fields.
    assert_eq!(
        (m.summary.instrument_x, m.summary.instrument_y),
        (Some(0.31), Some(0.33))
    );
    assert_eq!(
        m.summary.observer,
        Some(lightbooth_science::colorimetry::Observer::JuddVos)
    );
    assert!((m.summary.x.unwrap() - 30.0 / 84.0).abs() < 1e-12);
    assert_eq!(m.summary.state, MeasurementState::Complete);
    assert_eq!(m.samples.len(), 5);
    assert_eq!(m.summary.samples_taken, 5);
    assert!(!m.samples[2].usable && m.samples[2].radiance.is_none());
    assert_eq!(m.radiance.unwrap(), vec![0.01, 0.02, 0.03]);
    // Completing twice is a conflict, not a silent overwrite.
    assert!(store.complete_measurement(id, &avg).await.is_err());
}

/// The 1–99 sample limit was the PR-650's, written into the schema (0001's
/// CHECK), so an instrument that averages more could not record its
/// measurement. Since 0012 the schema asks only for at least one sample; the
/// limit is each driver's (`Capabilities::max_samples`).
async fn schema_refused_more_than_99_samples_though_the_limit_is_the_drivers(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let id = store
        .create_measurement(&NewMeasurement {
            samples: 150,
            ..new_measurement()
        })
        .await
        .expect("150 samples are the driver's business, not the schema's");
    let m = store.get_measurement(id).await.unwrap().unwrap();
    assert_eq!(m.summary.samples_requested, 150);
    let none = NewMeasurement {
        samples: 0,
        ..new_measurement()
    };
    assert!(
        store.create_measurement(&none).await.is_err(),
        "a measurement of no samples is still refused by the schema"
    );
}

async fn complete_without_an_average_is_refused_by_the_schema(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let id = store.create_measurement(&new_measurement()).await.unwrap();
    let r = store
        .execute_for_test("UPDATE measurements SET state = 'complete' WHERE id = $1", id)
        .await;
    assert!(r.is_err(), "a complete measurement must carry its average");
}

async fn reopening_marks_unfinished_measurements_interrupted_and_keeps_their_samples(engine: EngineKind) {
    let (_dir, store, url) = temp_store(engine).await;
    let id = store.create_measurement(&new_measurement()).await.unwrap();
    store.mark_running(id, None).await.unwrap();
    store.insert_sample(id, &sample(0, true)).await.unwrap();
    store.insert_sample(id, &sample(1, true)).await.unwrap();
    let queued = store.create_measurement(&new_measurement()).await.unwrap();
    store.close().await;
    let store = Store::open_recovering(&url).await.unwrap();
    let m = store.get_measurement(id).await.unwrap().unwrap();
    assert_eq!(m.summary.state, MeasurementState::Interrupted);
    assert_eq!(m.samples.len(), 2);
    assert!(m.radiance.is_none());
    let q = store.get_measurement(queued).await.unwrap().unwrap();
    assert_eq!(q.summary.state, MeasurementState::Interrupted);
}

async fn listing_filters_and_pages(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
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

async fn comparisons_are_all_or_nothing(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
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
        observer: lightbooth_science::colorimetry::Observer::Cie1931,
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
    assert_eq!(latest[0].observer, lightbooth_science::colorimetry::Observer::Cie1931);
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

/// The queries behind a comparison's CIELAB white: the newest complete
/// white of a booth, and the comparisons a booth's new white applies to,
/// never another booth's (booths share scene ids but not lamps).
async fn a_booths_white_and_comparisons_are_found_in_that_booth_only(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let north: Booth = "north".parse().unwrap();
    let south: Booth = "south".parse().unwrap();
    let avg = Average {
        wavelength_nm: vec![380.0, 384.0, 388.0],
        radiance: vec![0.01, 0.02, 0.03],
        radiance_sd: vec![0.0; 3],
        luminance_cd_m2: 34.0,
        x: Some(0.31),
        y: Some(0.33),
        luminance_cv: 0.002,
        xyz: None,
        observer: None,
    };
    let mut ids = Vec::new();
    // South's white, then north's (newer): south must still find its own.
    for booth in [&south, &north, &north] {
        let id = store
            .create_measurement(&NewMeasurement {
                booth: booth.clone(),
                ..new_measurement()
            })
            .await
            .unwrap();
        store.mark_running(id, None).await.unwrap();
        ids.push(id);
    }
    store.complete_measurement(ids[0], &avg).await.unwrap();
    store.complete_measurement(ids[1], &avg).await.unwrap();
    // ids[2] (north, newest) never completes: not a white.
    let white = |b: &Booth| {
        let store = store.clone();
        let b = b.clone();
        async move {
            store
                .latest_complete_in_booth("white", "patch", &b)
                .await
                .unwrap()
                .map(|m| m.summary.id)
        }
    };
    assert_eq!(white(&south).await, Some(ids[0]));
    assert_eq!(white(&north).await, Some(ids[1]));
    assert_eq!(white(&"east".parse().unwrap()).await, None);
    assert_eq!(store.measurement_booth(ids[1]).await.unwrap(), Some(north.clone()));
    assert_eq!(store.measurement_booth(9_999).await.unwrap(), None);

    let rid = store.create_render(&new_render()).await.unwrap();
    let row = |measurement_id: i64| NewComparison {
        measurement_id,
        render_id: rid,
        scene: "white".into(),
        target: "patch".into(),
        coding: "rgb".into(),
        observer: lightbooth_science::colorimetry::Observer::Cie1931,
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
    store.insert_comparisons(&[row(ids[0])]).await.unwrap();
    store.insert_comparisons(&[row(ids[1])]).await.unwrap();
    let of = |b: Booth| {
        let store = store.clone();
        async move {
            store
                .comparisons_of_scene_in_booth("white", &b)
                .await
                .unwrap()
                .into_iter()
                .map(|r| r.measurement_id)
                .collect::<Vec<_>>()
        }
    };
    assert_eq!(of(south).await, [ids[0]]);
    assert_eq!(of(north).await, [ids[1]]);
    assert_eq!(store.comparisons_of_scene("white").await.unwrap().len(), 2);
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

async fn renders_and_studies_left_running_by_a_crash_are_interrupted_when_the_store_reopens(engine: EngineKind) {
    let (_dir, store, url) = temp_store(engine).await;
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
    store.close().await;

    let store = Store::open_recovering(&url).await.unwrap();
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

async fn job_states_move_only_forward(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
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

/// `/api/jobs` reads the queued and running renders and studies by their
/// state (once, every render ever listed and filtered in memory, capped at
/// the newest 200).
async fn the_queue_reads_only_unfinished_renders_and_studies_oldest_first(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let ended = store.create_render(&new_render()).await.unwrap();
    let queued = store.create_render(&new_render()).await.unwrap();
    let running = store.create_render(&new_render()).await.unwrap();
    store
        .end_job(Job::Render, ended, JobEnd::Cancelled, "by a test")
        .await
        .unwrap();
    store.start_job(Job::Render, running).await.unwrap();
    let ids: Vec<i64> = store.unfinished_renders().await.unwrap().iter().map(|r| r.id).collect();
    assert_eq!(ids, [queued, running]);
    let done = store.create_study(&serde_json::json!({})).await.unwrap();
    let waiting = store.create_study(&serde_json::json!({})).await.unwrap();
    store
        .end_job(Job::Study, done, JobEnd::Failed, "by a test")
        .await
        .unwrap();
    let ids: Vec<i64> = store.unfinished_studies().await.unwrap().iter().map(|s| s.id).collect();
    assert_eq!(ids, [waiting]);
}

/// The bug (issue 33): a ColorCAL's or an LS-100's cancelled measurement
/// showed nothing of its good samples (the partial average read only
/// spectra). Now: their mean XYZ (or luminance) in the instrument's CIE
/// 1931 observer, the CV of their luminance, marked partial. Truth: the
/// samples' own numbers, averaged by hand.
async fn a_cancelled_colorimeter_or_luminance_meter_measurement_had_no_partial_average(engine: EngineKind) {
    let (_db, store, _) = temp_store(engine).await;
    for (model, xyz) in [("ColorCAL MkII", true), ("LS-100", false)] {
        let inst = store
            .upsert_instrument(&Booth::default(), model, None, "/dev/pts/2")
            .await
            .unwrap();
        let id = store.create_measurement(&new_measurement()).await.unwrap();
        store.mark_running(id, Some(inst)).await.unwrap();
        for (index, y) in [(0usize, 30.0), (1, 34.0)] {
            let sample = NewSample {
                index,
                taken_at: 1.0e9 + index as f64,
                code: 0,
                message: "OK".into(),
                usable: true,
                radiance: None,
                luminance_cd_m2: Some(y),
                instrument_xyz: xyz.then_some([0.9 * y, y, 1.1 * y]),
            };
            store.insert_sample(id, &sample).await.unwrap();
        }
        store
            .end_measurement(id, MeasurementState::Cancelled, "cancelled by the operator")
            .await
            .unwrap();
        let m = store.get_measurement(id).await.unwrap().unwrap().summary;
        assert_eq!(m.instrument_model.as_deref(), Some(model));
        assert!(m.partial, "{model}: {m:?}");
        assert_eq!(
            m.observer,
            Some(Observer::Cie1931),
            "{model}: the instrument's own observer"
        );
        assert!((m.luminance_cd_m2.unwrap() - 32.0).abs() < 1e-9, "{model}: {m:?}");
        // SD (n − 1) of 30 and 34 is 2√2; CV = 2√2 / 32.
        assert!(
            (m.luminance_cv.unwrap() - 8f64.sqrt() / 32.0).abs() < 1e-9,
            "{model}: {m:?}"
        );
        if xyz {
            let v = m.xyz.unwrap();
            assert!((v[0] - 28.8).abs() < 1e-9 && (v[2] - 35.2).abs() < 1e-9, "{v:?}");
            assert!((m.x.unwrap() - 0.9 / 3.0).abs() < 1e-9, "{m:?}");
        } else {
            assert!(
                m.xyz.is_none() && m.x.is_none(),
                "a luminance meter gives no colour: {m:?}"
            );
        }
    }
}

/// Reads that go through each engine's own types: the partial average of an
/// interrupted measurement (its samples' `usable` flag: 0/1 on SQLite, a
/// boolean on PostgreSQL), a preview's bytes (BLOB, BYTEA), the filters of
/// a listing, instruments and sessions.
async fn partial_averages_and_previews_read_back_alike(engine: EngineKind) {
    let (_db, store, _) = temp_store(engine).await;
    let session = store.create_session("ana", "booth 1").await.unwrap();
    let inst = store
        .upsert_instrument(&Booth::default(), "PR-650", None, "/dev/pts/1")
        .await
        .unwrap();
    let mut m = new_measurement();
    m.session_id = Some(session);
    let id = store.create_measurement(&m).await.unwrap();
    store.mark_running(id, Some(inst)).await.unwrap();
    let flat = |level: f64, index: usize| NewSample {
        index,
        taken_at: 1.0e9 + index as f64,
        code: 0,
        message: "OK".into(),
        usable: true,
        radiance: Some(vec![level; 101]),
        luminance_cd_m2: Some(level),
        instrument_xyz: None,
    };
    store.insert_sample(id, &flat(0.010, 0)).await.unwrap();
    store.insert_sample(id, &sample(1, false)).await.unwrap();
    store.insert_sample(id, &flat(0.014, 2)).await.unwrap();
    store
        .end_measurement(id, MeasurementState::Interrupted, "cable pulled")
        .await
        .unwrap();
    let page = store
        .list_measurements(&MeasurementFilter {
            target: Some("patch".into()),
            state: Some(MeasurementState::Interrupted),
            ..Default::default()
        })
        .await
        .unwrap();
    assert_eq!(page.total, 1);
    let summary = &page.items[0];
    assert_eq!((summary.samples_taken, summary.good_samples), (3, 2));
    assert!(
        summary.partial,
        "an interrupted measurement's good samples are averaged"
    );
    // Two flat spectra, 0.010 and 0.014 W/(sr·m²·nm): their luminances are
    // in the ratio 10 : 14, so CV = SD/mean = (0.002·√2)/0.012 = √2/6 (n − 1);
    // the mean is equal-energy, at CIE 1931 x = 1/3.
    assert!(
        (summary.luminance_cv.unwrap() - 2f64.sqrt() / 6.0).abs() < 1e-9,
        "{summary:?}"
    );
    assert!((summary.x.unwrap() - 1.0 / 3.0).abs() < 2e-3, "{summary:?}");
    // a_partial_average_labelled_the_instruments_values_as_the_observers:
    // Y, x, y, XYZ are computed with the store's observer and named; the
    // CIE 1931 values are the instrument's.
    assert_eq!(summary.observer, Some(store.observer()), "{summary:?}");
    assert_eq!(summary.luminance_cd_m2, summary.xyz.map(|v| v[1]), "{summary:?}");
    assert!(summary.instrument_luminance_cd_m2.is_some() && summary.instrument_x.is_some());
    assert!(
        (summary.instrument_luminance_cd_m2.unwrap() - summary.luminance_cd_m2.unwrap()).abs() > 1e-9,
        "Judd–Vos and CIE 1931 luminances of a flat spectrum differ: {summary:?}"
    );
    let detail = store.get_measurement(id).await.unwrap().unwrap();
    let one = detail.summary;
    assert_eq!(one.luminance_cd_m2, summary.luminance_cd_m2);
    for s in detail.samples.iter().filter(|s| s.radiance.is_some()) {
        assert!(
            s.luminance_cd_m2.is_some(),
            "a sample with a spectrum has the observer's Y: {s:?}"
        );
    }
    assert_eq!(one.session_id, Some(session));
    assert_eq!(one.instrument_id, Some(inst));
    let none = store
        .list_measurements(&MeasurementFilter {
            state: Some(MeasurementState::Complete),
            ..Default::default()
        })
        .await
        .unwrap();
    assert_eq!(none.total, 0);

    let render = store.create_render(&new_render()).await.unwrap();
    let png = [0x89, b'P', b'N', b'G', 0x00, 0xff, 0x0d, 0x0a];
    store.set_render_preview(render, &png).await.unwrap();
    assert_eq!(store.render_preview(render).await.unwrap().unwrap(), png);
    assert_eq!(store.render_preview(render + 1).await.unwrap(), None);

    let instruments = store.list_instruments().await.unwrap();
    assert_eq!((instruments.len(), instruments[0].serial.as_str()), (1, ""));
    let sessions = store.list_sessions().await.unwrap();
    assert_eq!((sessions[0].id, sessions[0].operator.as_str()), (session, "ana"));
}

/// The checksums sqlx recorded in every SQLite database made before the
/// migrations moved to `migrations/sqlite/` (SHA-384 of each file as it was
/// in `migrations/` on main at 5681dba).
const CHECKSUMS_BEFORE_THE_MOVE: [(i64, &str); 8] = [
    (
        1,
        "564d57b21223680f656638d05d5d9b26d16db1ca2d7216ab7a86efee549548be3ffe4e8296b24129421b01976f34ef03",
    ),
    (
        2,
        "d6811fd3f7555d2320b041ce95e5075ce59cf9d006ebb5e6ca17df2d023f5d227ce196a47a83f438d954c339847c2f42",
    ),
    (
        3,
        "5fc28bb3578910e431fd10de26184be2fa923a6a859ba0e64f7179650ea1bd56e832e2f493cb5651628c39434ad15cdd",
    ),
    (
        4,
        "c5678c44bd6c03e33b17d0d66599cb99f210e11521b06b23ebd332420a7e5db5675c8778070ede6dde0f1bfb3a14e82f",
    ),
    (
        5,
        "5ed7590ac00c8dd045fa82e0c4b8230c2ca667cd365732eeb0ffb0b5fd5b309aa662fe5dcff4b4a6b9709f5be0421d21",
    ),
    (
        6,
        "f8aef11f707f2e9d81c19b540a5e108bc5638d9d8f0e4887ded8191a79b17c6ed9bec6f1479cfbc2ab40f6ba99b2bcd0",
    ),
    (
        7,
        "0485846b8a2ba8c11eb7c4d4bad5c7375c89f6563afff8a1e8ac78408f24f7fa4c039193789ecf81e6540d2bd4ea29aa",
    ),
    (
        8,
        "5459cd1c2bcfa84a90219e91eeeb42f50733b76dce9047da08b2fafb1c691bc48bd0314321b62b0b2944da1d762bd05a",
    ),
];

/// The bug (issue 32): two simultaneous retries of one cancelled render
/// each queued a render. The store takes one retry per render or study;
/// the second, even from another process, is a conflict naming the first.
async fn two_retries_of_one_render_both_queued_a_render(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let old = store.create_render(&new_render()).await.unwrap();
    store
        .end_job(Job::Render, old, JobEnd::Cancelled, "cancelled")
        .await
        .unwrap();
    let retry = new_render();
    let (a, b) = tokio::join!(
        store.create_render_retrying(&retry, Some(old)),
        store.create_render_retrying(&retry, Some(old)),
    );
    let (first, refused) = match (a, b) {
        (Ok(first), Err(e)) | (Err(e), Ok(first)) => (first, e),
        other => panic!("exactly one retry must be stored: {other:?}"),
    };
    assert_eq!(
        refused.to_string(),
        already_retried_message(Job::Render, old, first),
        "the second names the first retry"
    );
    assert_eq!(store.retried_as(Job::Render, old).await.unwrap(), Some(first));
    assert_eq!(
        store.list_renders(None).await.unwrap().len(),
        2,
        "one render and its one retry"
    );
    // A retry of the retry is its own.
    store
        .end_job(Job::Render, first, JobEnd::Failed, "failed")
        .await
        .unwrap();
    assert!(store.create_render_retrying(&new_render(), Some(first)).await.is_ok());

    let study = store.create_study(&serde_json::json!({})).await.unwrap();
    store
        .end_job(Job::Study, study, JobEnd::Interrupted, "interrupted")
        .await
        .unwrap();
    let again = store
        .create_study_retrying(&serde_json::json!({}), Some(study))
        .await
        .unwrap();
    let e = store
        .create_study_retrying(&serde_json::json!({}), Some(study))
        .await
        .unwrap_err();
    assert_eq!(e.to_string(), already_retried_message(Job::Study, study, again));
}
