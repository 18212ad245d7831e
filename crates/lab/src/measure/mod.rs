//! **Measure**: a target asked for, taken by the one task that owns the
//! instrument, each raw sample stored before the next, and handed to the
//! comparisons.
//!
//! - [`booth_instrument`]: **where a measurement is asked for**
//!   ([`BoothInstrument::request`](booth_instrument::BoothInstrument::request):
//!   checked, recorded, queued), cancelled, and where the calibration
//!   takes its hold; the HTTP layer's one way to the instrument;
//! - [`queue`]: the queue of measurements the instrument task takes, its
//!   live status, and the handles it lends out;
//! - [`task`]: **the one task that owns the instrument** (a thread of its
//!   own): takes the queue's measurements one at a time through the
//!   recorder, publishes each sample as an event, aims the simulator,
//!   reopens a lost port, restarts after a panic, and hands each complete
//!   measurement to the comparisons;
//! - [`recorder`]: **where a measurement is taken**
//!   ([`Recorder::take`](recorder::Recorder::take): each raw sample stored
//!   before the next, the average, the end classified), used by the
//!   instrument task and by `lightbooth study --measure-simulated`;
//! - [`scan`]: which serial ports answer as which instrument, one scan at
//!   a time per lab;
//! - [`files`]: a measurement's spectra as CSV, MAT and chart;
//! - [`simulated_truth`]: what the simulated PR-650 measures.
//!
//! Invariant: a sample is stored before the next is asked for, and a
//! measurement is marked complete only with its average.

pub mod booth_instrument;
pub mod files;
pub mod queue;
pub mod recorder;
pub mod scan;
pub mod simulated_truth;
pub mod task;
