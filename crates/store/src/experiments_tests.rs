//! Experiment sessions in the store, on both engines (issue 32): one
//! running session per observer however many start it at once, and the
//! trial that ends a session completing it in the same transaction.

use super::super::engine::EngineKind;
use super::super::test_db::{on_both_engines, TestDb};
use super::super::*;

on_both_engines!(
    starts_of_one_observer_at_once_make_one_running_session,
    the_trial_that_ends_a_session_completes_it_in_its_transaction,
);

/// An experiment on a queued measurement and the simulated CRT's profile.
async fn experiment(store: &Store) -> i64 {
    let m = store
        .create_measurement(&NewMeasurement {
            booth: Booth::default(),
            session_id: None,
            scene: Some("white".into()),
            target: Some("patch".into()),
            samples: 1,
            settings_json: serde_json::json!({}),
            note: String::new(),
        })
        .await
        .unwrap();
    let crt = lightbooth_science::display::SimulatedDisplay::crt().unwrap();
    let profile = crt
        .exact_profile(lightbooth_science::colorimetry::Observer::JuddVos)
        .unwrap();
    let profile = store.insert_display_profile("crt", "", &profile).await.unwrap();
    let json = serde_json::json!({});
    store
        .insert_experiment(&NewExperiment {
            name: "e",
            scene: "white",
            target: "patch",
            booth: "default",
            measurement_id: m,
            display_profile_id: profile,
            output_method: "8bit",
            seed: 1,
            request: &json,
            check: &json,
        })
        .await
        .unwrap()
}

/// Regression (issue 32): two tabs starting one observer made two running
/// sessions (20 of 20 tries).
async fn starts_of_one_observer_at_once_make_one_running_session(engine: EngineKind) {
    let db = TestDb::new(engine).await;
    let store = Store::open(&db.url).await.unwrap();
    let e = experiment(&store).await;
    for attempt in 0..5 {
        let observer = format!("tab{attempt}");
        let tabs: Vec<_> = (0..4)
            .map(|_| {
                let (store, observer) = (store.clone(), observer.clone());
                tokio::spawn(async move {
                    store
                        .create_experiment_session(e, &observer, |id| 1000 + id)
                        .await
                        .unwrap()
                })
            })
            .collect();
        let mut got = Vec::new();
        for t in tabs {
            got.push(t.await.unwrap());
        }
        let id = got[0].0;
        assert!(got.iter().all(|(i, _)| *i == id), "attempt {attempt}: {got:?}");
        assert_eq!(got.iter().filter(|(_, created)| *created).count(), 1, "{got:?}");
        let s = store.get_experiment_session(id).await.unwrap().unwrap();
        assert_eq!((s.seed, s.state.as_str()), (1000 + id, "running"));
        assert_eq!(store.running_session_of(e, &observer).await.unwrap(), Some(id));
    }
    assert_eq!(store.sessions_of_experiment(e).await.unwrap().len(), 5);
}

fn trial(session_id: i64, position: i64, dropped: bool) -> TrialRow {
    TrialRow {
        session_id,
        position,
        approximation: "nstep3".into(),
        configuration: "OON".into(),
        response: 2,
        correct: true,
        reaction_ms: 600.0,
        stimulus_frames: 18,
        dropped_frames: i64::from(dropped),
        dropped_in_stimulus: dropped,
        frame_intervals_ms: vec![16.7; 3],
        created_at: now(),
    }
}

/// Regression (issue 32): the last trial and the session's end were two
/// commits; a kill between them left the session running with all its
/// trials. The running sessions' counts come from one query.
async fn the_trial_that_ends_a_session_completes_it_in_its_transaction(engine: EngineKind) {
    let db = TestDb::new(engine).await;
    let store = Store::open(&db.url).await.unwrap();
    let e = experiment(&store).await;
    let (sid, _) = store.create_experiment_session(e, "obs", |_| 5).await.unwrap();
    store.insert_trial(&trial(sid, 0, true), false).await.unwrap();
    store.insert_trial(&trial(sid, 1, false), false).await.unwrap();
    let running = store.running_experiment_sessions("default").await.unwrap();
    assert_eq!(running.len(), 1);
    assert_eq!((running[0].id, running[0].trials, running[0].dropped), (sid, 2, 1));
    assert!(store.running_experiment_sessions("booth-2").await.unwrap().is_empty());
    store.insert_trial(&trial(sid, 2, false), true).await.unwrap();
    let s = store.get_experiment_session(sid).await.unwrap().unwrap();
    assert_eq!((s.state.as_str(), s.trials_recorded), ("complete", 3));
    assert!(s.finished_at.is_some() && s.touched_at.is_some());
    let late = store.insert_trial(&trial(sid, 3, false), false).await.unwrap_err();
    assert!(
        late.to_string().contains("is complete: it takes no more trials"),
        "{late}"
    );
    assert!(store.running_experiment_sessions("default").await.unwrap().is_empty());
    // The observer starts again: a new session.
    let (again, created) = store.create_experiment_session(e, "obs", |_| 6).await.unwrap();
    assert!(created && again != sid);
    // A completed session's display is not rewritten.
    assert!(!store.set_session_display(sid, 33.3, "late").await.unwrap());
    assert!(store.set_session_display(again, 16.7, "page").await.unwrap());
}
