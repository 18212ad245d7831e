//! The study's display question: at which frame-buffer depth does a display
//! show two colour codings' renderings of the same scene as different?
//!
//! For each coding pair (a, b) and bit depth, every colour (a target) is
//! converted in both codings ([`super::stimulus::convert`], one gamut
//! policy applied to both codings' colours together, so a `scale` factor is
//! common to them) and compared:
//! - `true ΔE00`: between the two renderings as rendered (unquantised, no gamut policy);
//! - `intended ΔE00`: between the two after the gamut policy, unquantised:
//!   what a display of unlimited depth would show (the `scale` policy
//!   darkens both, which changes ΔE00; quantisation is measured against this);
//! - `shown ΔE00`: between what the display shows for each after quantisation;
//! - a colour is **resolved** when at least one code differs between the
//!   codings *and* the shown ΔE00 is at least [`RESOLVED_FRACTION`] of the
//!   intended ΔE00 — the display shows a difference of the size it could
//!   show, not a one-code flip of a much larger one. A colour whose intended
//!   ΔE00 is below [`NEGLIGIBLE_DE00`] has nothing to resolve and is counted
//!   as such, not as unresolved.
//!
//! All ΔE00 relative to the display's white (see [`super::stimulus`]).

use serde::Serialize;

use super::profile::{DisplayProfile, FrameBuffer, TransferModel};
use super::stimulus::{convert, delta_e00, GamutPolicy};
use super::{Converter, DisplayError};

/// Shown ΔE00 must be at least this fraction of the true ΔE00 for "resolved".
pub const RESOLVED_FRACTION: f64 = 0.5;
/// True ΔE00 below this: the codings agree; nothing to resolve.
pub const NEGLIGIBLE_DE00: f64 = 1e-3;

/// One coding pair at one bit depth.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PairAtDepth {
    pub bits: u32,
    pub colours: usize,
    /// Colours whose codes differ in at least one channel.
    pub codes_differ: usize,
    pub resolved: usize,
    /// Colours with a true difference to resolve (true ΔE00 ≥ [`NEGLIGIBLE_DE00`]).
    pub to_resolve: usize,
    pub unresolved: usize,
    pub mean_shown_delta_e00: f64,
    pub max_shown_delta_e00: f64,
    pub mean_true_delta_e00: f64,
    /// Mean ΔE00 after the gamut policy, unquantised (see the module doc).
    pub mean_intended_delta_e00: f64,
    /// Per colour: shown ΔE00.
    pub shown_delta_e00: Vec<f64>,
}

/// One coding pair over the bit depths.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PairResolution {
    pub a: String,
    pub b: String,
    /// Per colour: true ΔE00 between the codings' renderings.
    pub true_delta_e00: Vec<f64>,
    pub depths: Vec<PairAtDepth>,
    /// The smallest depth at which every colour with a difference is resolved.
    pub resolves_at_bits: Option<u32>,
}

/// Compares the colours `a` and `b` (the same colours rendered in two
/// codings, XYZ cd/m² in the profile's observer) at each depth.
pub fn resolve_pair(
    profile: &DisplayProfile,
    names: (&str, &str),
    a: &[[f64; 3]],
    b: &[[f64; 3]],
    bits: &[u32],
    policy: GamutPolicy,
    model: TransferModel,
) -> Result<PairResolution, DisplayError> {
    if a.len() != b.len() {
        return Err(DisplayError::Profile(format!(
            "{} has {} colours and {} has {}",
            names.0,
            a.len(),
            names.1,
            b.len()
        )));
    }
    let white = Converter::new(profile)?.white();
    let n = a.len();
    let true_de: Vec<f64> = a.iter().zip(b).map(|(p, q)| delta_e00(white, *p, *q)).collect();
    let both: Vec<[f64; 3]> = a.iter().chain(b).copied().collect();
    let mut depths = Vec::new();
    for &bit in bits {
        // Any depth 1–16 (6-bit panels are common), not only the stimulus files' 8/10/12/16.
        if !(1..=16).contains(&bit) {
            return Err(DisplayError::Bits(bit));
        }
        let fb = FrameBuffer { bits: bit };
        let s = convert(profile, &both, fb, policy, model)?;
        let mut row = PairAtDepth {
            bits: bit,
            colours: n,
            codes_differ: 0,
            resolved: 0,
            to_resolve: 0,
            unresolved: 0,
            mean_shown_delta_e00: 0.0,
            max_shown_delta_e00: 0.0,
            mean_true_delta_e00: true_de.iter().sum::<f64>() / n.max(1) as f64,
            mean_intended_delta_e00: 0.0,
            shown_delta_e00: Vec::with_capacity(n),
        };
        let mut intended_sum = 0.0;
        for i in 0..n {
            let differ = s.codes[i] != s.codes[n + i];
            let shown = delta_e00(white, s.shown[i], s.shown[n + i]);
            let intended = delta_e00(white, s.intended[i], s.intended[n + i]);
            intended_sum += intended;
            row.codes_differ += usize::from(differ);
            if intended >= NEGLIGIBLE_DE00 {
                row.to_resolve += 1;
                if differ && shown >= RESOLVED_FRACTION * intended {
                    row.resolved += 1;
                } else {
                    row.unresolved += 1;
                }
            }
            row.max_shown_delta_e00 = row.max_shown_delta_e00.max(shown);
            row.shown_delta_e00.push(shown);
        }
        row.mean_shown_delta_e00 = row.shown_delta_e00.iter().sum::<f64>() / n.max(1) as f64;
        row.mean_intended_delta_e00 = intended_sum / n.max(1) as f64;
        depths.push(row);
    }
    let resolves_at_bits = depths.iter().find(|d| d.unresolved == 0).map(|d| d.bits);
    Ok(PairResolution {
        a: names.0.to_string(),
        b: names.1.to_string(),
        true_delta_e00: true_de,
        depths,
        resolves_at_bits,
    })
}
