//! The scale test's correctness with a small load, on PostgreSQL: three
//! `lightbooth serve` processes (three simulated booths) on one database,
//! ten scene-target measurements submitted to each at once through the
//! API; every one must end as exactly one complete row of its booth with
//! one comparison per coding. The same harness with a large load and the
//! figures is `cargo bench --bench booths_scale`.
//!
//! The two scenes' renders are made first, by one booth (a measurement of
//! each, compared): the other daemons find them in the database, so the
//! test does not wait for every daemon to render (and preview) each scene.

use crate::common;

use crate::common::booths;

use std::time::Duration;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn three_booths_measuring_at_once_lose_nothing_duplicate_nothing_and_compare_everything() {
    let db = common::fresh_postgres_database().await;
    let options = booths::ServeOptions {
        render_samples: 256,
        ..booths::ServeOptions::default()
    };
    let lab = booths::start_lab(&db, &booths::booth_names(3), &options).await;
    let targets = [("red", "patch"), ("white", "patch")];
    let first = &lab.daemons[0];
    let mut warm_up = Vec::new();
    for (scene, target) in targets {
        let note = format!("warm-up {scene}");
        let id = booths::submit(first.addr, scene, target, 1, &note).await;
        warm_up.push(booths::Submission {
            note,
            booth: first.booth.clone(),
            scene: scene.into(),
            target: target.into(),
            id,
        });
    }
    let a = booths::audit_when_settled(first.addr, &warm_up, &options.codings, Duration::from_secs(300)).await;
    assert!(a.passed(), "the warm-up measurements: {a:#?}");
    let load = booths::run_load(&lab, "ci", 10, 2, &targets, &options.codings, Duration::from_secs(300)).await;
    let a = &load.audit;
    assert_eq!(a.submitted, 30);
    assert!(a.lost.is_empty(), "lost: {:#?}", a.lost);
    assert!(a.duplicated.is_empty(), "duplicated: {:#?}", a.duplicated);
    assert!(a.not_complete.is_empty(), "not complete: {:#?}", a.not_complete);
    assert!(a.mismatched.is_empty(), "mismatched: {:#?}", a.mismatched);
    assert!(
        a.comparisons_missing.is_empty(),
        "comparisons missing: {:#?}",
        a.comparisons_missing
    );
    assert_eq!(a.comparisons, 30 * options.codings.len());
    // Each booth's rows are its own, as `?booth=` gives them.
    for (k, d) in lab.daemons.iter().enumerate() {
        let (_, page) = common::get_json(lab.daemons[0].addr, &format!("/api/measurements?booth={}", d.booth)).await;
        let warm_ups = if k == 0 { targets.len() } else { 0 };
        assert_eq!(page["total"], 10 + warm_ups, "{page}");
    }
}
