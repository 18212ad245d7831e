//! lightbooth: checks, in the lab, that a rendered stimulus matches the real
//! scene.
//!
//! It drives a PR-650 spectroradiometer in a lighting booth, keeps every
//! spectrum, renders the same scene in every colour coding (RGB, sRGB, N-step
//! spectral) and reports how far each rendering is from the measurement, and
//! at what cost in time. The study it automates is Ruppertsberg & Bloj (2006),
//! "Rendering complex scenes for psychophysics using RADIANCE: How accurate
//! can you get?", JOSA A 23(3).
//!
//! Where things live:
//!
//! - [`spectrum`]: spectra with their grid and unit; CSV in and out.
//! - [`reference_data`]: CIE matching functions, illuminants and reflectance
//!   sets compiled into the binary.
//! - [`colorimetry`]: XYZ, chromaticity, CIELAB, ΔE*ab, CIEDE2000, RGB spaces.
//! - [`nstep`]: the N-step spectral approximation and its error analysis.
//! - [`instrument`]: the PR-650 (protocol, serial transport, driver) and its simulator.
//! - [`render`]: the built-in spectral renderer, every colour coding in one pass.
//! - [`display`]: a display profile measured with the PR-650, and stimulus conversion.
//! - [`calibration`]: reflectances and lamp spectra measured in the booth
//!   against a white standard.

pub mod calibration;
pub mod charts;
pub mod colorimetry;
pub mod comparison;
pub mod daemon;
pub mod display;
pub mod export;
pub mod http;
pub mod instrument;
pub mod lab;
pub mod nstep;
pub mod reference_data;
pub mod render;
pub mod spectrum;
pub mod store;
pub mod study;
pub mod worker;
