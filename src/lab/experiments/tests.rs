//! The experiment workflow on a real SQLite file: set up from a stored
//! measurement and its comparisons, checked, run trial by trial with a
//! dropped frame and a resumed session, analysed.

use super::session::TrialReport;
use super::*;
use crate::colorimetry::Observer;
use crate::display::profile::TransferModel;
use crate::display::SimulatedDisplay;
use crate::lab::testing::{queued_measurement, store_in};
use crate::store::{Average, NewComparison, NewRender};

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
    let id = queued_measurement(&store, Some(("white", "patch"))).await;
    store.mark_running(id, None).await.unwrap();
    let average = Average {
        wavelength_nm: vec![380.0, 780.0],
        radiance: vec![0.01, 0.01],
        radiance_sd: vec![0.0; 2],
        luminance_cd_m2: 0.0,
        x: 0.0,
        y: 0.0,
        luminance_cv: 0.0,
        xyz: None,
        observer: None,
    };
    store.complete_measurement(id, &average).await.unwrap();
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

fn report(position: usize, response: u8, dropped: bool) -> TrialReport {
    TrialReport {
        position,
        response,
        reaction_ms: 650.0,
        stimulus_frames: 18,
        dropped_frames: u32::from(dropped),
        dropped_in_stimulus: dropped,
        frame_intervals_ms: vec![16.7; 80],
    }
}

/// An observer who always finds nstep3 and always answers "left" for
/// nstep81: 36 of 36 and 12 of 36 (the odd piece is left in two of the six
/// configurations).
#[tokio::test]
async fn a_session_records_every_trial_repeats_dropped_ones_and_resumes() {
    let lab = lab().await;
    let x = &lab.experiments;
    let e = x.create(request(&lab, &["nstep3", "nstep81"])).await.unwrap();
    let mut view = x.start_session(e.id, "obs1").await.unwrap();
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
        row("nstep3").differencing.rule,
        Some(crate::psychophysics::oddity::ALL_CORRECT_RULE)
    );
    assert_eq!((row("nstep81").correct, row("nstep81").trials), (12, 36));
    assert_eq!(row("nstep3").excluded + row("nstep81").excluded, 1);
    assert!(row("nstep81").differencing.d_prime < 0.5);
    let csv = analysis::analysis_csv(&a);
    assert_eq!(csv.lines().count(), 3);
    assert!(csv.lines().nth(1).unwrap().contains(",obs1,nstep3,36,36,"), "{csv}");
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
    let view = x.start_session(e.id, "obs01").await.unwrap();
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
    use crate::lab::instrument_queue::InstrumentStatus;
    use crate::lab::queue::{queue, QueueSources};
    use crate::store::Booth;
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
    let elsewhere = jobs_of("booth-2".parse().unwrap()).await;
    assert!(elsewhere.is_empty(), "another booth's queue lists {elsewhere:?}");
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
    bad.validation[0].delta_e00 = 10.7;
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
