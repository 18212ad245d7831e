//! lightbooth's science, pure and without I/O: the bottom layer of the
//! workspace. Nothing here knows of instruments, storage, HTTP or an async
//! runtime, and Cargo enforces it: this crate depends on no other crate of
//! lightbooth.
//!
//! - [`spectrum`]: spectra with their grid and unit; CSV in and out.
//! - [`reference_data`]: CIE matching functions, illuminants and reflectance
//!   sets compiled into the binary.
//! - [`colorimetry`]: XYZ, chromaticity, CIELAB, ΔE*ab, CIEDE2000, RGB spaces.
//! - [`nstep`]: the N-step spectral approximation and its error analysis.
//! - [`comparison`]: the figures of merit of a rendering against a
//!   measurement (ΔE, luminance ratio, rms_rel, significance).
//! - [`uncertainty`]: those figures with 95 % coverage intervals by a GUM
//!   Supplement 1 Monte Carlo propagation of the measurement's repeatability
//!   and the instrument's stated accuracy ([`uncertainty::StatedAccuracy`]).
//! - [`calibration`]: reflectances and lamp spectra from measurements
//!   against a white standard.
//! - [`display`]: a display profile, and rendered colours turned into
//!   frame-buffer codes.
//! - [`random`]: seeded random numbers specified to the bit (SplitMix64),
//!   for seeds that are stored.
//! - [`psychophysics`]: whether an observer can tell: percent correct with
//!   its exact interval, and d′ of the study's oddity task under the
//!   differencing and independent-observation models, and each observer's
//!   threshold (σ of d′ = ΔE00/σ) fitted from the trials.
//!
//! The `lightbooth` crate re-exports each module under its own name
//! (`lightbooth_science::colorimetry`, …), so the rest of lightbooth and its users
//! name them as before.

pub mod calibration;
pub mod colorimetry;
pub mod comparison;
pub mod display;
pub mod nstep;
pub mod psychophysics;
pub mod random;
pub mod reference_data;
pub mod spectrum;
pub mod uncertainty;
