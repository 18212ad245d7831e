//! The study: how accurate each colour coding is, what it costs, where it
//! fails, and the cheapest settings that meet a tolerance — for the booth
//! scenes of Ruppertsberg & Bloj (2006) and for any scene a lab brings.
//!
//! - [`run`]: a study run — every coding against measurements or a converged
//!   reference, spread over seeds, settings sweeps for speed against accuracy.
//! - [`report`]: the study's charts and the self-contained HTML/CSV report.
//! - [`measure`]: measurements of every target with the simulated PR-650.
//! - [`failure_map`]: where each coding crosses ΔE = 2 and rms_rel = 5 %.
//! - [`auto`]: the cheapest settings that meet a tolerance, and why.
//! - [`jobs`]: a study planned from a request and run as the daemon's job
//!   (or a render worker's), or now for the command line, and its end
//!   recorded.
//! - [`awaited`]: a study's wait for the measurements it asked for.
//!
//! The CIELAB white each scene declares, and a stored measurement's XYZ,
//! are [`crate::compare::white`]'s: the same for the study and the
//! daemon's comparisons.

pub mod auto;
pub mod awaited;
pub mod failure_map;
pub mod jobs;
pub mod measure;
pub mod report;
pub mod run;
