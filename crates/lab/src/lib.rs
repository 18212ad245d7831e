//! The lab's workflows, below the daemon and the HTTP layer and knowing
//! neither: what happens between a request ("measure this target", "render
//! this scene in these codings", "run the study") and the rows in the store.
//!
//! A layer of the workspace above `lightbooth-store`, `lightbooth-report`,
//! `lightbooth-instrument`, `lightbooth-render` and `lightbooth-science`;
//! Cargo refuses a build where it would name the daemon, the HTTP layer or
//! the command line. `lightbooth` re-exports it as `lightbooth::lab`.
//!
//! - [`charts`], [`export`]: `lightbooth-report`'s charts (SVG) and files
//!   (MAT, EXR, ENVI), re-exported here as the lab's workflows use them:
//!   the lab chooses what a chart shows, the report crate draws it;
//! - [`assemble`]: **where the lab's object graph is built**, the daemon's
//!   ([`DaemonLab::start`](assemble::DaemonLab::start)) and a render
//!   worker's ([`RenderSide`](assemble::RenderSide)), and stopped in order;
//! - [`handle`]: **the HTTP layer's one way to the lab**, the [`Lab`]
//!   handle (the instrument, the renders, the experiments and every record);
//! - [`events`]: every [`Event`](events::Event) on one bus, for `/api/events`
//!   and the dashboards;
//! - [`booth_instrument`]: **where a measurement is asked for**
//!   ([`BoothInstrument::request`](booth_instrument::BoothInstrument::request):
//!   checked, recorded, queued), cancelled, and where the calibration
//!   takes its hold; the HTTP layer's one way to the instrument;
//! - [`measurement`]: **where a measurement is taken**
//!   ([`Recorder::take`](measurement::Recorder::take): each raw sample
//!   stored before the next, the average, the end classified), used by the
//!   daemon's instrument task and by `lightbooth study --measure-simulated`;
//! - [`instrument_task`]: **the one task that owns the instrument** (a
//!   thread of its own): takes the queue's measurements one at a time
//!   through the recorder, publishes each sample as an event, aims the
//!   simulator, reopens a lost port, restarts after a panic, and hands each
//!   complete measurement to the comparisons;
//! - [`instrument_queue`]: the queue of measurements the instrument task
//!   takes, its live status, and the handles it lends out;
//! - [`computed`]: the heavy results the pages poll (an experiment's
//!   analysis, a scene's comparison summary, the scenes' overview) and the
//!   bodies made from them, computed once per version of what they read,
//!   off the async runtime, a bounded number at a time;
//! - [`database_watch`]: does the database answer, one ping at a time
//!   however many ask (`/api/health`);
//! - [`scene_overview`]: every scene at a glance (targets measured, its
//!   thumbnail's render, each coding's mean ΔE00 and rms_rel);
//! - [`scenes`]: the scene catalogue, every scene loaded once at start;
//! - [`render_runner`]: one recorded render run (settings checked, bundle
//!   stored, rendered on the rayon pool, each coding's cost);
//! - [`comparisons`]: **where a measurement's comparison with every coding
//!   is computed** (the render, the booth's CIELAB white, the rows, the
//!   whites kept current) and a scene's comparisons summarised per coding;
//! - [`render_jobs`]: the daemon's renders, studies and camera images as
//!   the API asks for them;
//! - [`study`]: the study itself (every coding against measurements or a
//!   reference, sweeps, failure maps, the automatic choice of settings,
//!   the report);
//! - [`experiments`]: the study's oddity experiment: set up from a
//!   measurement and checked on its display, observers' sessions trial by
//!   trial, and the analysis (percent correct, d′);
//! - [`study_jobs`]: a study planned from a request and run as a job;
//! - [`simulated_truth`]: what the simulated PR-650 measures;
//! - [`jobs`], [`images`], [`worker_queue`], [`study_measurements`]: the
//!   bounded job queue, camera images, the hand-off to render workers, and
//!   a study's wait for the measurements it asked for;
//! - [`progress`]: how far each running render and study has got, and the
//!   time it extrapolates to still need;
//! - [`queue`]: every job of the booth waiting or under way, with its
//!   progress and time left, for the dashboard's home page;
//! - [`requests`]: the requests those workflows take;
//! - [`error`]: [`LabError`](error::LabError), the kinds of refusal a caller
//!   can act on, mapped to HTTP statuses only in `http::error`.
//!
//! The rule (see `lightbooth`'s `lib.rs`): the lab uses the store, the
//! renderer, the instruments and the science below them; nothing here names
//! axum or the HTTP layer.

pub mod assemble;
pub mod booth_instrument;
pub mod calibration;
pub use lightbooth_report::charts;
pub mod comparisons;
pub mod computed;
pub mod database_watch;
pub mod display_profiles;
pub mod download;
pub mod error;
pub mod events;
pub mod experiments;
pub use lightbooth_report::export;
pub mod handle;
pub mod images;
pub mod instrument_queue;
pub mod instrument_scan;
pub mod instrument_task;
pub mod jobs;
pub mod lease;
pub mod measurement;
pub mod measurement_files;
pub mod progress;
pub mod queue;
pub mod render_jobs;
pub mod render_runner;
pub mod requests;
pub mod scene_overview;
pub mod scenes;
pub mod simulated_truth;
pub mod study;
pub mod study_jobs;
pub mod study_measurements;
#[cfg(test)]
mod testing;
pub mod worker_queue;

pub use download::{Download, FileFormat};
pub use handle::{AnalysisFile, Lab, MeasuredColorimetry};
