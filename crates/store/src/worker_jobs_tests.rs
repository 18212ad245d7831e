//! Worker jobs on both engines: claims never hand one job to two workers,
//! a gone worker's job (and its render row) is queued again and fails after
//! [`MAX_ATTEMPTS`] claims, lease recovery leaves job subjects alone, and
//! cancelling ends a queued job or flags a running one.

use std::collections::BTreeSet;
use std::time::Duration;

use super::super::engine::EngineKind;
use super::super::test_db::{on_both_engines, TestDb};
use super::super::*;
use super::MAX_ATTEMPTS;

on_both_engines!(
    workers_claiming_at_once_never_take_the_same_job,
    a_second_worker_takes_another_scene_than_the_one_being_rendered,
    a_gone_workers_render_is_queued_again_never_interrupted_and_fails_after_max_attempts,
    cancelling_ends_a_queued_job_and_flags_a_running_one,
);

/// A registered process of `booth` on the store at `url`, acting as itself.
async fn registered(url: &str, booth: &str) -> Store {
    let store = Store::open_as_tool(url).await.unwrap();
    let id = store
        .register_daemon(&booth.parse().unwrap(), Duration::from_secs(30))
        .await
        .unwrap();
    store.as_daemon(id)
}

async fn workers_claiming_at_once_never_take_the_same_job(engine: EngineKind) {
    let db = TestDb::new(engine).await;
    let daemon = registered(&db.url, "north").await;
    for subject in 1..=30 {
        daemon
            .queue_worker_job(WorkerJobKind::Comparison, subject, &serde_json::json!({}))
            .await
            .unwrap();
    }
    let mut claimers = Vec::new();
    for _ in 0..3 {
        let worker = registered(&db.url, "workers").await;
        claimers.push(tokio::spawn(async move {
            let mut got = Vec::new();
            while let Some(job) = worker.claim_worker_job().await.unwrap() {
                assert_eq!(job.attempts, 1);
                got.push(job.subject_id);
                tokio::task::yield_now().await;
            }
            got
        }));
    }
    let mut all = Vec::new();
    for c in claimers {
        all.extend(c.await.unwrap());
    }
    let distinct: BTreeSet<i64> = all.iter().copied().collect();
    assert_eq!(all.len(), 30, "every job claimed exactly once: {all:?}");
    assert_eq!(distinct, (1..=30).collect::<BTreeSet<i64>>());
}

async fn a_gone_workers_render_is_queued_again_never_interrupted_and_fails_after_max_attempts(engine: EngineKind) {
    let db = TestDb::new(engine).await;
    let daemon = registered(&db.url, "north").await;
    let render = daemon
        .create_render(&NewRender {
            scene: "white".into(),
            scene_hash: "0123456789abcdef".into(),
            settings_json: serde_json::json!({"samples": 2}),
            codings: vec!["rgb".into()],
            seed: 1,
        })
        .await
        .unwrap();
    let job = daemon
        .queue_worker_job(WorkerJobKind::Render, render, &serde_json::json!({"scene": "white"}))
        .await
        .unwrap();
    for attempt in 1..=MAX_ATTEMPTS {
        let worker = registered(&db.url, "workers").await;
        let claimed = worker.claim_worker_job().await.unwrap().expect("the job is queued");
        assert_eq!((claimed.id, claimed.attempts), (job, attempt));
        assert!(
            worker.start_job(Job::Render, render).await.unwrap(),
            "its render row is queued"
        );
        // The worker dies (stopped counts as gone at once, as an expired lease does).
        worker.mark_daemon_stopped(worker.daemon_id().unwrap()).await.unwrap();
        // Lease recovery alone never interrupts a job's render...
        let recovered = daemon
            .recover_abandoned_work(RecoveryScope {
                rows_without_daemon: true,
                every_daemon_is_gone: false,
            })
            .await
            .unwrap();
        assert_eq!(recovered.renders, 0, "attempt {attempt}");
        assert_eq!(daemon.get_render(render).await.unwrap().unwrap().state, "running");
        // ...the job queue takes it back.
        assert_eq!(daemon.requeue_abandoned_jobs().await.unwrap(), 1);
        let row = daemon.worker_job(job).await.unwrap().unwrap();
        let render_row = daemon.get_render(render).await.unwrap().unwrap();
        if attempt < MAX_ATTEMPTS {
            assert_eq!(
                (row.state.as_str(), row.worker_id),
                ("queued", None),
                "attempt {attempt}"
            );
            assert_eq!(render_row.state, "queued");
        } else {
            assert_eq!(row.state, "failed");
            assert_eq!(render_row.state, "failed");
            let error = render_row.error.unwrap();
            assert!(error.contains("3 workers stopped while running this render"), "{error}");
        }
    }
    assert_eq!(
        daemon.requeue_abandoned_jobs().await.unwrap(),
        0,
        "nothing left to take back"
    );
}

async fn cancelling_ends_a_queued_job_and_flags_a_running_one(engine: EngineKind) {
    let db = TestDb::new(engine).await;
    let daemon = registered(&db.url, "north").await;
    let worker = registered(&db.url, "workers").await;
    let first = daemon
        .queue_worker_job(WorkerJobKind::Study, 7, &serde_json::json!({}))
        .await
        .unwrap();
    daemon
        .queue_worker_job(WorkerJobKind::Study, 8, &serde_json::json!({}))
        .await
        .unwrap();
    assert!(
        daemon
            .queue_worker_job(WorkerJobKind::Study, 8, &serde_json::json!({}))
            .await
            .is_err(),
        "one job per subject"
    );
    let claimed = worker.claim_worker_job().await.unwrap().unwrap();
    assert_eq!(claimed.id, first);
    assert!(!worker.worker_job_cancel_requested(first).await.unwrap());
    assert_eq!(
        daemon.cancel_worker_job(WorkerJobKind::Study, 7).await.unwrap(),
        Some(false)
    );
    assert!(worker.worker_job_cancel_requested(first).await.unwrap());
    assert_eq!(
        daemon.cancel_worker_job(WorkerJobKind::Study, 8).await.unwrap(),
        Some(true)
    );
    let second = daemon.worker_job_of(WorkerJobKind::Study, 8).await.unwrap().unwrap();
    assert_eq!(second.state, "cancelled");
    assert_eq!(daemon.cancel_worker_job(WorkerJobKind::Study, 9).await.unwrap(), None);
    assert!(
        worker.claim_worker_job().await.unwrap().is_none(),
        "a cancelled job is not claimed"
    );
    assert!(worker
        .finish_worker_job(first, "cancelled", Some("cancelled by a client"))
        .await
        .unwrap());
    assert_eq!(daemon.unfinished_worker_jobs_requested().await.unwrap(), 0);
}

/// Comparisons of red, red, green queued in that order: while the first
/// worker holds red (rendering it), the second takes green, which it can
/// render meanwhile, not the second red, which would wait for the first.
async fn a_second_worker_takes_another_scene_than_the_one_being_rendered(engine: EngineKind) {
    let db = TestDb::new(engine).await;
    let daemon = registered(&db.url, "north").await;
    for (subject, scene) in [(1, "red"), (2, "red"), (3, "green")] {
        daemon
            .queue_worker_job(
                WorkerJobKind::Comparison,
                subject,
                &serde_json::json!({ "scene": scene }),
            )
            .await
            .unwrap();
    }
    let first = registered(&db.url, "workers").await;
    let second = registered(&db.url, "workers").await;
    assert_eq!(first.claim_worker_job().await.unwrap().unwrap().subject_id, 1);
    assert_eq!(second.claim_worker_job().await.unwrap().unwrap().subject_id, 3);
    assert_eq!(
        second.claim_worker_job().await.unwrap().unwrap().subject_id,
        2,
        "then the rest, oldest first"
    );
}
