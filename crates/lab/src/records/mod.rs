//! **Records**: what the lab keeps beside its measurements and renders —
//! the calibration records (reflectances and illuminants measured against
//! a white standard) and the display profiles fitted from stored patches.
//!
//! - [`calibration`]: a measured reflectance or illuminant from stored
//!   measurements, with its provenance;
//! - [`display_profiles`]: a display's profile fitted from the stored
//!   measurements of its patches;
//! - [`stimulus_sets`]: a rendered image's codings converted through a
//!   display profile, stored as what the display will be asked to show;
//! - [`image_verification`]: a set's coding measured on the display at the
//!   scene's targets projected into it.

pub mod calibration;
pub mod display_profiles;
pub mod image_verification;
pub mod stimulus_sets;
