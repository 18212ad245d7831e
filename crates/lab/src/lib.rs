//! The lab's workflows, below the daemon and the HTTP layer and knowing
//! neither: what happens between a request ("measure this target", "render
//! this scene in these codings", "run the study") and the rows in the store.
//!
//! A layer of the workspace above `lightbooth-store`, `lightbooth-report`,
//! `lightbooth-instrument`, `lightbooth-render` and `lightbooth-science`;
//! Cargo refuses a build where it would name the daemon, the HTTP layer or
//! the command line. `lightbooth` re-exports it as `lightbooth::lab`.
//!
//! Its folders are the lab's workflows; start at [`handle`] (what the API
//! can ask) or [`assemble`] (how the daemon's lab is put together):
//!
//! - [`measure`]: **a target measured** — asked for, queued, taken by the
//!   one task that owns the instrument (each raw sample stored before the
//!   next), its files; the instrument scan;
//! - [`render`]: **a scene rendered** in every coding — the daemon's render,
//!   study and camera-image jobs, one recorded run, the hand-off to render
//!   workers;
//! - [`compare`]: **a measurement compared** with every coding — the rows,
//!   the booth's CIELAB white, a scene's summary per coding, its charts and
//!   files, the scenes' overview;
//! - [`study`]: **the study** — every coding against measurements or a
//!   reference, sweeps, failure maps, the automatic choice of settings, the
//!   report, and the study as a job;
//! - [`experiments`]: **the oddity experiment** — set up from a measurement
//!   and checked on its display, observers' sessions trial by trial, the
//!   analysis (percent correct, d′, thresholds) and its files;
//! - [`records`]: the calibration records (reflectances, illuminants) and
//!   the display profiles fitted from stored patches;
//!
//! and what every workflow shares:
//!
//! - [`assemble`]: **where the lab's object graph is built**, the daemon's
//!   ([`DaemonLab::start`](assemble::DaemonLab::start)) and a render
//!   worker's ([`RenderSide`](assemble::RenderSide)), and stopped in order;
//! - [`handle`]: **the HTTP layer's one way to the lab**, the [`LabHandle`]
//!   (the instrument, the renders, the experiments and every record);
//! - [`events`]: every [`Event`](events::Event) on one bus
//!   ([`EventSink`](events::EventSink)), for `/api/events` and the
//!   dashboards;
//! - [`computed`]: the heavy results the pages poll (an experiment's
//!   analysis, a scene's comparison summary, the scenes' overview) and the
//!   bodies made from them, computed once per version of what they read,
//!   off the async runtime, a bounded number at a time;
//! - [`download`]: a file made for a caller to save (every export);
//! - [`charts`], [`export`]: `lightbooth-report`'s charts (SVG) and files
//!   (MAT, EXR, ENVI), re-exported here: the lab chooses what a chart
//!   shows, the report crate draws it;
//! - [`database_watch`]: does the database answer, one ping at a time
//!   however many ask (`/api/health`);
//! - [`scenes`]: the scene catalogue, every scene loaded once at start;
//! - [`jobs`], [`queue`], [`progress`]: the bounded job queue, every job of
//!   the booth waiting or under way (the home page's), and how far each has
//!   got;
//! - [`lease`]: a booth's one daemon, by a lease in the database;
//! - [`requests`]: the requests the workflows take;
//! - [`error`]: [`LabError`](error::LabError), the kinds of refusal a caller
//!   can act on, mapped to HTTP statuses only in `http::error`.
//!
//! The rule (see `lightbooth`'s `lib.rs`): the lab uses the store, the
//! renderer, the instruments and the science below them; nothing here names
//! axum or the HTTP layer.

pub mod assemble;
pub use lightbooth_report::charts;
pub mod compare;
pub mod computed;
pub mod database_watch;
pub mod download;
pub mod error;
pub mod events;
pub mod experiments;
pub use lightbooth_report::export;
pub mod handle;
pub mod jobs;
pub mod lease;
pub mod measure;
pub mod progress;
pub mod queue;
pub mod records;
pub mod render;
pub mod requests;
pub mod scenes;
pub mod study;
#[cfg(test)]
mod testing;

pub use download::{Download, FileFormat};
pub use handle::{AnalysisFile, LabHandle, MeasuredColorimetry};
