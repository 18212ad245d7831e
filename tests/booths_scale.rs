//! The scale test's correctness with a small load, on PostgreSQL: three
//! `lightbooth serve` processes (three simulated booths) on one database,
//! ten scene-target measurements submitted to each at once through the
//! API; every one must end as exactly one complete row of its booth with
//! one comparison per coding. The same harness with a large load and the
//! figures is `cargo bench --bench booths_scale`.

mod common;

#[path = "common/booths.rs"]
mod booths;

use std::time::Duration;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn three_booths_measuring_at_once_lose_nothing_duplicate_nothing_and_compare_everything() {
    let db = common::fresh_postgres_database().await;
    let options = booths::ServeOptions {
        render_samples: 256,
        ..booths::ServeOptions::default()
    };
    let lab = booths::start_lab(&db, &booths::booth_names(3), &options).await;
    let load = booths::run_load(&lab, "ci", 10, 2, &options.codings, Duration::from_secs(120)).await;
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
    for d in &lab.daemons {
        let (_, page) = common::get_json(lab.daemons[0].addr, &format!("/api/measurements?booth={}", d.booth)).await;
        assert_eq!(page["total"], 10, "{page}");
    }
}
