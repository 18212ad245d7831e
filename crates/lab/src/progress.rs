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
//! sweeps) are weighed by their scene's targets
//! (`study::run::progress_fractions`), so its estimate is rougher than a
//! render's, whose fraction is paths traced over paths planned.
//!
//! A render has steps ([`RENDER_STEPS`]): tracing its paths, then timing
//! each coding alone, then its camera preview. Each step is its own phase,
//! and a render's estimate is that of its step, which it names. A phase
//! whose work is all done while the job still runs has no estimate (a
//! render at 100 % of its paths said "about 0 s" for the minute its codings
//! were timed), nor has a step with no count.
//!
//! ```
//! use lightbooth_lab::progress::seconds_left;
//! // A quarter done after 30 s: about 90 s to go.
//! assert_eq!(seconds_left(30.0, 0.25), Some(90.0));
//! // Too little done to extrapolate from.
//! assert_eq!(seconds_left(1.0, 0.001), None);
//! ```

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use serde::Serialize;
use tokio::sync::broadcast;

use super::events::{Event, EventSink};
use lightbooth_store::Job;

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

/// The most seconds a camera image still needs after the pass it reported
/// in `p`, under its `time_budget_s`, and how that bound was made; `None`
/// with the reason when there is no honest bound. An image stops when every
/// pixel reaches its noise target or its path cap, or at the first pass
/// that ends after its time budget; so it needs at most the paths still
/// allowed at its pace so far, and at most the budget left plus one more
/// pass (the pass started before the budget ran out ends after it). Spent
/// budget: no new pass starts, nothing is left to extrapolate (the viewer
/// said "at most about 0 s left" at 0 of 6 912 pixels).
///
/// ```
/// use lightbooth_lab::progress::image_time_left;
/// use lightbooth_render::camera::CameraProgress;
/// let first_pass = CameraProgress { pass: 1, pixels_done: 0, pixels: 6912, paths: 6912 * 4, max_paths: 6912 * 64, elapsed_seconds: 8.0 };
/// // 4 of 64 paths per pixel in 8 s: at most 120 s more at that pace, within a 60 s budget (+ a pass of 8 s).
/// assert_eq!(image_time_left(&first_pass, 60.0).0, Some(60.0));
/// let late = CameraProgress { elapsed_seconds: 61.0, ..first_pass };
/// assert_eq!(image_time_left(&late, 60.0).0, None);
/// ```
pub fn image_time_left(p: &lightbooth_render::camera::CameraProgress, time_budget_s: f64) -> (Option<f64>, String) {
    if p.pixels > 0 && p.pixels_done >= p.pixels {
        return (None, "every pixel is done: the image is being stored".into());
    }
    if p.elapsed_seconds >= time_budget_s {
        return (
            None,
            format!("its time budget ({time_budget_s} s) is spent: it stops after this pass, no more passes start"),
        );
    }
    let fraction = p.paths as f64 / p.max_paths.max(1) as f64;
    let Some(by_cap) = seconds_left(p.elapsed_seconds, fraction) else {
        return (None, "no estimate yet: too few paths traced to extrapolate from".into());
    };
    let pass = p.elapsed_seconds / f64::from(p.pass.max(1));
    let by_budget = time_budget_s - p.elapsed_seconds + pass;
    if by_cap <= by_budget {
        (
            Some(by_cap),
            "at most: time so far × paths still allowed / paths traced (earlier once every pixel reaches its noise target)"
                .into(),
        )
    } else {
        (
            Some(by_budget),
            format!("at most: the time budget ({time_budget_s} s) left, plus one pass at the passes' pace so far"),
        )
    }
}

/// A render's steps in order, as its progress reports name them, with the
/// unit each counts in.
pub const RENDER_STEPS: [(&str, &str); 3] = [
    ("tracing paths", "paths"),
    ("timing each coding alone", "timing renders"),
    ("camera preview", ""),
];

/// Where a running job is.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct JobProgress {
    /// 0–1: paths traced of those planned (a render), the work before the
    /// step begun of the study's, steps weighed by their scene's targets (a
    /// study); -1 when the step has no count.
    pub fraction: f64,
    /// What it is doing, in words (a study's or a render's step).
    pub message: Option<String>,
    /// POSIX seconds of the job's first progress report (none is reset by
    /// a new phase).
    pub started_at: f64,
    /// POSIX seconds: when this phase of the job started (its first
    /// progress report; a study that measured first restarts the clock
    /// when it starts rendering).
    pub phase_started_at: f64,
    /// POSIX seconds of the newest report.
    pub updated_at: f64,
}

impl JobProgress {
    /// The extrapolated seconds left at `now` (POSIX seconds); see
    /// [`seconds_left`]. None when the phase's work is all done (the job is
    /// finishing something not counted) or not counted at all, and None
    /// once the time the newest report extrapolated has run out with the
    /// job still there: its current step is slower than the ones before it
    /// and the pace so far says nothing of the rest (a study said "about
    /// 0 s" at 14 s of a 31 s run, its four one-target scenes done and the
    /// 21-target CYLINDER under way); "estimating…" is the honest answer.
    pub fn seconds_left_at(&self, now: f64) -> Option<f64> {
        if self.fraction >= 1.0 {
            return None;
        }
        let at_report = seconds_left(self.updated_at - self.phase_started_at, self.fraction)?;
        let left = at_report - (now - self.updated_at);
        (left > 0.0).then_some(left)
    }
}

/// The newest progress of every running render and study.
#[derive(Default)]
pub struct ProgressBoard {
    entries: Mutex<HashMap<(Job, i64), JobProgress>>,
}

impl ProgressBoard {
    /// A board that follows `events` until the bus closes (a sink that
    /// sends nowhere leaves it empty).
    pub fn follow(events: &EventSink) -> Arc<ProgressBoard> {
        let board = Arc::new(ProgressBoard::default());
        let Some(mut rx) = events.subscribe() else {
            return board;
        };
        let weak = Arc::downgrade(&board);
        tokio::spawn(async move {
            loop {
                match rx.recv().await {
                    Ok(event) => match weak.upgrade() {
                        Some(board) => board.record(&event, lightbooth_store::now()),
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
            Event::RenderProgress {
                render_id,
                done,
                total,
                step,
            } => (
                (Job::Render, *render_id),
                (*total > 0).then(|| *done as f64 / *total as f64),
                Some(step.clone()),
            ),
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
        // A render's next step is a new phase too.
        let next_step = key.0 == Job::Render && previous.is_some_and(|p| p.message != message);
        let new_phase = match (previous, fraction) {
            (None, _) => true,
            (Some(p), Some(f)) => f < p.fraction || (p.fraction < 0.0) || next_step,
            (Some(_), None) => next_step,
        };
        let phase_started_at = if new_phase {
            now
        } else {
            previous.map(|p| p.phase_started_at).unwrap_or(now)
        };
        let entry = JobProgress {
            fraction: fraction.map(|f| f.clamp(0.0, 1.0)).unwrap_or(-1.0),
            message: message.or_else(|| previous.and_then(|p| p.message.clone())),
            started_at: previous.map(|p| p.started_at).unwrap_or(now),
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
        render_step(RENDER_STEPS[0].0, done, total)
    }

    fn render_step(step: &str, done: u64, total: u64) -> Event {
        Event::RenderProgress {
            render_id: 7,
            done,
            total,
            step: step.into(),
        }
    }

    /// Red and green renders sat at "100 % of paths, about 0 s" for over a
    /// minute while they timed each coding alone: a render whose paths are
    /// all traced gives no estimate until its next step reports, that step
    /// starts its own clock and says which it is, and a step with no count
    /// (the camera preview) gives none either.
    #[test]
    fn a_render_at_every_path_but_still_running_does_not_say_about_0_s() {
        let board = ProgressBoard::default();
        board.record(&render_progress(0, 100), 1000.0);
        board.record(&render_progress(100, 100), 1010.0);
        let p = board.get(Job::Render, 7).unwrap();
        assert_eq!(p.fraction, 1.0);
        assert_eq!(
            p.seconds_left_at(1010.0),
            None,
            "all paths traced, the render not finished"
        );
        assert_eq!(p.seconds_left_at(1070.0), None);
        // Timing the codings: its own clock from its first report.
        board.record(&render_step(RENDER_STEPS[1].0, 0, 28), 1011.0);
        board.record(&render_step(RENDER_STEPS[1].0, 7, 28), 1021.0);
        let p = board.get(Job::Render, 7).unwrap();
        assert_eq!(p.message.as_deref(), Some("timing each coding alone"));
        assert_eq!(p.phase_started_at, 1011.0);
        assert_eq!(p.started_at, 1000.0, "the render started at its first report");
        assert_eq!(p.seconds_left_at(1021.0), Some(30.0));
        // The preview: no count, no estimate.
        board.record(&render_step(RENDER_STEPS[2].0, 0, 0), 1050.0);
        let p = board.get(Job::Render, 7).unwrap();
        assert_eq!(p.message.as_deref(), Some("camera preview"));
        assert_eq!(p.seconds_left_at(1050.0), None);
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
        // Never negative, nor "about 0 s", however late the next report is: no estimate.
        assert_eq!(p.seconds_left_at(1100.0), None);
    }

    /// The Viewer said "at most about 0 s left" at 0 of 6 912 pixels: the
    /// first pass had outlasted the time budget, and the budget left (0)
    /// was taken as the time left. Spent budget: no number; before it, the
    /// bound keeps the pass that ends after the budget; never 0 with
    /// pixels still to do.
    #[test]
    fn the_viewer_at_0_pixels_never_says_at_most_about_0_s() {
        use lightbooth_render::camera::CameraProgress;
        let pixels = 6912;
        let first = CameraProgress {
            pass: 1,
            pixels_done: 0,
            pixels,
            paths: pixels * 16,
            max_paths: pixels * 1024,
            elapsed_seconds: 31.0,
        };
        let (left, why) = image_time_left(&first, 30.0);
        assert_eq!(left, None, "{why}");
        assert!(why.contains("time budget (30 s) is spent"), "{why}");
        for elapsed in [0.5, 5.0, 29.9] {
            let p = CameraProgress {
                elapsed_seconds: elapsed,
                ..first
            };
            let (left, why) = image_time_left(&p, 30.0);
            let left = left.unwrap_or_else(|| panic!("{elapsed} s: {why}"));
            assert!(
                left >= elapsed,
                "{elapsed} s into a pass-long image: at most {left} s left ({why})"
            );
            assert!(why.starts_with("at most"), "{why}");
        }
        // Too little done to say.
        let barely = CameraProgress {
            paths: 10,
            elapsed_seconds: 1.0,
            ..first
        };
        assert_eq!(image_time_left(&barely, 30.0).0, None);
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

    /// A study of WHITE, RED, GREEN, BLUE and CYLINDER said "about 0 s"
    /// left at 14 s of a 31 s run: its steps are counted as equal, the
    /// four one-target scenes went by in 4 s, and CYLINDER's 21 targets
    /// then took 25 s. Once the time extrapolated at the newest report has
    /// run out, there is no estimate (the page says "estimating…").
    #[test]
    fn a_study_said_about_0_s_left_at_14_s_of_a_31_s_run() {
        let board = ProgressBoard::default();
        let study = |message: &str, fraction: f64| Event::StudyProgress {
            study_id: 5,
            message: message.into(),
            fraction: Some(fraction),
        };
        for (k, scene) in ["white", "red", "green", "blue"].into_iter().enumerate() {
            board.record(&study(&format!("{scene}: truth"), 0.2 * k as f64), 100.0 + k as f64);
            board.record(
                &study(&format!("{scene}: seed 1 of 1"), 0.2 * k as f64 + 0.1),
                100.5 + k as f64,
            );
        }
        board.record(&study("cylinder: truth", 0.8), 104.0);
        let p = board.get(Job::Study, 5).unwrap();
        let near = |left: Option<f64>, want: f64| left.is_some_and(|s| (s - want).abs() < 1e-9);
        assert!(
            near(p.seconds_left_at(104.0), 1.0),
            "4 s for 80 %: 1 s more at that pace"
        );
        assert!(near(p.seconds_left_at(104.5), 0.5));
        assert_eq!(p.seconds_left_at(114.0), None, "at 14 s: not \"about 0 s\"");
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
