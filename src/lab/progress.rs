//! How far each render and study of this daemon has got, and roughly how
//! long it still needs: the dashboard's queue (`GET /api/jobs`) reads it.
//!
//! A [`ProgressBoard`] follows the event bus and keeps the newest
//! `render_progress` and `study_progress` of every job still running; a
//! job's `*_finished` event removes it.
//!
//! **The estimate is an extrapolation**, stated as such wherever it is
//! shown: the time spent so far in the job's current phase, scaled by the
//! fraction still to do ([`seconds_left`]). It assumes the rest goes at the
//! pace of what is done; a study's steps (truth, one render per seed,
//! sweeps) are counted as equal, so its estimate is rougher than a
//! render's, whose fraction is paths traced over paths planned.
//!
//! ```
//! use lightbooth::lab::progress::seconds_left;
//! // A quarter done after 30 s: about 90 s to go.
//! assert_eq!(seconds_left(30.0, 0.25), Some(90.0));
//! // Too little done to extrapolate from.
//! assert_eq!(seconds_left(1.0, 0.001), None);
//! ```

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use serde::Serialize;
use tokio::sync::broadcast;
use utoipa::ToSchema;

use super::events::Event;
use crate::store::Job;

/// Below this fraction done, no estimate is given: a job's first moments
/// (loading a scene, warming caches) say little about its pace.
pub const MIN_FRACTION_FOR_ESTIMATE: f64 = 0.01;

/// Seconds still needed by a job that took `elapsed` seconds for
/// `fraction` (0–1) of its work, if the rest goes at the same pace; `None`
/// below [`MIN_FRACTION_FOR_ESTIMATE`] or for numbers that are not finite.
pub fn seconds_left(elapsed: f64, fraction: f64) -> Option<f64> {
    if !(elapsed.is_finite() && fraction.is_finite()) || fraction < MIN_FRACTION_FOR_ESTIMATE || elapsed < 0.0 {
        return None;
    }
    Some(elapsed * (1.0 - fraction.min(1.0)) / fraction)
}

/// Where a running job is.
#[derive(Clone, Debug, Serialize, ToSchema)]
pub struct JobProgress {
    /// 0–1: paths traced of those planned (a render), steps begun of the
    /// study's steps (a study).
    pub fraction: f64,
    /// What it is doing, in words (a study's step).
    pub message: Option<String>,
    /// POSIX seconds: when this phase of the job started (its first
    /// progress report; a study that measured first restarts the clock
    /// when it starts rendering).
    pub phase_started_at: f64,
    /// POSIX seconds of the newest report.
    pub updated_at: f64,
}

impl JobProgress {
    /// The extrapolated seconds left at `now` (POSIX seconds); see [`seconds_left`].
    pub fn seconds_left_at(&self, now: f64) -> Option<f64> {
        let at_report = seconds_left(self.updated_at - self.phase_started_at, self.fraction)?;
        Some((at_report - (now - self.updated_at)).max(0.0))
    }
}

/// The newest progress of every running render and study.
#[derive(Default)]
pub struct ProgressBoard {
    entries: Mutex<HashMap<(Job, i64), JobProgress>>,
}

impl ProgressBoard {
    /// A board that follows `events` until the bus closes.
    pub fn follow(events: &broadcast::Sender<Event>) -> Arc<ProgressBoard> {
        let board = Arc::new(ProgressBoard::default());
        let mut rx = events.subscribe();
        let weak = Arc::downgrade(&board);
        tokio::spawn(async move {
            loop {
                match rx.recv().await {
                    Ok(event) => match weak.upgrade() {
                        Some(board) => board.record(&event, crate::store::now()),
                        None => return,
                    },
                    // A lagging board misses reports; the next one sets it right.
                    Err(broadcast::error::RecvError::Lagged(_)) => continue,
                    Err(broadcast::error::RecvError::Closed) => return,
                }
            }
        });
        board
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<(Job, i64), JobProgress>> {
        self.entries.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The newest progress of a running render or study.
    pub fn get(&self, job: Job, id: i64) -> Option<JobProgress> {
        self.lock().get(&(job, id)).cloned()
    }

    /// Takes one event at `now` (POSIX seconds).
    pub fn record(&self, event: &Event, now: f64) {
        let (key, fraction, message) = match event {
            Event::RenderProgress { render_id, done, total } if *total > 0 => {
                ((Job::Render, *render_id), Some(*done as f64 / *total as f64), None)
            }
            Event::StudyProgress {
                study_id,
                message,
                fraction,
            } => ((Job::Study, *study_id), *fraction, Some(message.clone())),
            Event::RenderFinished { render_id, .. } => {
                self.lock().remove(&(Job::Render, *render_id));
                return;
            }
            Event::StudyFinished { study_id, .. } => {
                self.lock().remove(&(Job::Study, *study_id));
                return;
            }
            _ => return,
        };
        let mut entries = self.lock();
        let previous = entries.get(&key);
        // A report without a fraction (a study measuring first) starts no
        // clock; the first one with a fraction does.
        let new_phase = match (previous, fraction) {
            (None, _) => true,
            (Some(p), Some(f)) => f < p.fraction || (p.fraction < 0.0),
            (Some(_), None) => false,
        };
        let phase_started_at = if new_phase {
            now
        } else {
            previous.map(|p| p.phase_started_at).unwrap_or(now)
        };
        let entry = JobProgress {
            fraction: fraction.map(|f| f.clamp(0.0, 1.0)).unwrap_or(-1.0),
            message: message.or_else(|| previous.and_then(|p| p.message.clone())),
            phase_started_at,
            updated_at: now,
        };
        entries.insert(key, entry);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn render_progress(done: u64, total: u64) -> Event {
        Event::RenderProgress {
            render_id: 7,
            done,
            total,
        }
    }

    #[test]
    fn a_render_half_done_after_ten_seconds_has_ten_to_go() {
        let board = ProgressBoard::default();
        board.record(&render_progress(0, 100), 1000.0);
        board.record(&render_progress(50, 100), 1010.0);
        let p = board.get(Job::Render, 7).unwrap();
        assert_eq!(p.fraction, 0.5);
        assert_eq!(p.seconds_left_at(1010.0), Some(10.0));
        // Four seconds after the report, six are left.
        assert_eq!(p.seconds_left_at(1014.0), Some(6.0));
        // Never negative, however late the next report is.
        assert_eq!(p.seconds_left_at(1100.0), Some(0.0));
    }

    #[test]
    fn a_finished_job_leaves_the_board() {
        let board = ProgressBoard::default();
        board.record(&render_progress(10, 100), 1.0);
        board.record(
            &Event::RenderFinished {
                render_id: 7,
                scene: "white".into(),
                ok: true,
                error: None,
            },
            2.0,
        );
        assert!(board.get(Job::Render, 7).is_none());
    }

    #[test]
    fn a_study_restarts_its_clock_when_it_starts_rendering() {
        let board = ProgressBoard::default();
        let study = |message: &str, fraction: Option<f64>| Event::StudyProgress {
            study_id: 3,
            message: message.into(),
            fraction,
        };
        board.record(&study("measuring the 5 missing targets first", None), 100.0);
        let p = board.get(Job::Study, 3).unwrap();
        assert_eq!(p.seconds_left_at(100.0), None, "no fraction, no estimate");
        board.record(&study("white: truth", Some(0.0)), 400.0);
        board.record(&study("white: seed 1 of 2", Some(0.25)), 420.0);
        let p = board.get(Job::Study, 3).unwrap();
        assert_eq!(
            p.phase_started_at, 400.0,
            "the measuring phase is not counted as rendering time"
        );
        assert_eq!(p.seconds_left_at(420.0), Some(60.0));
        assert_eq!(p.message.as_deref(), Some("white: seed 1 of 2"));
    }

    #[test]
    fn no_estimate_from_nothing_done_or_from_numbers_that_are_not_finite() {
        assert_eq!(seconds_left(10.0, 0.0), None);
        assert_eq!(seconds_left(f64::NAN, 0.5), None);
        assert_eq!(seconds_left(10.0, f64::INFINITY), None);
        assert_eq!(seconds_left(-1.0, 0.5), None);
        assert_eq!(seconds_left(10.0, 1.0), Some(0.0));
    }
}
