//! The experiment workflow on a real SQLite file: set up from a stored
//! measurement and its comparisons, checked, run trial by trial with a
//! dropped frame and a resumed session, analysed.

use super::session::TrialReport;
use super::*;
use crate::error::LabError;
use crate::testing::{completed_held_measurement, completed_measurement, queued_measurement, store_in};
use lightbooth_science::colorimetry::Observer;
use lightbooth_science::display::profile::TransferModel;
use lightbooth_science::display::SimulatedDisplay;
use lightbooth_store::{NewComparison, NewRender};

struct Lab {
    _dir: tempfile::TempDir,
    experiments: Experiments,
    measurement: i64,
    profile: i64,
}

/// A complete measurement of WHITE's patch compared with three codings,
/// whose colours are the simulated CRT's at codes 100.2 (measured), 142.8
/// (nstep3), 100.4 (nstep81: the same 8-bit code) and 101.0 (nstep27: the
/// next code), and the CRT's profile.
async fn lab() -> Lab {
    let dir = tempfile::tempdir().unwrap();
    let store = store_in(dir.path()).await;
    let crt = SimulatedDisplay::crt().unwrap();
    let profile = crt.exact_profile(Observer::JuddVos).unwrap();
    let at = |v: f64| profile.xyz_of_drive([v; 3], TransferModel::Gamma).unwrap().to_array();
    let id = completed_measurement(&store, Some(("white", "patch"))).await;
    let render = store
        .create_render(&NewRender {
            scene: "white".into(),
            scene_hash: "test".into(),
            settings_json: serde_json::json!({}),
            codings: vec!["nstep3".into(), "nstep27".into(), "nstep81".into()],
            seed: 1,
        })
        .await
        .unwrap();
    let rows: Vec<NewComparison> = [("nstep3", 0.56), ("nstep27", 101.0 / 255.0), ("nstep81", 100.4 / 255.0)]
        .into_iter()
        .map(|(coding, v)| NewComparison {
            measurement_id: id,
            render_id: render,
            scene: "white".into(),
            target: "patch".into(),
            coding: coding.into(),
            observer: Observer::JuddVos,
            white_source: "test".into(),
            white: at(1.0),
            measured: at(100.2 / 255.0),
            measured_y_se: 0.01,
            rendered: at(v),
            rendered_y_se: 0.01,
            y_ratio: 1.0,
            xy_distance: 0.0,
            de76: 0.0,
            de00: 0.0,
        })
        .collect();
    store.insert_comparisons(&rows).await.unwrap();
    let profile = store.insert_display_profile("crt", "", &profile).await.unwrap();
    Lab {
        _dir: dir,
        experiments: Experiments::new(store),
        measurement: id,
        profile,
    }
}

fn request(lab: &Lab, approximations: &[&str]) -> ExperimentRequest {
    serde_json::from_value(serde_json::json!({
        "measurement_id": lab.measurement,
        "display_profile_id": lab.profile,
        "approximations": approximations,
        "seed": 11,
    }))
    .unwrap()
}

#[tokio::test]
async fn an_experiment_says_which_approximations_its_display_shows_apart() {
    let lab = lab().await;
    let e = lab
        .experiments
        .create(request(&lab, &["nstep3", "nstep27", "nstep81"]))
        .await
        .unwrap();
    assert_eq!(
        (e.scene.as_str(), e.target.as_str(), e.name.as_str()),
        ("white", "patch", "white/patch")
    );
    assert_eq!(e.output_method, "noisy_bit", "noisy-bit dithering is the default");
    let check = &e.check;
    assert_eq!(check["testable"], serde_json::json!(["nstep3", "nstep27", "nstep81"]));
    assert_eq!(check["testable_only_with_method"], serde_json::json!(["nstep81"]));
    let summary = check["summary"].to_string();
    assert!(
        summary.contains("at 8 bits nstep81 has the original's codes (100, 100, 100)"),
        "{summary}"
    );
    // The stored request has its defaults: the study's presentation, the seed.
    assert_eq!(e.request["presentation"]["stimulus_ms"], 300.0);
    assert_eq!(e.seed, 11);

    // At 8 bits, N = 81 cannot be tested.
    let mut at8 = request(&lab, &["nstep3", "nstep81"]);
    at8.output = OutputMethod::EightBit;
    let (_, c) = lab.experiments.check(&at8).await.unwrap();
    assert_eq!(c.untestable, ["nstep81"]);
}

#[tokio::test]
async fn a_bad_request_is_refused_naming_the_field() {
    let lab = lab().await;
    let err = |r| async { lab.experiments.create(r).await.unwrap_err().to_string() };
    let e = err(request(&lab, &["nstep9"])).await;
    assert!(
        e.contains("approximations[0] = `nstep9`") && e.contains("it has nstep27, nstep3, nstep81"),
        "{e}"
    );
    let e = err(request(&lab, &[])).await;
    assert!(e.contains("give 1–16 codings"), "{e}");
    let e = err(request(&lab, &["nstep3", "nstep3"])).await;
    assert!(e.contains("listed twice"), "{e}");
    let mut r = request(&lab, &["nstep3"]);
    r.original = "nstep3".into();
    assert!(err(r).await.contains("is the original itself"));
    let mut r = request(&lab, &["nstep3"]);
    r.display_profile_id = 99;
    assert!(err(r).await.contains("there is no display profile 99"));
    let mut r = request(&lab, &["nstep3"]);
    r.presentation.stimulus_ms = 5.0;
    assert!(err(r).await.contains("presentation.stimulus_ms = 5"));
    let queued = queued_measurement(lab.experiments.store(), Some(("white", "patch"))).await;
    let mut r = request(&lab, &["nstep3"]);
    r.measurement_id = queued;
    assert!(err(r)
        .await
        .contains("is queued: an experiment needs a complete measurement"));
    assert!(
        lab.experiments.store().list_experiments().await.unwrap().is_empty(),
        "nothing stored"
    );
}

/// The refresh the test's pages report, ms a frame.
const FRAME_MS: f64 = 16.7;

/// A trial as the page reports it at [`FRAME_MS`] with the study's
/// presentation: the cross's 60 frames, the pie's 18, then 22 more until
/// the key; `dropped` puts a long interval in the pie.
fn report(position: usize, response: u8, dropped: bool) -> TrialReport {
    let mut frame_intervals_ms = vec![FRAME_MS; 100];
    if dropped {
        frame_intervals_ms[65] = 40.0;
    }
    TrialReport {
        position,
        response,
        reaction_ms: 650.0,
        stimulus_frames: 18,
        dropped_frames: u32::from(dropped),
        dropped_in_stimulus: dropped,
        frame_intervals_ms,
    }
}

/// A session of `observer` started, its page's refresh reported.
async fn started(x: &Experiments, experiment: i64, observer: &str) -> session::SessionView {
    let view = x.start_session(experiment, observer).await.unwrap();
    let display = session::DisplayReport {
        frame_ms: FRAME_MS,
        client: "test".into(),
    };
    x.report_display(view.session.id, &display).await.unwrap()
}

/// An observer who always finds nstep3 and always answers "left" for
/// nstep81: 36 of 36 and 12 of 36 (the odd piece is left in two of the six
/// configurations).
#[tokio::test]
async fn a_session_records_every_trial_repeats_dropped_ones_and_resumes() {
    let lab = lab().await;
    let x = &lab.experiments;
    let e = x.create(request(&lab, &["nstep3", "nstep81"])).await.unwrap();
    let mut view = started(x, e.id, "obs1").await;
    assert_eq!((view.trials_total, view.trials_recorded), (72, 0));
    assert!(x
        .start_session(e.id, "Ann Smith")
        .await
        .unwrap_err()
        .to_string()
        .contains("no names needed"));
    let mut position = 0;
    while let Some(next) = view.next.clone() {
        assert_eq!(next.position, position);
        let odd = if next.configuration.matches('O').count() == 1 {
            next.configuration.find('O').unwrap()
        } else {
            next.configuration.find('N').unwrap()
        };
        let response = if next.approximation == "nstep3" { odd as u8 } else { 0 };
        // Trial 3 drops a frame during its pie: it is shown again at the end.
        view = x
            .record_trial(view.session.id, &report(position, response, position == 3))
            .await
            .unwrap();
        if position == 10 {
            // The tab is closed and opened again: the same session, the same next trial.
            let resumed = x.start_session(e.id, "obs1").await.unwrap();
            assert_eq!(resumed.session.id, view.session.id);
            assert_eq!(resumed.next.as_ref().map(|n| n.position), Some(11));
            let stale = x
                .record_trial(view.session.id, &report(5, 0, false))
                .await
                .unwrap_err()
                .to_string();
            assert!(stale.contains("the next is trial 11"), "{stale}");
        }
        position += 1;
    }
    assert_eq!(position, 73, "72 planned and one repeat");
    assert_eq!(
        (view.trials_total, view.repeats, view.session.state.as_str()),
        (73, 1, "complete")
    );
    let late = x
        .record_trial(view.session.id, &report(73, 0, false))
        .await
        .unwrap_err()
        .to_string();
    assert!(late.contains("is complete"), "{late}");

    let a = x.analyze(e.id).await.unwrap();
    assert_eq!(a.observers, ["obs1"]);
    let row = |name: &str| a.rows.iter().find(|r| r.approximation == name).unwrap();
    assert_eq!((row("nstep3").correct, row("nstep3").trials), (36, 36));
    assert_eq!(
        row("nstep3").differencing.as_ref().unwrap().rule,
        Some(lightbooth_science::psychophysics::oddity::ALL_CORRECT_RULE)
    );
    assert_eq!((row("nstep81").correct, row("nstep81").trials), (12, 36));
    assert_eq!(row("nstep3").excluded + row("nstep81").excluded, 1);
    // Regression (issue 32): the note read "1 had a frame dropped … and are not counted".
    assert_eq!(
        a.notes[0],
        "73 trials stored; 1 had a frame dropped during the pie and is not counted (each was shown again)"
    );
    assert!(
        a.warnings.is_empty(),
        "1 of 73 excluded is no warning: {:?}",
        a.warnings
    );
    assert!(row("nstep81").differencing.as_ref().unwrap().d_prime < 0.5);
    // nstep3's 36 of 36 have no upper end: the table marks it and says why.
    let text = analysis::analysis_text(&a);
    let nstep3_line = text.lines().find(|l| l.starts_with("obs1       nstep3")).unwrap();
    assert!(nstep3_line.contains(", —]") && nstep3_line.ends_with("  *"), "{text}");
    assert!(
        text.contains("\n— an upper end of — : every trial or nearly correct"),
        "{text}"
    );
    let csv = analysis::analysis_csv(&a);
    assert_eq!(csv.lines().count(), 3);
    assert!(csv.lines().nth(1).unwrap().contains(",obs1,nstep3,36,36,"), "{csv}");
    // The run page says how many of the recorded trials are not counted.
    assert_eq!((view.excluded, view.warning.as_deref()), (1, None));
}

/// Regression: a trial recorded while another request wrote to the same
/// SQLite file failed with "database is locked" (SQLITE_BUSY_SNAPSHOT: the
/// transaction read the session before writing, another writer committed in
/// between, and SQLite refuses such a write without waiting). Trials and
/// other writes interleave here; every trial must land.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn trials_recorded_while_another_writer_commits_are_not_refused_as_locked() {
    let lab = lab().await;
    let x = lab.experiments.clone();
    let e = x.create(request(&lab, &["nstep3", "nstep81"])).await.unwrap();
    let view = started(&x, e.id, "obs01").await;
    let other = x.store().clone();
    let writer = tokio::spawn(async move {
        for i in 0..300 {
            other
                .insert_verification(e.id, &serde_json::json!({ "i": i }))
                .await
                .unwrap();
        }
    });
    for position in 0..72 {
        x.record_trial(view.session.id, &report(position, 0, false))
            .await
            .unwrap_or_else(|err| panic!("trial {position}: {err}"));
    }
    writer.await.unwrap();
}

/// `/api/jobs` lists a running session of this booth's experiments with its
/// trials, and not once it is another booth's queue that is asked.
#[tokio::test]
async fn the_queue_lists_a_running_session_of_this_booths_experiments_only() {
    use crate::measure::queue::InstrumentStatus;
    use crate::queue::{queue, QueueSources};
    use lightbooth_store::Booth;
    let lab = lab().await;
    let e = lab.experiments.create(request(&lab, &["nstep3"])).await.unwrap();
    let session = lab.experiments.start_session(e.id, "obs01").await.unwrap();
    let status = InstrumentStatus::Disconnected { reason: "test".into() };
    let jobs_of = |booth: Booth| {
        let (store, status) = (lab.experiments.store.clone(), status.clone());
        async move {
            queue(&QueueSources {
                store: &store,
                booth: &booth,
                status: &status,
                renders: None,
                progress: None,
            })
            .await
            .unwrap()
            .jobs
        }
    };
    let here = jobs_of(Booth::default()).await;
    assert_eq!(here.len(), 1, "{here:?}");
    let job = &here[0];
    assert_eq!(
        (job.kind, job.id, job.parent_id),
        ("experiment_session", session.session.id, Some(e.id))
    );
    assert_eq!((job.done, job.total), (Some(0.0), Some(session.trials_total as f64)));
    assert!(job.what.contains("observer obs01"), "{}", job.what);
    assert_eq!(job.state, "running");
    let elsewhere = jobs_of("booth-2".parse().unwrap()).await;
    assert!(elsewhere.is_empty(), "another booth's queue lists {elsewhere:?}");

    // Regression (issue 32): a session started and left stayed `running`
    // for ever. Untouched for longer than PAUSED_AFTER_S it is paused, and
    // resumable: starting the observer again touches it.
    let long_ago = lightbooth_store::now() - session::PAUSED_AFTER_S - 60.0;
    sqlx::query("UPDATE experiment_sessions SET touched_at = $1 WHERE id = $2")
        .bind(long_ago)
        .bind(session.session.id)
        .execute(lab.experiments.store.sqlite_pool().unwrap())
        .await
        .unwrap();
    let here = jobs_of(Booth::default()).await;
    assert_eq!(here[0].state, "paused", "{here:?}");
    assert!(here[0]
        .step
        .as_deref()
        .unwrap()
        .contains("start the observer again to resume"));
    let resumed = lab.experiments.start_session(e.id, "obs01").await.unwrap();
    assert_eq!(resumed.session.id, session.session.id);
    assert_eq!(jobs_of(Booth::default()).await[0].state, "running");
}

/// Regression (issue 32): `/api/jobs` built every running session's view
/// with all its trials. Its counts now come from one query: a session with
/// dropped trials has its repeats in its total, as its view says.
#[tokio::test]
async fn the_queue_counts_a_sessions_trials_and_repeats_without_reading_them() {
    use crate::measure::queue::InstrumentStatus;
    use crate::queue::{queue, QueueSources};
    use lightbooth_store::Booth;
    let lab = lab().await;
    let x = &lab.experiments;
    let e = x.create(request(&lab, &["nstep3"])).await.unwrap();
    let mut view = started(x, e.id, "obs01").await;
    for position in 0..5 {
        view = x
            .record_trial(view.session.id, &report(position, 0, position % 2 == 0))
            .await
            .unwrap();
    }
    let status = InstrumentStatus::Disconnected { reason: "test".into() };
    let jobs = queue(&QueueSources {
        store: &x.store,
        booth: &Booth::default(),
        status: &status,
        renders: None,
        progress: None,
    })
    .await
    .unwrap()
    .jobs;
    assert_eq!(
        (jobs[0].done, jobs[0].total),
        (Some(5.0), Some(view.trials_total as f64))
    );
    assert_eq!(view.trials_total, 36 + 3, "three repeats");
}

fn small(lab: &Lab, approximations: &[&str]) -> ExperimentRequest {
    let mut r = request(lab, approximations);
    r.presentation.repeats = 1;
    r
}

/// Regression (issue 32): a trial for the position after the last panicked
/// a worker (`order[report.position]`, index out of bounds) when the last
/// trial was stored and the session not yet marked complete: two commits,
/// and a kill -9 between them left the session running with all its
/// trials for ever. Now the position is refused with a 409 saying the
/// session is complete, and the start-up repair completes such a session.
#[tokio::test]
async fn a_trial_after_the_last_is_refused_as_complete_and_a_session_left_running_with_all_trials_is_repaired() {
    let lab = lab().await;
    let x = &lab.experiments;
    let e = x.create(small(&lab, &["nstep3"])).await.unwrap();
    let mut view = started(x, e.id, "last3").await;
    assert_eq!(view.trials_total, 6);
    for position in 0..5 {
        view = x
            .record_trial(view.session.id, &report(position, 0, false))
            .await
            .unwrap();
    }
    // The state a daemon killed between the two commits left: the last
    // trial stored, the session still running.
    let sid = view.session.id;
    let next = view.next.clone().unwrap();
    let trial = lightbooth_store::TrialRow {
        session_id: sid,
        position: 5,
        approximation: next.approximation.clone(),
        configuration: next.configuration.clone(),
        response: 0,
        correct: false,
        reaction_ms: 650.0,
        stimulus_frames: 18,
        dropped_frames: 0,
        dropped_in_stimulus: false,
        frame_intervals_ms: vec![FRAME_MS; 100],
        created_at: lightbooth_store::now(),
    };
    x.store.insert_trial(&trial, false).await.unwrap();
    let stuck = x.view(sid).await.unwrap();
    assert_eq!((stuck.session.state.as_str(), stuck.next.is_none()), ("running", true));
    for position in [6, 7] {
        let err = x.record_trial(sid, &report(position, 0, false)).await.unwrap_err();
        assert!(matches!(err, LabError::Conflict(_)), "{err:?}");
        assert!(
            err.to_string().contains("is complete: all 6 trials are recorded"),
            "{err}"
        );
    }
    assert_eq!(x.complete_finished_sessions("default").await.unwrap(), [sid]);
    assert_eq!(x.view(sid).await.unwrap().session.state, "complete");
    assert!(x.complete_finished_sessions("default").await.unwrap().is_empty());
    // The observer can run the experiment again: a new session.
    let again = x.start_session(e.id, "last3").await.unwrap();
    assert_ne!(again.session.id, sid);
    assert_eq!(again.next.map(|n| n.position), Some(0));

    // The last trial recorded through the workflow completes the session in
    // the same transaction.
    let mut view = started(x, e.id, "obs2").await;
    for position in 0..6 {
        view = x
            .record_trial(view.session.id, &report(position, 0, false))
            .await
            .unwrap();
    }
    assert_eq!(view.session.state, "complete");
}

/// Regression (issue 32): two tabs starting one observer at once created
/// two running sessions with the same seed, and sixteen observers started
/// at once got 7 distinct seeds (the seed came from the number of sessions).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_tabs_starting_one_observer_get_one_session_and_no_two_sessions_share_a_seed() {
    let lab = lab().await;
    let x = lab.experiments.clone();
    let e = x.create(request(&lab, &["nstep3"])).await.unwrap();
    for attempt in 0..5 {
        let observer = format!("tab{attempt}");
        let tabs: Vec<_> = (0..4)
            .map(|_| {
                let (x, observer) = (x.clone(), observer.clone());
                tokio::spawn(async move { x.start_session(e.id, &observer).await.unwrap().session.id })
            })
            .collect();
        let mut ids = Vec::new();
        for t in tabs {
            ids.push(t.await.unwrap());
        }
        ids.dedup();
        assert_eq!(ids.len(), 1, "attempt {attempt}: sessions {ids:?}");
    }
    let starts: Vec<_> = (0..16)
        .map(|i| {
            let x = x.clone();
            tokio::spawn(async move { x.start_session(e.id, &format!("obs{i:02}")).await.unwrap().session })
        })
        .collect();
    let mut seeds = Vec::new();
    for s in starts {
        seeds.push(s.await.unwrap().seed);
    }
    let running = x.store.sessions_of_experiment(e.id).await.unwrap();
    assert_eq!(running.len(), 5 + 16);
    seeds.extend(running.iter().map(|s| s.seed));
    seeds.sort();
    seeds.dedup();
    assert_eq!(seeds.len(), 21, "every session its own seed");
    assert!(seeds.iter().all(|&s| (0..=session::MAX_SEED as i64).contains(&s)));
}

/// `session_seed` is one-to-one in the session id within an experiment.
#[test]
fn session_seeds_are_distinct_and_exact_as_doubles() {
    let mut seeds: Vec<i64> = (1..20_000)
        .map(|id| session::session_seed(9_043_539_040_596_399, id))
        .collect();
    assert!(seeds
        .iter()
        .all(|&s| s as u64 <= session::MAX_SEED && (s as f64) as i64 == s));
    seeds.sort();
    seeds.dedup();
    assert_eq!(seeds.len(), 19_999);
}

/// Regression (issue 32): contradictory trials were stored (the daemon
/// trusted the page's flags): each is refused, naming the field, and
/// nothing is stored; a trial before the page reported its refresh is
/// refused too.
#[tokio::test]
async fn a_trial_that_contradicts_its_own_frames_or_the_measured_refresh_is_refused_naming_the_field() {
    let lab = lab().await;
    let x = &lab.experiments;
    let e = x.create(request(&lab, &["nstep3"])).await.unwrap();
    let fresh = x.start_session(e.id, "early").await.unwrap();
    let err = x
        .record_trial(fresh.session.id, &report(0, 0, false))
        .await
        .unwrap_err();
    assert!(
        matches!(err, LabError::Conflict(_)) && err.to_string().contains("has no measured refresh"),
        "{err:?}"
    );
    let view = started(x, e.id, "obs01").await;
    let sid = view.session.id;
    type Spoil = Box<dyn Fn(&mut TrialReport)>;
    let cases: Vec<(&str, Spoil)> = vec![
        ("stimulus_frames = 0", Box::new(|r| r.stimulus_frames = 0)),
        (
            "stimulus_frames = 4000000000",
            Box::new(|r| r.stimulus_frames = 4_000_000_000),
        ),
        ("dropped_in_stimulus = true", Box::new(|r| r.dropped_in_stimulus = true)),
        ("dropped_frames = 0", Box::new(|r| r.frame_intervals_ms[70] = 50.0)),
        (
            "dropped_in_stimulus = false: frame_intervals_ms[70]",
            Box::new(|r| {
                r.frame_intervals_ms[70] = 50.0;
                r.dropped_frames = 1;
            }),
        ),
        ("reaction_ms = 0", Box::new(|r| r.reaction_ms = 0.0)),
        ("reaction_ms = 3599999", Box::new(|r| r.reaction_ms = 3_599_999.0)),
        (
            "frame_intervals_ms has 0 intervals",
            Box::new(|r| r.frame_intervals_ms.clear()),
        ),
        (
            "frame_intervals_ms[3] = -1",
            Box::new(|r| r.frame_intervals_ms[3] = -1.0),
        ),
        ("response = 3", Box::new(|r| r.response = 3)),
    ];
    for (field, spoil) in &cases {
        let mut r = report(0, 0, false);
        spoil(&mut r);
        let err = x.record_trial(sid, &r).await.unwrap_err();
        assert!(
            matches!(err, LabError::Invalid(_)) && err.to_string().contains(field),
            "{field}: {err:?}"
        );
    }
    assert!(x.store.trials_of_session(sid).await.unwrap().is_empty());
    // A drop outside the pie is counted but not repeated; one inside is both.
    let mut r = report(0, 0, false);
    r.frame_intervals_ms[90] = 50.0;
    r.dropped_frames = 1;
    let v = x.record_trial(sid, &r).await.unwrap();
    assert_eq!((v.trials_recorded, v.repeats), (1, 0));
    let v = x.record_trial(sid, &report(1, 0, true)).await.unwrap();
    assert_eq!((v.trials_recorded, v.repeats), (2, 1));
}

/// Regression (issue 32): `POST …/display` after the session ended
/// rewrote the completed session's refresh.
#[tokio::test]
async fn the_display_of_an_ended_session_is_not_rewritten() {
    let lab = lab().await;
    let x = &lab.experiments;
    let e = x.create(small(&lab, &["nstep3"])).await.unwrap();
    let mut view = started(x, e.id, "obs01").await;
    for position in 0..6 {
        view = x
            .record_trial(view.session.id, &report(position, 0, false))
            .await
            .unwrap();
    }
    let late = session::DisplayReport {
        frame_ms: 33.3,
        client: "changed after the end".into(),
    };
    let err = x.report_display(view.session.id, &late).await.unwrap_err();
    assert!(
        matches!(err, LabError::Conflict(_)) && err.to_string().contains("is complete"),
        "{err:?}"
    );
    let s = x.view(view.session.id).await.unwrap().session;
    assert_eq!((s.frame_ms, s.client.as_str()), (Some(FRAME_MS), "test"));
}

/// Regression (issue 32): a verification accepted the booth's own scene
/// measurement as the display's emission and passed.
#[tokio::test]
async fn the_booths_scene_measurement_does_not_verify_the_display() {
    let lab = lab().await;
    let x = &lab.experiments;
    let e = x.create(request(&lab, &["nstep3"])).await.unwrap();
    let r: verification::VerificationRequest = serde_json::from_value(serde_json::json!({
        "patches": [{ "colour": "original", "geometry": "full_field", "measurement_id": lab.measurement }],
    }))
    .unwrap();
    let err = x.verify(e.id, &r).await.unwrap_err().to_string();
    assert!(
        err.contains("patches[0].measurement_id") && err.contains("not of the display"),
        "{err}"
    );
    assert!(x.verifications(e.id).await.unwrap().is_empty());
}

/// Regression (issue 32): a verification accepted any measurement as the
/// display's emission; only one taken under the hold of this experiment's
/// verification says the display showed the colour.
#[tokio::test]
async fn a_measurement_taken_freely_or_for_another_purpose_does_not_verify_the_display() {
    let lab = lab().await;
    let x = &lab.experiments;
    let e = x.create(request(&lab, &["nstep3"])).await.unwrap();
    let other = verification::hold_purpose(e.id + 1);
    let free = completed_measurement(&x.store, None).await;
    let calibration = completed_held_measurement(&x.store, (1, "display calibration “crt”")).await;
    let another = completed_held_measurement(&x.store, (2, &other)).await;
    let ours = completed_held_measurement(&x.store, (3, &verification::hold_purpose(e.id))).await;
    let verify = |m: i64| {
        serde_json::from_value::<verification::VerificationRequest>(serde_json::json!({
            "patches": [{ "colour": "original", "geometry": "full_field", "measurement_id": m }],
        }))
        .unwrap()
    };
    for (m, taken) in [
        (free, "freely, under no instrument hold".to_string()),
        (calibration, "under hold 1 for “display calibration “crt””".to_string()),
        (another, format!("under hold 2 for “{other}”")),
    ] {
        let err = x.verify(e.id, &verify(m)).await.unwrap_err().to_string();
        assert!(
            err.contains(&format!(
                "patches[0].measurement_id: measurement {m} was taken {taken}, not under the hold"
            )),
            "{err}"
        );
    }
    assert!(x.verifications(e.id).await.unwrap().is_empty());
    let v = x.verify(e.id, &verify(ours)).await.unwrap();
    assert_eq!(v.colours[0].measurement_id, ours);
    assert_eq!(x.verifications(e.id).await.unwrap().len(), 1);
}

/// Regression (issue 32): a 60 KB name, NUL and ESC were stored.
#[tokio::test]
async fn an_experiment_name_is_limited_in_length_and_characters() {
    let lab = lab().await;
    let x = &lab.experiments;
    for (name, want) in [
        ("x".repeat(60_000), "name: 60000 characters; give at most 200"),
        ("a\0b".to_string(), "character 2 is the control character U+0000"),
        (
            "\u{1b}[31mred".to_string(),
            "character 1 is the control character U+001B",
        ),
    ] {
        let mut r = request(&lab, &["nstep3"]);
        r.name = name;
        let err = x.create(r).await.unwrap_err().to_string();
        assert!(err.contains(want), "{err}");
    }
    let mut r = request(&lab, &["nstep3"]);
    r.name = "Ørsted's booth — white/patch".into();
    assert_eq!(x.create(r).await.unwrap().name, "Ørsted's booth — white/patch");
}

/// Regression (issue 32): seeds over 2⁵³ lost precision in JavaScript.
#[tokio::test]
async fn experiment_seeds_are_exact_as_doubles_and_sent_as_text() {
    let lab = lab().await;
    let x = &lab.experiments;
    let mut r = request(&lab, &["nstep3"]);
    r.seed = Some(9_043_539_040_596_399_293);
    let err = x.create(r).await.unwrap_err().to_string();
    assert!(
        err.contains("seed = 9043539040596399293: give 0–9007199254740991"),
        "{err}"
    );
    let mut r = request(&lab, &["nstep3"]);
    r.seed = None;
    for _ in 0..20 {
        let e = x.create(r.clone()).await.unwrap();
        assert!(e.seed as u64 <= session::MAX_SEED, "{}", e.seed);
        assert_eq!(e.seed_text, e.seed.to_string());
    }
}

/// Regression (issue 32): with every trial of nstep3 excluded for dropped
/// frames the results had no nstep3 row, no warning, and the figure was
/// titled "2 observers" over bars one observer's trials made.
#[tokio::test]
async fn results_show_what_was_not_counted_and_the_figure_is_titled_from_what_it_draws() {
    let lab = lab().await;
    let x = &lab.experiments;
    let e = x.create(small(&lab, &["nstep3", "nstep81"])).await.unwrap();
    let mut view = started(x, e.id, "obs1").await;
    while let Some(next) = view.next.clone() {
        let dropped = next.approximation == "nstep3";
        view = x
            .record_trial(view.session.id, &report(next.position, 0, dropped))
            .await
            .unwrap();
    }
    // 6 planned nstep3 trials, their 6 repeats and 6 repeats of those (the
    // cap: twice the 12 planned trials), every one with a dropped frame.
    assert_eq!((view.trials_recorded, view.excluded), (24, 18));
    let warning = view.warning.clone().expect("the session warns the operator");
    assert!(
        warning.starts_with("18 of 24 trials (75 %) had a frame dropped"),
        "{warning}"
    );
    // A second observer who started and did nothing.
    started(x, e.id, "obs2").await;
    let a = x.analyze(e.id).await.unwrap();
    let nstep3 = a
        .rows
        .iter()
        .find(|r| r.approximation == "nstep3" && r.observer == "obs1");
    let nstep3 = nstep3.expect("a row for nstep3 though none is counted");
    assert_eq!((nstep3.trials, nstep3.excluded), (0, 18));
    assert!(nstep3.differencing.is_none() && nstep3.independent_observation.is_none());
    // Regression (issue 32): `experiment analyze` footnoted a "—" no row
    // showed; a row with none counted says so and has no interval.
    let text = analysis::analysis_text(&a);
    assert!(
        text.contains("obs1       nstep3            0/0    none counted (18 excluded for a dropped frame)"),
        "{text}"
    );
    assert!(!text.contains("—"), "no row shows an unbounded upper end: {text}");
    assert!(
        a.warnings
            .iter()
            .any(|w| w.starts_with("observer obs1: 18 of 24 trials (75 %)")),
        "{:?}",
        a.warnings
    );
    assert!(
        a.warnings
            .iter()
            .any(|w| w.contains("obs1, nstep3: no trial counted (18 excluded")),
        "{:?}",
        a.warnings
    );
    let csv = analysis::analysis_csv(&a);
    assert!(csv.contains(",obs1,nstep3,0,0,18,,,,"), "{csv}");
    analysis::analysis_mat(&a).unwrap();
    let svg = analysis::figure(
        std::slice::from_ref(&a),
        lightbooth_science::psychophysics::oddity::OddityModel::Differencing,
    )
    .unwrap();
    assert!(svg.contains("1 observer,"), "the figure draws one observer's trials");
    assert!(!svg.contains("2 observers"));
}

/// The bug (issue 32): a profile fitted to a corrupted patch (red γ 3.18,
/// RMS residual 0.106, grey validation ΔE00 10.7) was stored without a
/// word and offered for experiments like any other. It is stored as failed,
/// says why, and an experiment cannot use it.
#[tokio::test]
async fn a_failed_display_profile_was_offered_for_an_experiment_like_any_other() {
    let lab = lab().await;
    let mut bad = SimulatedDisplay::crt()
        .unwrap()
        .exact_profile(Observer::JuddVos)
        .unwrap();
    bad.transfer[0].rms_residual = 0.106;
    if let lightbooth_science::display::Checks::Colour { validation, .. } = &mut bad.checks {
        validation[0].delta_e00 = 10.7;
    }
    let store = &lab.experiments.store;
    let id = store.insert_display_profile("corrupted", "", &bad).await.unwrap();
    let row = store.get_display_profile(id).await.unwrap().unwrap();
    assert_eq!(row.state, "failed");
    assert_eq!(row.failures.len(), 2, "{:?}", row.failures);
    assert!(
        row.failures[0].starts_with("red transfer: RMS residual 0.106"),
        "{:?}",
        row.failures
    );
    assert!(row.failures[1].contains("ΔE00 10.7"), "{:?}", row.failures);
    let good = store.get_display_profile(lab.profile).await.unwrap().unwrap();
    assert_eq!((good.state, good.failures.len()), ("passed", 0));

    let mut r = request(&lab, &["nstep3"]);
    r.display_profile_id = id;
    match lab.experiments.create(r).await {
        Err(LabError::Conflict(m)) => assert!(
            m.starts_with(&format!(
                "display_profile_id: profile {id} failed its checks (red transfer"
            )),
            "{m}"
        ),
        other => panic!("an experiment on a failed profile: {other:?}"),
    }
}

/// A luminance meter's profile (γ only) passes its own checks, but has no
/// primaries' colour: an experiment on it is refused, saying why and what
/// would do.
#[tokio::test]
async fn an_experiment_on_a_luminance_meters_profile_is_refused_naming_what_would_do() {
    use lightbooth_science::display::{fit_profile, CalibrationPlan, MeasuredPatch, PatchLight};
    let lab = lab().await;
    let display = SimulatedDisplay::crt().unwrap();
    let patches: Vec<MeasuredPatch> = CalibrationPlan::new(8)
        .unwrap()
        .patches
        .iter()
        .map(|p| MeasuredPatch {
            drive: p.drive,
            light: PatchLight::Luminance(
                lightbooth_science::colorimetry::xyz_from_radiance(&display.spectrum(p.drive), Observer::JuddVos)
                    .unwrap()
                    .y,
            ),
            measurement_id: None,
        })
        .collect();
    let profile = fit_profile(&patches, Observer::JuddVos).unwrap();
    let store = &lab.experiments.store;
    let id = store.insert_display_profile("LS-100", "", &profile).await.unwrap();
    assert_eq!(store.get_display_profile(id).await.unwrap().unwrap().state, "passed");
    let mut r = request(&lab, &["nstep3"]);
    r.display_profile_id = id;
    match lab.experiments.create(r).await {
        Err(LabError::Conflict(m)) => assert!(
            m.contains("luminance meter") && m.contains("colorimeter or a spectroradiometer"),
            "{m}"
        ),
        other => panic!("an experiment on a luminance-only profile: {other:?}"),
    }
}

// ---- computed once (issue 46: the daemon under load) ----

/// Regression (issue 46): every GET of an experiment's analysis ran the
/// whole analysis again on the async runtime (≈0.4 s of CPU each), so 200
/// pollers starved the daemon. Polled twice it is computed once; a new
/// trial (a new version of what it reads) computes it again.
#[tokio::test]
async fn an_analysis_polled_twice_is_computed_once_and_again_after_a_new_trial() {
    let lab = lab().await;
    let x = &lab.experiments;
    let computed = crate::computed::Computed::new(x.store().clone(), Observer::JuddVos);
    let e = x.create(small(&lab, &["nstep3", "nstep81"])).await.unwrap();
    let view = started(x, e.id, "obs1").await;
    let first = computed.analysis(e.id).await.unwrap();
    let again = computed.analysis(e.id).await.unwrap();
    assert_eq!(computed.computations(), 1, "the second GET was served from the first");
    assert!(std::sync::Arc::ptr_eq(&first, &again));
    assert_eq!(first.rows.len(), 0);

    let next = view.next.clone().unwrap();
    x.record_trial(view.session.id, &report(next.position, 0, false))
        .await
        .unwrap();
    let after = computed.analysis(e.id).await.unwrap();
    assert_eq!(computed.computations(), 2, "a new trial is a new version");
    assert_eq!(after.rows.iter().map(|r| r.trials).sum::<u32>(), 1);
    computed.analysis(e.id).await.unwrap();
    assert_eq!(computed.computations(), 2);

    // A second observer's session is a new version too.
    started(x, e.id, "obs2").await;
    assert_eq!(computed.analysis(e.id).await.unwrap().sessions, 2);
    assert_eq!(computed.computations(), 3);
}

/// Regression (issue 46): requests arriving while an analysis is computed
/// each started their own; now they wait for the one under way.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn concurrent_requests_for_one_analysis_share_one_computation() {
    let lab = lab().await;
    let x = &lab.experiments;
    let computed = std::sync::Arc::new(crate::computed::Computed::new(x.store().clone(), Observer::JuddVos));
    let e = x.create(small(&lab, &["nstep3", "nstep81"])).await.unwrap();
    started(x, e.id, "obs1").await;
    let polls: Vec<_> = (0..16)
        .map(|_| {
            let computed = computed.clone();
            tokio::spawn(async move { computed.analysis(e.id).await.map(|a| a.experiment_id) })
        })
        .collect();
    for p in polls {
        assert_eq!(p.await.unwrap().unwrap(), e.id);
    }
    assert_eq!(computed.computations(), 1);
}

/// Regression (issue 46): `figure.svg?ids=1,1,…,1` analysed experiment 1
/// once per copy (24 copies, 24 analyses). A repeated id is analysed once;
/// more distinct ids than a figure draws are refused, saying how many.
#[tokio::test]
async fn a_figure_analyses_a_repeated_experiment_once_and_refuses_too_many() {
    let lab = lab().await;
    let x = &lab.experiments;
    let computed = crate::computed::Computed::new(x.store().clone(), Observer::JuddVos);
    let e = x.create(small(&lab, &["nstep3", "nstep81"])).await.unwrap();
    let analyses = computed.analyses(&[e.id; 24]).await.unwrap();
    assert_eq!(analyses.len(), 1);
    assert_eq!(computed.computations(), 1);
    let many: Vec<i64> = (1..=25).collect();
    match computed.analyses(&many).await {
        Err(LabError::Invalid(m)) => assert!(m.contains("query `ids`: 25 distinct experiment ids; give 1–24"), "{m}"),
        other => panic!("expected a refusal, got {:?}", other.map(|v| v.len())),
    }
    assert!(matches!(computed.analyses(&[]).await, Err(LabError::Invalid(_))));
    assert_eq!(computed.computations(), 1, "nothing was computed for a refused figure");
}

/// Regression (issue 46): a scene's summary (every compared measurement
/// read with its samples, a Monte Carlo per coding) was computed again for
/// its JSON, CSV, MAT, every chart and the scenes' overview on every
/// request. Computed once; a new comparison or a rewritten white computes
/// it again.
#[tokio::test]
async fn a_scene_summary_is_computed_once_and_again_after_a_new_comparison_or_white() {
    let lab = lab().await;
    let store = lab.experiments.store().clone();
    let computed = crate::computed::Computed::new(store.clone(), Observer::JuddVos);
    let first = computed.scene_comparisons("white").await.unwrap();
    let again = computed.scene_comparisons("white").await.unwrap();
    assert_eq!(computed.computations(), 1);
    assert!(std::sync::Arc::ptr_eq(&first, &again));
    assert_eq!(first.rows.len(), 3);

    // A new measurement of the target, compared with nstep3.
    let id = completed_measurement(&store, Some(("white", "patch"))).await;
    let row = NewComparison {
        measurement_id: id,
        render_id: first.rows[0].render_id,
        scene: "white".into(),
        target: "patch".into(),
        coding: "nstep3".into(),
        observer: Observer::JuddVos,
        white_source: "test".into(),
        white: [95.0, 100.0, 108.0],
        measured: [40.0, 42.0, 45.0],
        measured_y_se: 0.01,
        rendered: [41.0, 43.0, 46.0],
        rendered_y_se: 0.01,
        y_ratio: 43.0 / 42.0,
        xy_distance: 0.0,
        de76: 1.0,
        de00: 0.5,
    };
    store.insert_comparisons(std::slice::from_ref(&row)).await.unwrap();
    let after = computed.scene_comparisons("white").await.unwrap();
    assert_eq!(computed.computations(), 2);
    let nstep3 = after.rows.iter().find(|r| r.coding == "nstep3").unwrap();
    assert_eq!(nstep3.measurement_id, id, "the newest comparison is summarised");

    // The booth's white rewritten in place: same rows, new ΔE.
    let newest = nstep3.id;
    store
        .update_comparison_whites(&[(newest, "new white".into(), [96.0, 100.0, 109.0], 1.5, 0.7)])
        .await
        .unwrap();
    let rewritten = computed.scene_comparisons("white").await.unwrap();
    assert_eq!(computed.computations(), 3);
    let nstep3 = rewritten.rows.iter().find(|r| r.coding == "nstep3").unwrap();
    assert_eq!((nstep3.white_source.as_str(), nstep3.dE00), ("new white", 0.7));

    // Another scene is kept apart.
    computed.scene_comparisons("red").await.unwrap();
    assert_eq!(computed.computations(), 4);
    computed.scene_comparisons("white").await.unwrap();
    assert_eq!(computed.computations(), 4);
}

/// Regression (issue 46, second round): every poll of a kept result still
/// read its version from the database, so 200 pollers queued for the
/// store's connections (health p99 1.7 s). Polled 50 times with nothing
/// written, the version is read once; a trial written by this process is
/// seen by the very next poll.
#[tokio::test]
async fn polling_a_kept_analysis_reads_its_version_once_until_this_process_writes() {
    let lab = lab().await;
    let x = &lab.experiments;
    let computed = crate::computed::Computed::new(x.store().clone(), Observer::JuddVos);
    let e = x.create(small(&lab, &["nstep3", "nstep81"])).await.unwrap();
    let view = started(x, e.id, "obs1").await;
    for _ in 0..50 {
        computed.analysis(e.id).await.unwrap();
    }
    assert_eq!(computed.version_reads(), 1, "one read for 50 polls");
    assert_eq!(computed.computations(), 1);

    let next = view.next.clone().unwrap();
    x.record_trial(view.session.id, &report(next.position, 0, false))
        .await
        .unwrap();
    let after = computed.analysis(e.id).await.unwrap();
    assert_eq!(
        after.rows.iter().map(|r| r.trials).sum::<u32>(),
        1,
        "the trial is in the next poll"
    );
    assert_eq!(computed.version_reads(), 2);
    assert_eq!(computed.computations(), 2);
}

/// What another daemon sharing the database writes (its own store
/// handle, whose writes this process does not count) is seen once the
/// version read is older than `OTHERS_SEEN_WITHIN`, and not before.
#[tokio::test]
async fn a_trial_written_by_another_daemon_is_seen_within_a_second() {
    let lab = lab().await;
    let x = &lab.experiments;
    let computed = crate::computed::Computed::new(x.store().clone(), Observer::JuddVos);
    let e = x.create(small(&lab, &["nstep3", "nstep81"])).await.unwrap();
    started(x, e.id, "obs1").await;
    let first = computed.analysis(e.id).await.unwrap();
    assert_eq!(first.sessions, 1);

    let other = Experiments::new(store_in(lab._dir.path()).await);
    started(&other, e.id, "obs2").await;
    let soon = computed.analysis(e.id).await.unwrap();
    assert!(
        std::sync::Arc::ptr_eq(&first, &soon),
        "within the second the kept version stands"
    );
    tokio::time::sleep(crate::computed::OTHERS_SEEN_WITHIN + std::time::Duration::from_millis(100)).await;
    let later = computed.analysis(e.id).await.unwrap();
    assert_eq!(later.sessions, 2, "another daemon's session is seen after a second");
}

/// Regression (issue 46, second round): each poll serialised the kept
/// analysis again (a 200-observer analysis is megabytes of JSON) and drew
/// its charts again. A body is made once per kept result, and again for a
/// new one.
#[tokio::test]
async fn a_body_is_made_once_per_kept_result() {
    let lab = lab().await;
    let x = &lab.experiments;
    let computed = crate::computed::Computed::new(x.store().clone(), Observer::JuddVos);
    let e = x.create(small(&lab, &["nstep3", "nstep81"])).await.unwrap();
    let view = started(x, e.id, "obs1").await;
    let made = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let csv = |a: std::sync::Arc<super::analysis::Analysis>| {
        let made = made.clone();
        let computed = &computed;
        async move {
            computed
                .output(&a, "csv", move |a| {
                    made.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                    Ok(super::analysis::analysis_csv(a).into_bytes())
                })
                .await
                .unwrap()
        }
    };
    let one = csv(computed.analysis(e.id).await.unwrap()).await;
    let two = csv(computed.analysis(e.id).await.unwrap()).await;
    assert!(std::sync::Arc::ptr_eq(&one, &two));
    assert_eq!(made.load(std::sync::atomic::Ordering::SeqCst), 1);

    let next = view.next.clone().unwrap();
    x.record_trial(view.session.id, &report(next.position, 1, false))
        .await
        .unwrap();
    let three = csv(computed.analysis(e.id).await.unwrap()).await;
    assert_eq!(
        made.load(std::sync::atomic::Ordering::SeqCst),
        2,
        "a new analysis, a new body"
    );
    assert_ne!(one, three, "the new body has the trial");
}

/// The analysis and thresholds CSVs (issue 47: written by hand with
/// `format!`, now by the `csv` crate) read back with a CSV reader, every
/// row with the header's columns, the fitter's sentences (commas in them)
/// whole in their one cell.
#[tokio::test]
async fn the_analysis_csvs_read_back_whole_with_a_csv_reader() {
    let lab = lab().await;
    let x = &lab.experiments;
    let e = x.create(small(&lab, &["nstep3", "nstep81"])).await.unwrap();
    let view = started(x, e.id, "obs.1").await;
    let next = view.next.clone().unwrap();
    x.record_trial(view.session.id, &report(next.position, 1, false))
        .await
        .unwrap();
    let a = x.analyze(e.id).await.unwrap();
    let mut sentences = 0;
    for (what, text) in [
        ("analysis", super::analysis::analysis_csv(&a)),
        ("thresholds", super::analysis::thresholds_csv(&a)),
    ] {
        let mut r = csv::Reader::from_reader(text.as_bytes());
        let header = r.headers().unwrap().clone();
        let observer = header.iter().position(|h| h == "observer").unwrap();
        let rows: Vec<csv::StringRecord> = r.records().map(|row| row.unwrap()).collect();
        assert!(!rows.is_empty(), "{what}: {text}");
        for row in &rows {
            assert_eq!(row.len(), header.len(), "{what}: {text}");
            assert_eq!(&row[observer], "obs.1", "{what}: {text}");
            for name in ["at_bounds", "not_fitted"] {
                if let Some(k) = header.iter().position(|h| h == name) {
                    if row[k].contains(", ") {
                        sentences += 1;
                    }
                }
            }
        }
    }
    assert!(
        sentences > 0,
        "no sentence with a comma was written: nothing was checked"
    );
}
