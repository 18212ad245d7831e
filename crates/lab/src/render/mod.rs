//! **Render**: the scene rendered in every coding in one pass, as the API,
//! a comparison or a render worker asks.
//!
//! - [`jobs`]: the daemon's renders, studies and camera images as the API
//!   asks for them: one bounded queue and one worker, or the hand-off to
//!   render workers;
//! - [`runner`]: one recorded render run (settings checked, bundle
//!   stored, rendered on the rayon pool, each coding's cost);
//! - [`images`]: camera images (rendered, kept, probed, exported);
//! - [`image_batches`]: camera images on render workers (batches of
//!   paths, merged);
//! - [`image_views`]: what the image viewer reads from one (the display
//!   PNG, a pixel probe and its chart, the ΔE map as a PNG);
//! - [`worker_queue`]: the hand-off of renders and studies to render
//!   workers through the database.
//!
//! Invariant: CPU work runs on the rayon pool or a blocking thread, never
//! on the async workers, and every job is cancellable by its token.

pub mod image_batches;
pub mod image_views;
pub mod images;
pub mod jobs;
pub mod runner;
pub mod worker_queue;
