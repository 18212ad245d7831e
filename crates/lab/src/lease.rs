//! A process's lease on the work it writes (`store::leases`): it registers
//! in `daemons` (booth, host, pid), renews its heartbeat on a background
//! task while it runs, and is marked stopped at the end. `serve` holds one,
//! and so do the one-shot commands that create jobs (`study`), so a daemon
//! starting beside a tool never counts the tool's running study as
//! abandoned.
//!
//! A daemon's heartbeat also recovers the work of daemons that are gone and
//! tells its event clients (`/api/events`) which of their measurements,
//! renders and studies it interrupted, after queueing again the jobs of
//! render workers that are gone; a render worker's heartbeat does the same
//! (its events reach nobody). A tool's heartbeat only renews its lease (it
//! has no event clients, and a daemon that notices is better placed to tell
//! the dashboards).

use std::time::Duration;

use crate::events::{Event, EventSink};
use lightbooth_store::{Booth, InterruptedWork, MeasurementState, Recovered, RecoveryScope, Store, StoreError};

/// A registered lease and its heartbeat task; the heartbeat stops when the
/// lease is released or dropped (also when its holder fails early).
pub struct Lease {
    id: i64,
    store: Store,
    heartbeat: tokio::task::JoinHandle<()>,
}

impl Lease {
    /// Registers a process of `booth` holding a lease of `lease`, renewed
    /// every `interval`. With `events`, every beat also recovers the work of
    /// gone daemons and sends an event for each row it interrupted.
    pub async fn take(
        store: &Store,
        booth: &Booth,
        lease: Duration,
        interval: Duration,
        events: Option<EventSink>,
    ) -> Result<Lease, StoreError> {
        let id = store.register_daemon(booth, lease).await?;
        let store = store.as_daemon(id);
        let heartbeat = tokio::spawn(heartbeat(store.clone(), id, interval, events));
        Ok(Lease { id, store, heartbeat })
    }

    /// The lease's id (its `daemons` row).
    pub fn id(&self) -> i64 {
        self.id
    }

    /// A store handle acting for this lease: rows it creates or starts name it.
    pub fn store(&self) -> &Store {
        &self.store
    }

    /// Stops the heartbeat and marks the lease stopped: whatever the holder
    /// left unfinished is recovered by the next daemon that notices.
    pub async fn release(self) -> Result<(), StoreError> {
        self.heartbeat.abort();
        self.store.mark_daemon_stopped(self.id).await
    }
}

impl Drop for Lease {
    fn drop(&mut self) {
        self.heartbeat.abort();
    }
}

/// The events that tell a dashboard a gone daemon's work ended.
pub fn interruption_events(recovered: &Recovered) -> Vec<Event> {
    recovered
        .interrupted
        .iter()
        .map(|w| match w.clone() {
            InterruptedWork::Measurement { id, error } => Event::MeasurementFinished {
                measurement_id: id,
                state: MeasurementState::Interrupted,
                error: Some(error),
            },
            InterruptedWork::Render { id, scene, error } => Event::RenderFinished {
                render_id: id,
                scene,
                ok: false,
                error: Some(error),
            },
            InterruptedWork::Study { id, error } => Event::StudyFinished {
                study_id: id,
                ok: false,
                error: Some(error),
            },
        })
        .collect()
}

/// Renews lease `id` every `interval`; with `events`, also recovers the
/// work of daemons whose lease expired and sends its events. Runs until
/// aborted. A database error is logged and retried at the next beat, for as
/// long as it takes: the first renewal after a failed one is the moment this
/// daemon saw the database come back, and no lease it judges counts time
/// before it (`store::leases`, the outage rule), so an outage neither
/// expires this daemon's lease nor lets it take a neighbour's work that
/// was only renewed late.
async fn heartbeat(store: Store, id: i64, interval: Duration, events: Option<EventSink>) {
    let mut ticks = tokio::time::interval(interval);
    ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    // Whether the last renewal failed, and since when (database time) the
    // renewals have succeeded after the last failure.
    let mut failing = false;
    let mut seen_since: Option<f64> = None;
    loop {
        ticks.tick().await;
        match store.renew_lease(id).await {
            Ok(at) => {
                if std::mem::take(&mut failing) {
                    tracing::info!(daemon = id, "the database answers again: lease renewed");
                    seen_since = at;
                }
                if at.is_none() {
                    tracing::warn!(daemon = id, "this daemon's lease row is marked stopped");
                }
            }
            Err(e) => {
                tracing::warn!(daemon = id, error = %e, "cannot renew this daemon's lease; retrying at the next beat");
                failing = true;
                continue;
            }
        }
        let Some(events) = &events else { continue };
        // Before recovery: a gone render worker's render and study rows go
        // back to the queue (`store/worker_jobs.rs`), never to `interrupted`.
        if let Err(e) = store.requeue_abandoned_jobs().await {
            tracing::warn!(daemon = id, error = %e, "cannot queue again the jobs of gone render workers");
        }
        match store
            .recover_abandoned_work_seen_since(
                RecoveryScope {
                    rows_without_daemon: false,
                    every_daemon_is_gone: false,
                },
                seen_since,
            )
            .await
        {
            Ok(recovered) => {
                for event in interruption_events(&recovered) {
                    // No receiver (no dashboard open) is not an error.
                    events.send(event);
                }
            }
            Err(e) => tracing::warn!(daemon = id, error = %e, "cannot recover the work of gone daemons"),
        }
    }
}
