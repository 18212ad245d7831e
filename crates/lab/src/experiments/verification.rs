//! Verification: an experiment's colours as the display really emits them,
//! measured with the booth's spectroradiometer before any observer sits
//! down.
//!
//! The session page shows each colour through the same path as a trial
//! (WebGL2, the profile's γ per pixel, the output method's rounding or
//! dithering), full-field and in the pie's geometry, and measures it as a
//! calibration patch is measured (`POST /api/measurements`; with `--mock`
//! the simulated PR-650 looks at the simulated display, which is told the
//! codes the page drew). [`Experiments::verify`] then compares, per colour,
//! three XYZ in the display profile's observer:
//!
//! - **intended**: the colour the experiment asks the display for, after
//!   the gamut policy and before any quantisation;
//! - **predicted**: what the profile says the output method emits (8-bit
//!   or 10-bit codes, or the mean of the dithered codes);
//! - **emitted**: the measurement of the displayed stimulus;
//!
//! and, for the original and every approximation, the **booth**: the real
//! booth measurement the stimulus stands for, on the display (through the
//! same gamut policy and scale factor as the colours).
//!
//! Every ΔE00 is relative to the display's white (CIELAB needs one white;
//! the display's is the one the observer adapts to). A colour fails when
//! ΔE00(intended, emitted) exceeds the tolerance (default 1), and the
//! likely cause is named from the other differences:
//!
//! - **out of gamut**: the colour asked for lies outside the display's
//!   gamut and the policy clipped it;
//! - **quantisation**: ΔE00(intended, predicted) alone is over half the
//!   tolerance: the output method cannot show the colour closer;
//! - **drift since calibration**: the display emits other than its profile
//!   predicts (ΔE00(predicted, emitted) over half the tolerance):
//!   recalibrate;
//!
//! Drift includes the measurement's own noise: a drift near the tolerance
//! with few samples is worth measuring again before recalibrating.
//!
//! Only a measurement of the display showing that colour verifies it
//! (issue 32: the booth's own scene measurement was accepted as the
//! display's emission and the verification passed): a measurement of a
//! scene's target is the booth, not the display, and is refused; so is one
//! taken before the experiment existed (it cannot have been of its
//! colours), and one measurement given for two patches (the display showed
//! one colour at a time). The daemon cannot see a real display, so what
//! the display showed is known from the measurement's provenance: a patch
//! must have been measured under the instrument hold of this experiment's
//! verification ([`hold_purpose`], taken by the session page's “verify the
//! display”; the hold is stored with each measurement taken under it). A
//! measurement taken freely, or under another hold (a calibration, a test
//! patch, another experiment's verification), is refused.

use serde::{Deserialize, Serialize};

use super::{parts, Experiments, StoredColour};
use crate::compare::white::measured_xyz;
use crate::error::LabError;
use lightbooth_science::display::stimulus::{delta_e00, GamutPolicy, GAMUT_TOLERANCE};
use lightbooth_science::display::Converter;
use lightbooth_store::MeasurementState;

/// The tolerance a verification applies unless told otherwise, ΔE00.
pub const DEFAULT_TOLERANCE_DE00: f64 = 1.0;
/// A verification names at most this many measured patches.
pub const MAX_PATCHES: usize = 128;

/// The purpose of the instrument hold a verification's patches are
/// measured under (see the module doc); the session page takes the hold
/// with exactly this purpose.
pub fn hold_purpose(experiment_id: i64) -> String {
    format!("verification of experiment {experiment_id}")
}

/// Where on the screen a colour was shown while it was measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case")]
pub enum Geometry {
    /// The whole screen in the colour.
    FullField,
    /// The pie, all three pieces in the colour, on the background; the
    /// instrument aimed at one piece.
    Pie,
}

impl Geometry {
    pub fn name(self) -> &'static str {
        match self {
            Geometry::FullField => "full field",
            Geometry::Pie => "pie",
        }
    }
}

/// One measured patch, as the page reports it.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct VerifiedPatch {
    /// `original`, an approximation's coding, or `background`.
    pub colour: String,
    pub geometry: Geometry,
    /// The complete measurement of the colour on the display.
    pub measurement_id: i64,
}

/// `POST /api/experiments/{id}/verifications`.
#[derive(Clone, Debug, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct VerificationRequest {
    /// 1–128 patches.
    pub patches: Vec<VerifiedPatch>,
    /// A colour passes when ΔE00(intended, emitted) is at most this (default 1).
    #[serde(default = "default_tolerance")]
    pub tolerance_delta_e00: f64,
    /// How the page showed the colours (browser and output path).
    #[serde(default)]
    pub client: String,
}

fn default_tolerance() -> f64 {
    DEFAULT_TOLERANCE_DE00
}

/// A stored verification.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Verification {
    pub id: i64,
    pub experiment_id: i64,
    /// Unix seconds.
    pub created_at: f64,
    pub tolerance_delta_e00: f64,
    /// Every colour within the tolerance.
    pub passed: bool,
    pub client: String,
    /// The display's white, XYZ cd/m²: the white of every ΔE00 here.
    pub white_xyz: [f64; 3],
    pub observer: String,
    pub colours: Vec<VerifiedColour>,
    /// Plain words, one line per finding.
    pub summary: Vec<String>,
}

/// One colour in one geometry, measured on the display.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct VerifiedColour {
    pub colour: String,
    pub geometry: Geometry,
    pub measurement_id: i64,
    /// The colour asked of the display (gamut policy applied, unquantised), XYZ cd/m².
    pub intended_xyz: [f64; 3],
    /// What the profile predicts the output method emits, XYZ cd/m².
    pub predicted_xyz: [f64; 3],
    /// The measurement of the displayed stimulus, XYZ cd/m².
    pub emitted_xyz: [f64; 3],
    /// ΔE00(intended, emitted): the figure the tolerance applies to.
    pub delta_e00_emitted: f64,
    /// ΔE00(intended, predicted): what the output method's resolution costs.
    pub delta_e00_quantisation: f64,
    /// ΔE00(predicted, emitted): how far the display is from its profile.
    pub delta_e00_drift: f64,
    /// The real booth measurement the stimulus stands for, on the display
    /// (same gamut policy); none for the background.
    pub booth_xyz: Option<[f64; 3]>,
    /// ΔE00(booth, emitted): real scene against displayed stimulus.
    pub delta_e00_booth: Option<f64>,
    pub passed: bool,
    /// Why it failed, in words; none when it passed.
    pub likely_cause: Option<String>,
}

/// The three ΔE00 of one colour and the verdict (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct Assessment {
    pub delta_e00_emitted: f64,
    pub delta_e00_quantisation: f64,
    pub delta_e00_drift: f64,
    pub passed: bool,
    pub likely_cause: Option<String>,
}

/// Compares intended, predicted and emitted XYZ of one colour (relative to
/// `white`) and names the likely cause of a failure; `clipped` says that
/// the colour was outside the gamut and clipped by the policy.
pub fn assess(
    white: lightbooth_science::colorimetry::Xyz,
    intended: [f64; 3],
    predicted: [f64; 3],
    emitted: [f64; 3],
    clipped: bool,
    tolerance: f64,
) -> Assessment {
    let delta_e00_emitted = delta_e00(white, intended, emitted);
    let delta_e00_quantisation = delta_e00(white, intended, predicted);
    let delta_e00_drift = delta_e00(white, predicted, emitted);
    let passed = delta_e00_emitted <= tolerance;
    let likely_cause = (!passed).then(|| {
        let half = tolerance / 2.0;
        let mut causes = Vec::new();
        if clipped {
            causes.push(
                "out of gamut: the colour lies outside the display's gamut and was clipped (use the `scale` gamut policy)"
                    .to_string(),
            );
        }
        if delta_e00_quantisation > half {
            causes.push(format!(
                "quantisation: the output method alone shows it {delta_e00_quantisation:.2} ΔE00 away (use noisy_bit or 10bit)"
            ));
        }
        if delta_e00_drift > half {
            causes.push(format!(
                "drift since calibration: the display emits {delta_e00_drift:.2} ΔE00 from what its profile predicts \
                 (recalibrate the display)"
            ));
        }
        // ΔE00 is near enough a metric that a failure has one part over half
        // the tolerance; this is for the rare colour where it does not.
        if causes.is_empty() {
            causes.push(
                "measurement noise: no single cause exceeds half the tolerance (measure with more samples)".into(),
            );
        }
        causes.join("; ")
    });
    Assessment {
        delta_e00_emitted,
        delta_e00_quantisation,
        delta_e00_drift,
        passed,
        likely_cause,
    }
}

impl Experiments {
    /// Compares the measured patches with the experiment's colours and
    /// stores the verification (see the module doc).
    pub async fn verify(&self, experiment_id: i64, request: &VerificationRequest) -> Result<Verification, LabError> {
        let e = self.get(experiment_id).await?;
        let (experiment, check) = parts(&e)?;
        let n = request.patches.len();
        if n == 0 || n > MAX_PATCHES {
            return Err(LabError::Invalid(format!(
                "patches: give 1–{MAX_PATCHES} measured patches, each {{colour, geometry, measurement_id}}"
            )));
        }
        let tolerance = request.tolerance_delta_e00;
        if !(tolerance.is_finite() && tolerance > 0.0 && tolerance <= 100.0) {
            return Err(LabError::Invalid(format!(
                "tolerance_delta_e00 = {tolerance}: give a ΔE00 above 0 and at most 100 (default {DEFAULT_TOLERANCE_DE00})"
            )));
        }
        if request.client.len() > 1000 {
            return Err(LabError::Invalid("client: at most 1000 characters".into()));
        }
        let profile = self
            .store
            .get_display_profile(e.display_profile_id)
            .await?
            .ok_or_else(|| {
                LabError::Conflict(format!(
                    "experiment {experiment_id}'s display profile {} is gone",
                    e.display_profile_id
                ))
            })?
            .profile;
        let converter = Converter::new(&profile)
            .map_err(|err| LabError::Internal(format!("display profile {}: {err}", e.display_profile_id)))?;
        let white = converter.white();
        let scale_factor = check.gamut_scale_factor();
        let on_display = |xyz: [f64; 3]| {
            let l = converter.linear(xyz);
            let l = match experiment.gamut {
                GamutPolicy::Scale => l.map(|t| (t * scale_factor).clamp(0.0, 1.0)),
                _ => l.map(|t| t.clamp(0.0, 1.0)),
            };
            converter.xyz(l)
        };
        let booth = self.booth_xyz(e.measurement_id, profile.observer).await?;
        let mut colours = Vec::new();
        for (i, p) in request.patches.iter().enumerate() {
            let colour: &StoredColour = std::iter::once(&check.original)
                .chain(&check.approximations)
                .chain(std::iter::once(&check.background))
                .find(|c| c.name == p.colour)
                .ok_or_else(|| {
                    LabError::Invalid(format!(
                        "patches[{i}].colour = `{}`: experiment {experiment_id} shows `original`, {} and `background`",
                        p.colour,
                        experiment
                            .approximations
                            .iter()
                            .map(|a| format!("`{a}`"))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ))
                })?;
            if let Some(j) = request.patches[..i]
                .iter()
                .position(|q| q.measurement_id == p.measurement_id)
            {
                return Err(LabError::Invalid(format!(
                    "patches[{i}].measurement_id = {}: patches[{j}] names the same measurement; the display shows \
                     one colour at a time, so each patch is its own measurement",
                    p.measurement_id
                )));
            }
            let emitted = self
                .display_xyz(p.measurement_id, profile.observer, experiment_id, e.created_at)
                .await
                .map_err(|err| match err {
                    LabError::Invalid(m) | LabError::NotFound(m) | LabError::Conflict(m) => {
                        LabError::Invalid(format!("patches[{i}].measurement_id: {m}"))
                    }
                    other => other,
                })?;
            let intended = converter.xyz(colour.linear);
            let clipped = colour.out_of_gamut && experiment.gamut != GamutPolicy::Scale;
            let a = assess(white, intended, colour.shown_xyz, emitted, clipped, tolerance);
            let booth_xyz = (p.colour != "background").then(|| on_display(booth));
            colours.push(VerifiedColour {
                colour: p.colour.clone(),
                geometry: p.geometry,
                measurement_id: p.measurement_id,
                intended_xyz: intended,
                predicted_xyz: colour.shown_xyz,
                emitted_xyz: emitted,
                delta_e00_emitted: a.delta_e00_emitted,
                delta_e00_quantisation: a.delta_e00_quantisation,
                delta_e00_drift: a.delta_e00_drift,
                booth_xyz,
                delta_e00_booth: booth_xyz.map(|b| delta_e00(white, b, emitted)),
                passed: a.passed,
                likely_cause: a.likely_cause,
            });
        }
        let failed: Vec<&VerifiedColour> = colours.iter().filter(|c| !c.passed).collect();
        let mut summary = Vec::new();
        if failed.is_empty() {
            summary.push(format!(
                "every colour is within ΔE00 {tolerance} of what the experiment asks of the display (worst {:.2})",
                colours.iter().map(|c| c.delta_e00_emitted).fold(0.0, f64::max)
            ));
        } else {
            for c in &failed {
                summary.push(format!(
                    "{} ({}): emitted ΔE00 {:.2} from the intended colour, over the tolerance {tolerance}; likely cause: {}",
                    c.colour,
                    c.geometry.name(),
                    c.delta_e00_emitted,
                    c.likely_cause.as_deref().unwrap_or("unknown")
                ));
            }
            summary.push("do not run observers until the display shows the colours as intended".into());
        }
        if scale_factor < 1.0 - GAMUT_TOLERANCE && experiment.gamut == GamutPolicy::Scale {
            summary.push(format!(
                "the booth measurement is compared as the display shows it, darkened by the gamut scale factor {scale_factor:.4}"
            ));
        }
        let client = request.client.clone();
        let mut v = Verification {
            id: 0,
            experiment_id,
            created_at: lightbooth_store::now(),
            tolerance_delta_e00: tolerance,
            passed: failed.is_empty(),
            client,
            white_xyz: white.to_array(),
            observer: profile.observer.name().to_string(),
            colours,
            summary,
        };
        let json = serde_json::to_value(&v).map_err(|err| LabError::Internal(format!("a verification: {err}")))?;
        v.id = self.store.insert_verification(experiment_id, &json).await?;
        Ok(v)
    }

    /// An experiment's verifications, newest first.
    pub async fn verifications(&self, experiment_id: i64) -> Result<Vec<Verification>, LabError> {
        self.get(experiment_id).await?;
        self.store
            .verifications_of_experiment(experiment_id)
            .await?
            .into_iter()
            .map(|(id, created_at, json)| {
                let mut v: Verification = serde_json::from_value(json)
                    .map_err(|err| LabError::Internal(format!("verification {id}: {err}")))?;
                v.id = id;
                v.created_at = created_at;
                Ok(v)
            })
            .collect()
    }

    /// The booth measurement's XYZ, as the experiment's check took it.
    async fn booth_xyz(
        &self,
        measurement_id: i64,
        observer: lightbooth_science::colorimetry::Observer,
    ) -> Result<[f64; 3], LabError> {
        let rows = self.store.comparisons_for_measurement(measurement_id).await?;
        if let Some(r) = rows.last() {
            return Ok([r.measured_X, r.measured_Y, r.measured_Z]);
        }
        self.emitted_xyz(measurement_id, observer).await
    }

    /// The XYZ of a complete measurement of the display (see the module
    /// doc): not a scene's target, taken after the experiment was created.
    async fn display_xyz(
        &self,
        id: i64,
        observer: lightbooth_science::colorimetry::Observer,
        experiment_id: i64,
        experiment_created_at: f64,
    ) -> Result<[f64; 3], LabError> {
        let m = self
            .store
            .get_measurement(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("there is no measurement {id}")))?;
        if let (Some(scene), Some(target)) = (&m.summary.scene, &m.summary.target) {
            return Err(LabError::Invalid(format!(
                "measurement {id} is of the booth's scene {scene}/{target}, not of the display: measure the display \
                 while it shows the colour (the session page's “verify the display”)"
            )));
        }
        if m.summary.created_at < experiment_created_at {
            return Err(LabError::Invalid(format!(
                "measurement {id} was taken before the experiment was created, so not while the display showed its \
                 colour: measure the display while it shows the colour (the session page's “verify the display”)"
            )));
        }
        let wanted = hold_purpose(experiment_id);
        match &m.summary.hold {
            Some(h) if h.purpose == wanted => {}
            held => {
                let taken = match held {
                    None => "freely, under no instrument hold".to_string(),
                    Some(h) => format!("under hold {} for “{}”", h.id, h.purpose),
                };
                return Err(LabError::Invalid(format!(
                    "measurement {id} was taken {taken}, not under the hold “{wanted}”, so nothing says the display \
                     showed the colour: measure the display while it shows the colour (the session page's “verify \
                     the display”, or take POST /api/instrument/hold {{\"purpose\": \"{wanted}\"}} and name it in each \
                     measurement)"
                )));
            }
        }
        self.emitted_xyz(id, observer).await
    }

    /// The XYZ of a complete measurement.
    async fn emitted_xyz(
        &self,
        id: i64,
        observer: lightbooth_science::colorimetry::Observer,
    ) -> Result<[f64; 3], LabError> {
        let m = self
            .store
            .get_measurement(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("there is no measurement {id}")))?;
        if m.summary.state != MeasurementState::Complete {
            return Err(LabError::Conflict(format!(
                "measurement {id} is {}: only a complete measurement verifies a colour",
                m.summary.state.as_str()
            )));
        }
        measured_xyz(&m, observer)
            .map_err(LabError::Internal)?
            .map(|x| x.to_array())
            .ok_or_else(|| LabError::Conflict(format!("measurement {id} holds no spectrum")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lightbooth_science::colorimetry::Xyz;

    const WHITE: Xyz = Xyz {
        x: 95.047,
        y: 100.0,
        z: 108.883,
    };

    #[test]
    fn a_colour_emitted_as_intended_passes_with_no_cause() {
        let c = [20.0, 21.0, 23.0];
        let a = assess(WHITE, c, c, c, false, 1.0);
        assert!(a.passed && a.likely_cause.is_none(), "{a:?}");
        assert_eq!(a.delta_e00_emitted, 0.0);
    }

    #[test]
    fn a_display_darker_than_its_profile_is_called_drift() {
        let c = [20.0, 21.0, 23.0];
        let dim = c.map(|v| v * 0.9);
        let a = assess(WHITE, c, c, dim, false, 1.0);
        assert!(!a.passed, "{a:?}");
        assert!(a.delta_e00_drift > 1.0 && a.delta_e00_quantisation == 0.0);
        let cause = a.likely_cause.unwrap();
        assert!(
            cause.starts_with("drift since calibration") && cause.contains("recalibrate"),
            "{cause}"
        );
    }

    #[test]
    fn a_colour_the_method_cannot_show_is_called_quantisation_and_a_clipped_one_out_of_gamut() {
        let intended = [20.0, 21.0, 23.0];
        let predicted = [20.0, 21.8, 23.0];
        let a = assess(WHITE, intended, predicted, predicted, true, 1.0);
        assert!(!a.passed && a.delta_e00_drift == 0.0, "{a:?}");
        let cause = a.likely_cause.unwrap();
        assert!(
            cause.contains("out of gamut") && cause.contains("quantisation"),
            "{cause}"
        );
        assert!(!cause.contains("drift"), "{cause}");
    }
}
