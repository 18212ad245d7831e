//! Recovery of gone daemons' work: only theirs, each row once, also after
//! a database outage and for a dead predecessor on the same host.

use super::*;

/// The state and error of measurement `id`.
pub(super) async fn state_of(store: &Store, id: i64) -> (MeasurementState, Option<String>, usize) {
    let m = store.get_measurement(id).await.unwrap().unwrap();
    (m.summary.state, m.summary.error, m.samples.len())
}

/// Leases (migration 0010): a daemon whose lease expired or that stopped
/// loses its unfinished work to whoever recovers — interrupted, samples
/// kept, the error naming it — while a live daemon's running work is left
/// alone; rows naming no daemon are recovered only when asked (at a
/// daemon's start); a caller holding the database alone (SQLite's file
/// lock) recovers everything.
pub(super) async fn recovery_interrupts_only_the_work_of_gone_daemons_and_rows_naming_none(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let lease = Duration::from_secs(3600);
    let live = store.register_daemon(&"north".parse().unwrap(), lease).await.unwrap();
    let lapsing = store
        .register_daemon(&"south".parse().unwrap(), Duration::from_millis(50))
        .await
        .unwrap();
    let stopping = store.register_daemon(&"east".parse().unwrap(), lease).await.unwrap();
    let running_as = |daemon: Option<i64>| {
        let store = daemon.map_or_else(|| store.clone(), |d| store.as_daemon(d));
        async move {
            let id = store.create_measurement(&new_measurement()).await.unwrap();
            store.mark_running(id, None).await.unwrap();
            store.insert_sample(id, &sample(0, true)).await.unwrap();
            id
        }
    };
    let of_live = running_as(Some(live)).await;
    let of_lapsing = running_as(Some(lapsing)).await;
    let of_stopping = running_as(Some(stopping)).await;
    let of_none = running_as(None).await;
    let study_of_lapsing = store
        .as_daemon(lapsing)
        .create_study(&serde_json::json!({}))
        .await
        .unwrap();
    store.mark_daemon_stopped(stopping).await.unwrap();
    // The lapsing daemon's 50 ms lease runs out on the database's clock.
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(store.heartbeat(live).await.unwrap());

    let noticer = store.as_daemon(live);
    let heartbeat_scope = RecoveryScope {
        rows_without_daemon: false,
        every_daemon_is_gone: false,
    };
    let recovered = noticer.recover_abandoned_work(heartbeat_scope).await.unwrap();
    assert_eq!(
        (recovered.measurements, recovered.renders, recovered.studies),
        (2, 0, 1)
    );
    // Recovery returns the rows it marked, with their errors, so the daemon
    // that noticed can send their events (`lab::lease`).
    let mut ids: Vec<(&str, i64)> = recovered
        .interrupted
        .iter()
        .map(|w| match w {
            InterruptedWork::Measurement { id, error } => {
                assert!(error.contains("before this measurement finished"), "{error}");
                ("measurement", *id)
            }
            InterruptedWork::Render { id, .. } => ("render", *id),
            InterruptedWork::Study { id, error } => {
                assert!(error.contains("retry it with POST /api/studies/"), "{error}");
                ("study", *id)
            }
        })
        .collect();
    ids.sort();
    let mut expected = vec![
        ("measurement", of_lapsing),
        ("measurement", of_stopping),
        ("study", study_of_lapsing),
    ];
    expected.sort();
    assert_eq!(ids, expected);
    let (state, error, samples) = state_of(&store, of_lapsing).await;
    assert_eq!((state, samples), (MeasurementState::Interrupted, 1));
    let error = error.unwrap();
    let pid = std::process::id();
    assert!(
        error.contains("booth `south`")
            && error.contains(&format!("pid {pid}"))
            && error.contains("stopped heartbeating"),
        "{error}"
    );
    let (state, error, samples) = state_of(&store, of_stopping).await;
    assert_eq!((state, samples), (MeasurementState::Interrupted, 1));
    assert!(error.as_deref().unwrap().contains("booth `east`") && error.as_deref().unwrap().contains("stopped at"));
    let study = store.get_study(study_of_lapsing).await.unwrap().unwrap();
    assert_eq!(study.state, "interrupted");
    assert!(study
        .error
        .as_deref()
        .unwrap()
        .contains("retry it with POST /api/studies/"));
    assert_eq!(state_of(&store, of_live).await.0, MeasurementState::Running);
    assert_eq!(state_of(&store, of_none).await.0, MeasurementState::Running);
    // Nothing is left to recover: a second pass changes nothing.
    assert_eq!(
        noticer.recover_abandoned_work(heartbeat_scope).await.unwrap(),
        Recovered::default()
    );

    // At a daemon's start: the rows naming no daemon too, still not the live one's.
    let at_start = RecoveryScope {
        rows_without_daemon: true,
        every_daemon_is_gone: false,
    };
    let recovered = store.recover_abandoned_work(at_start).await.unwrap();
    assert_eq!(recovered.total(), 1);
    let (state, _, samples) = state_of(&store, of_none).await;
    assert_eq!((state, samples), (MeasurementState::Interrupted, 1));
    assert_eq!(state_of(&store, of_live).await.0, MeasurementState::Running);

    // Holding the database alone, even the live-looking daemon is gone.
    let alone = RecoveryScope {
        rows_without_daemon: true,
        every_daemon_is_gone: true,
    };
    assert_eq!(store.recover_abandoned_work(alone).await.unwrap().measurements, 1);
    assert_eq!(state_of(&store, of_live).await.0, MeasurementState::Interrupted);
}

/// Two daemons noticing the same gone daemon at the same moment: the
/// conditional UPDATE interrupts each of its rows exactly once (the counts
/// of the two recoveries add up to the rows), and the row keeps one error.
pub(super) async fn two_daemons_recovering_the_same_gone_daemon_at_once_interrupt_each_row_once(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let lease = Duration::from_secs(3600);
    let a = store.as_daemon(store.register_daemon(&"a".parse().unwrap(), lease).await.unwrap());
    let b = store.as_daemon(store.register_daemon(&"b".parse().unwrap(), lease).await.unwrap());
    let gone = store.register_daemon(&"c".parse().unwrap(), lease).await.unwrap();
    let gone_store = store.as_daemon(gone);
    let mut ids = Vec::new();
    for _ in 0..20 {
        let id = gone_store.create_measurement(&new_measurement()).await.unwrap();
        ids.push(id);
    }
    gone_store.mark_running(ids[0], None).await.unwrap();
    store.mark_daemon_stopped(gone).await.unwrap();
    let scope = RecoveryScope {
        rows_without_daemon: false,
        every_daemon_is_gone: false,
    };
    let (ra, rb) = tokio::join!(a.recover_abandoned_work(scope), b.recover_abandoned_work(scope));
    assert_eq!(ra.unwrap().measurements + rb.unwrap().measurements, 20);
    for id in ids {
        let (state, error, _) = state_of(&store, id).await;
        assert_eq!(state, MeasurementState::Interrupted);
        assert!(error.unwrap().contains("booth `c`"));
    }
}

/// The bug: a database outage longer than a lease let a neighbour mark a
/// live daemon's running measurement interrupted ("stopped heartbeating")
/// as soon as the database was back, before the live daemon's next beat.
/// A noticer that saw the database come back only at `seen_since` counts
/// no lease time before it; once a whole lease passes after it with no
/// beat, the daemon is gone after all.
pub(super) async fn a_live_daemons_lease_lapsed_during_a_database_outage_and_a_neighbour_took_its_work(
    engine: EngineKind,
) {
    let (_dir, store, _) = temp_store(engine).await;
    let noticer = store
        .register_daemon(&"north".parse().unwrap(), Duration::from_secs(3600))
        .await
        .unwrap();
    let live = store
        .register_daemon(&"south".parse().unwrap(), Duration::from_millis(300))
        .await
        .unwrap();
    let id = store
        .as_daemon(live)
        .create_measurement(&new_measurement())
        .await
        .unwrap();
    store.as_daemon(live).mark_running(id, None).await.unwrap();
    // The outage: no beat for longer than the lease.
    tokio::time::sleep(Duration::from_millis(600)).await;
    let back_at = store
        .renew_lease(noticer)
        .await
        .unwrap()
        .expect("the noticer's lease is not stopped");
    let scope = RecoveryScope {
        rows_without_daemon: false,
        every_daemon_is_gone: false,
    };
    let recovered = store
        .as_daemon(noticer)
        .recover_abandoned_work_seen_since(scope, Some(back_at))
        .await
        .unwrap();
    assert_eq!(recovered.total(), 0, "{recovered:?}");
    assert_eq!(state_of(&store, id).await.0, MeasurementState::Running);
    // Renewed late, after the outage: still its own.
    assert!(store.heartbeat(live).await.unwrap());
    // A whole lease after the return without a beat: gone.
    tokio::time::sleep(Duration::from_millis(600)).await;
    let recovered = store
        .as_daemon(noticer)
        .recover_abandoned_work_seen_since(scope, Some(back_at))
        .await
        .unwrap();
    assert_eq!(recovered.measurements, 1, "{recovered:?}");
    assert_eq!(state_of(&store, id).await.0, MeasurementState::Interrupted);
}

/// A daemon's start recovers at once the work of its booth's earlier
/// daemon registered on this host whose process is gone (a pid no process
/// has), and marks it stopped; another booth's, and its own, are left alone.
pub(super) async fn a_dead_predecessor_on_this_host_is_recovered_at_once_a_live_one_is_not(engine: EngineKind) {
    let (_dir, store, _) = temp_store(engine).await;
    let lease = Duration::from_secs(3600);
    let north: Booth = "north".parse().unwrap();
    let dead = store.register_daemon(&north, lease).await.unwrap();
    let other_booth = store.register_daemon(&"south".parse().unwrap(), lease).await.unwrap();
    // The dead one's pid: beyond Linux's pid_max (4 194 304), so no process has it.
    with_pool!(store, |pool| sqlx::query(
        "UPDATE daemons SET pid = 99999999 WHERE id IN ($1, $2)"
    )
    .bind(dead)
    .bind(other_booth)
    .execute(pool)
    .await
    .map(|_| ())
    .unwrap());
    let running_as = |daemon: i64| {
        let store = store.as_daemon(daemon);
        async move {
            let id = store.create_measurement(&new_measurement()).await.unwrap();
            store.mark_running(id, None).await.unwrap();
            id
        }
    };
    let of_dead = running_as(dead).await;
    let of_other_booth = running_as(other_booth).await;
    let successor = store.register_daemon(&north, lease).await.unwrap();
    let recovered = store
        .as_daemon(successor)
        .recover_dead_predecessors(&north)
        .await
        .unwrap();
    assert_eq!(recovered.measurements, 1, "{recovered:?}");
    let (state, error, _) = state_of(&store, of_dead).await;
    assert_eq!(state, MeasurementState::Interrupted);
    let error = error.unwrap();
    assert!(
        error.contains("pid 99999999") && error.contains("process is gone"),
        "{error}"
    );
    assert!(store.daemon(dead).await.unwrap().unwrap().stopped_at.is_some());
    assert_eq!(state_of(&store, of_other_booth).await.0, MeasurementState::Running);
    // The successor itself is never its own predecessor.
    let again = store
        .as_daemon(successor)
        .recover_dead_predecessors(&north)
        .await
        .unwrap();
    assert_eq!(again.total(), 0);
}
