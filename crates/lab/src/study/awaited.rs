//! A study started with `measure_missing` waits here for the measurements
//! the API queued for it (one per target that had no complete measurement),
//! reporting progress as they finish. The instrument task takes them like
//! any other measurement; the study only reads their outcome from the store.
//!
//! The wait is bounded: if none of them makes progress (a new sample or a
//! new final state) for [`STALL_LIMIT`] — a disconnected instrument, say —
//! the study fails saying so, instead of waiting forever.

use std::time::Duration;

use lightbooth_store::{MeasurementState, Store};

/// How long the measurements may show no progress before the study gives up.
pub const STALL_LIMIT: Duration = Duration::from_secs(600);

const POLL: Duration = Duration::from_millis(250);

/// Waits until every measurement of `ids` is final. Ok when all are
/// complete; otherwise an error naming the ones that are not, and why.
pub async fn wait_for_measurements(store: &Store, ids: &[i64], progress: &(dyn Fn(&str) + Sync)) -> Result<(), String> {
    let n = ids.len();
    progress(&format!(
        "measuring the {n} missing target{} first",
        if n == 1 { "" } else { "s" }
    ));
    let mut last_seen = (usize::MAX, usize::MAX);
    let mut last_change = tokio::time::Instant::now();
    loop {
        let mut done = 0;
        let mut samples = 0;
        let mut failed = Vec::new();
        let mut running = None;
        for &id in ids {
            let m = store
                .get_measurement(id)
                .await
                .map_err(|e| e.to_string())?
                .ok_or_else(|| format!("measurement {id} vanished"))?;
            let s = &m.summary;
            samples += s.samples_taken as usize;
            let what = format!(
                "{}/{}",
                s.scene.as_deref().unwrap_or("-"),
                s.target.as_deref().unwrap_or("-")
            );
            match s.state {
                MeasurementState::Complete => done += 1,
                MeasurementState::Running => {
                    running = Some(format!(
                        "measurement {id} ({what}): sample {} of {}",
                        s.samples_taken, s.samples_requested
                    ))
                }
                MeasurementState::Queued => {}
                other => failed.push(format!(
                    "measurement {id} ({what}) ended {}{}",
                    other.as_str(),
                    s.error.as_ref().map(|e| format!(": {e}")).unwrap_or_default()
                )),
            }
        }
        if !failed.is_empty() {
            return Err(format!(
                "the study needs every target measured, and {}; measure {} again, then start the study again",
                failed.join("; "),
                if failed.len() == 1 { "it" } else { "them" }
            ));
        }
        if done == n {
            progress(&format!("all {n} missing targets measured; starting the study"));
            return Ok(());
        }
        if (done, samples) != last_seen {
            last_seen = (done, samples);
            last_change = tokio::time::Instant::now();
            progress(&format!(
                "measuring the missing targets: {done} of {n} done{}",
                running.map(|r| format!("; {r}")).unwrap_or_default()
            ));
        } else if last_change.elapsed() > STALL_LIMIT {
            return Err(format!(
                "the missing targets' measurements made no progress in {} s ({done} of {n} done); \
                 is the instrument connected? (see /api/health)",
                STALL_LIMIT.as_secs()
            ));
        }
        tokio::time::sleep(POLL).await;
    }
}
