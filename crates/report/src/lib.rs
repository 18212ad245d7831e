//! lightbooth's pictures and files of its results, pure functions of them
//! (data in, SVG text or file bytes out), used alike by the API, the
//! command line and the study's report:
//!
//! - [`charts`]: the study's charts as SVG (chromaticity diagrams,
//!   profiles, bars, scatter against cost, spectra, psychometric functions,
//!   false-colour maps), one visual language for every page and report;
//! - [`export`]: MATLAB Level 5 MAT-files, and camera images as OpenEXR,
//!   ENVI and MAT (with the OpenEXR reader the tests use).
//!
//! Layer 2 (see `lightbooth`'s `lib.rs`): it uses the science and the
//! renderer's camera image; it knows nothing of the store or the lab, which
//! choose the data.

pub mod charts;
pub mod export;
