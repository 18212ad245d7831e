//! The lab's workflows, below the daemon and the HTTP layer and knowing
//! neither: what happens between a request ("measure this target", "render
//! this scene in these codings", "run the study") and the rows in the store.
//!
//! - [`events`]: every [`Event`](events::Event) on one bus, for `/api/events`
//!   and the dashboards;
//! - [`measurement`]: the one recorder of a measurement (create, store each
//!   raw sample before the next is taken, average), used by the daemon's
//!   instrument task and by `lightbooth study --measure-simulated`;
//! - [`instrument_queue`]: the queue of measurements the instrument task
//!   takes, its live status, and the handles it lends out;
//! - [`renders`]: the scene catalogue, the comparison of every measurement
//!   with every coding, and the render, study and image jobs (one type
//!   today, to be split), behind [`services::RenderService`];
//! - [`jobs`], [`images`], [`worker_queue`], [`study_measurements`]: the
//!   bounded job queue, camera images, the hand-off to render workers, and
//!   a study's wait for the measurements it asked for;
//! - [`requests`]: the requests those workflows take;
//! - [`error`]: [`LabError`](error::LabError), the kinds of refusal a caller
//!   can act on, mapped to HTTP statuses only in `http::error`.
//!
//! The rule (see `lib.rs`): `lab` uses `store`, `output`-side modules,
//! `render`, `instrument` and the science below them; nothing here names
//! axum or the HTTP layer.

pub mod calibration;
pub mod error;
pub mod events;
pub mod images;
pub mod instrument_queue;
pub mod jobs;
pub mod lease;
pub mod measurement;
pub mod renders;
pub mod requests;
pub mod services;
pub mod study_measurements;
pub mod worker_queue;
