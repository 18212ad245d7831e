//! A display measured with a spectroradiometer, a colorimeter or a
//! luminance meter, and rendered colours turned into the frame-buffer values
//! that show them.
//!
//! - [`profile`]: the display profile (each primary at full drive and the
//!   black level, as spectra, XYZ or luminance; each channel's transfer
//!   function) and its
//!   forward (frame buffer → spectrum, XYZ) and inverse (XYZ → linear RGB →
//!   frame buffer at 8–16 bits) models.
//! - [`fit`]: the calibration plan (which colours to show) and the fit of a
//!   profile to what was measured while showing them.
//! - [`simulated`]: the display the simulated PR-650 looks at with `--mock`.
//! - [`stimulus`]: rendered XYZ → gamut policy → frame-buffer codes, what
//!   the display shows for them, and the quantisation bound.
//! - [`output`]: the output methods (8 bit, noisy-bit dithering, 10 bit)
//!   and whether an experiment's colours are distinct with one.
//! - [`stimulus_files`]: the codes and the ΔE00 map as files (PNG, raw).
//! - [`resolution`]: at which bit depth a display shows two codings apart.
//!
//! The display model is the usual one of Brainard, Pelli & Robson (2002),
//! "Display characterization", as Psychtoolbox's `CalibrateMonSpd` fits it:
//!
//! ```text
//! S(λ; r, g, b) = K(λ) + t_R(r)·P_R(λ) + t_G(g)·P_G(λ) + t_B(b)·P_B(λ)
//! ```
//!
//! with K the black level (everything at drive 0), P_c the *increment* of
//! primary c at full drive over black, and t_c the normalised transfer, 0 at
//! drive 0 and 1 at full drive. Stated approximations: channel independence
//! (checked by the additivity test: white against R + G + B) and a primary
//! whose spectral shape does not change with drive (phosphor constancy).

pub mod fit;
pub mod image_set;
pub mod image_verification;
pub mod output;
pub mod profile;
pub mod resolution;
pub mod simulated;
pub mod stimulus;
pub mod stimulus_files;

pub use fit::{fit_profile, CalibrationPlan, MeasuredPatch, PatchLight};
pub use profile::{
    Additivity, ChannelTransfer, Checks, Converter, DisplayProfile, Emission, FrameBuffer, MAX_TRANSFER_RMS_RESIDUAL,
    MAX_VALIDATION_DE00, MAX_VALIDATION_LUMINANCE,
};
pub use simulated::{CodeCounts, SimulatedDisplay};

/// Errors of the display profile and its fit; each names what was wrong.
#[derive(Debug, thiserror::Error)]
pub enum DisplayError {
    /// The measured patches cannot give a profile (a missing black, primary
    /// or ramp; spectra on different grids; …).
    #[error("display calibration: {0}")]
    Calibration(String),
    /// A profile read from a file or the store is not a valid profile.
    #[error("display profile: {0}")]
    Profile(String),
    /// A frame-buffer bit depth other than 8, 10, 12 or 16.
    #[error("bit depth {0}: choose 8, 10, 12 or 16")]
    Bits(u32),
    /// Colours outside the display's gamut under `--gamut fail`.
    #[error("gamut: {0}")]
    Gamut(String),
    #[error(transparent)]
    Color(#[from] crate::colorimetry::ColorError),
    #[error(transparent)]
    Spectrum(#[from] crate::spectrum::SpectrumError),
}
