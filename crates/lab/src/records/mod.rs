//! **Records**: what the lab keeps beside its measurements and renders —
//! the calibration records (reflectances and illuminants measured against
//! a white standard) and the display profiles fitted from stored patches.
//!
//! - [`calibration`]: a measured reflectance or illuminant from stored
//!   measurements, with its provenance;
//! - [`display_profiles`]: a display's profile fitted from the stored
//!   measurements of its patches.

pub mod calibration;
pub mod display_profiles;
