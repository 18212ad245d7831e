//! The study's discrimination experiment as a lab workflow: an experiment
//! set up from a stored measurement and its comparisons, checked on its
//! display before anyone sits down ([`Experiments::create`]), run trial by
//! trial by observers ([`session`]), and analysed ([`analysis`]).
//!
//! An experiment is one scene's target, as Ruppertsberg & Bloj (2006,
//! section 4.B) ran one block per scene:
//!
//! - **the original**: the measured colour of a complete measurement (the
//!   study's), or one coding's rendering of it (e.g. `spectral`, the
//!   converged reference);
//! - **the approximations**: any codings, each the rendering of that target
//!   in the comparison of that measurement ([`crate::compare`]:
//!   the same XYZ its ΔE is computed from, in the same observer);
//! - **the display**: a stored display profile in that observer, and an
//!   [`OutputMethod`];
//! - **the presentation**: the study's pie and timeline
//!   ([`Presentation`], its values the defaults), and a seed.
//!
//! Every colour is converted through the profile when the experiment is
//! created and the [`ColourCheck`] is stored with it: what is out of gamut
//! and which approximations the display cannot show apart from the original,
//! at 8 bits and with the output method, in words with the codes.

pub mod analysis;
pub mod session;
#[cfg(test)]
mod tests;
pub mod verification;

use serde::{Deserialize, Serialize};

use super::error::LabError;
use lightbooth_science::display::output::{check_colours, ColourCheck, OutputMethod};
use lightbooth_science::display::stimulus::GamutPolicy;
use lightbooth_science::psychophysics::design::MAX_APPROXIMATIONS;
use lightbooth_science::psychophysics::presentation::Presentation;
use lightbooth_science::random::splitmix64;
use lightbooth_store::{ExperimentRow, MeasurementState, NewExperiment, Store};
use session::MAX_SEED;

/// The refresh rate the check at creation assumes for the number of frames
/// a pie is averaged over; each session page measures its own and reports it.
pub const NOMINAL_REFRESH_HZ: f64 = 60.0;

/// An experiment as a client asks for it (`POST /api/experiments`,
/// `lightbooth experiment create`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct ExperimentRequest {
    /// A name for people; `"<scene>/<target>"` when empty.
    #[serde(default)]
    pub name: String,
    /// A complete measurement with comparisons: its scene, target and booth
    /// are the experiment's.
    pub measurement_id: i64,
    /// `measured` (the study's original) or a coding whose rendering is the original.
    #[serde(default = "measured")]
    pub original: String,
    /// Codings to test against the original (1–16), e.g. `["nstep3", "nstep9"]`.
    pub approximations: Vec<String>,
    /// The stored display profile the stimuli are shown through.
    pub display_profile_id: i64,
    /// `8bit`, `noisy_bit` (the default) or `10bit`.
    #[serde(default = "noisy_bit")]
    #[cfg_attr(feature = "openapi", schema(value_type = String))]
    pub output: OutputMethod,
    /// `scale` (the default: every colour darkened by one factor until all
    /// fit, so their differences keep their proportions), `clip` or `fail`.
    #[serde(default = "scale")]
    #[cfg_attr(feature = "openapi", schema(value_type = String))]
    pub gamut: GamutPolicy,
    #[serde(default)]
    pub presentation: Presentation,
    /// The trial orders' seed, 0–2⁵³−1 (exact in JavaScript and MATLAB);
    /// drawn and stored when absent.
    #[serde(default)]
    pub seed: Option<u64>,
}

fn measured() -> String {
    "measured".into()
}
fn noisy_bit() -> OutputMethod {
    OutputMethod::NoisyBit
}
fn scale() -> GamutPolicy {
    GamutPolicy::Scale
}

/// Sets up, checks and keeps experiments.
#[derive(Clone)]
pub struct Experiments {
    store: Store,
}

impl Experiments {
    pub fn new(store: Store) -> Experiments {
        Experiments { store }
    }

    /// The store under it, for the tests' checks behind it.
    #[cfg(test)]
    pub(crate) fn store(&self) -> &Store {
        &self.store
    }

    /// The colours of `request` through its display profile, checked (see
    /// the module doc), without storing anything.
    pub async fn check(&self, request: &ExperimentRequest) -> Result<(Checked, ColourCheck), LabError> {
        check_name(&request.name)?;
        request.presentation.validate().map_err(LabError::Invalid)?;
        let n = request.approximations.len();
        if n == 0 || n > MAX_APPROXIMATIONS {
            return Err(LabError::Invalid(format!(
                "approximations: give 1–{MAX_APPROXIMATIONS} codings to test against the original, e.g. [\"nstep3\", \"nstep9\"]"
            )));
        }
        for (i, a) in request.approximations.iter().enumerate() {
            if *a == request.original {
                return Err(LabError::Invalid(format!(
                    "approximations[{i}] = `{a}` is the original itself: an oddity trial needs two different colours"
                )));
            }
            if request.approximations[..i].contains(a) {
                return Err(LabError::Invalid(format!(
                    "approximations[{i}] = `{a}` is listed twice"
                )));
            }
        }
        if let Some(seed) = request.seed {
            if seed > MAX_SEED {
                return Err(LabError::Invalid(format!(
                    "seed = {seed}: give 0–{MAX_SEED} (2⁵³ − 1: a larger number is not exact in JavaScript or MATLAB)"
                )));
            }
        }
        let id = request.measurement_id;
        let m = self
            .store
            .get_measurement(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("measurement_id: there is no measurement {id}")))?;
        if m.summary.state != MeasurementState::Complete {
            return Err(LabError::Conflict(format!(
                "measurement {id} is {}: an experiment needs a complete measurement",
                m.summary.state.as_str()
            )));
        }
        let (Some(scene), Some(target)) = (m.summary.scene.clone(), m.summary.target.clone()) else {
            return Err(LabError::Invalid(format!(
                "measurement {id} names no scene target: measure a target of a scene (POST /api/measurements with scene and target)"
            )));
        };
        let profile_id = request.display_profile_id;
        let row = self.store.get_display_profile(profile_id).await?.ok_or_else(|| {
            LabError::NotFound(format!(
                "display_profile_id: there is no display profile {profile_id} (calibrate the display first: /calibrate)"
            ))
        })?;
        if !row.failures.is_empty() {
            return Err(LabError::Conflict(format!(
                "display_profile_id: profile {profile_id} failed its checks ({}); calibrate the display again (/calibrate)",
                row.failures.join("; ")
            )));
        }
        if let lightbooth_science::display::Emission::Luminance { .. } = row.profile.emission {
            return Err(LabError::Conflict(format!(
                "display_profile_id: profile {profile_id} was calibrated with a luminance meter (γ only, no primaries' \
                 colour) and cannot show an experiment's colours; calibrate with a colorimeter or a spectroradiometer"
            )));
        }
        let profile = row.profile;
        let rows = self.store.comparisons_for_measurement(id).await?;
        if rows.is_empty() {
            return Err(LabError::Conflict(format!(
                "measurement {id} has no comparisons yet: they are computed after it completes; try again in a moment"
            )));
        }
        let newest = |coding: &str| rows.iter().rev().find(|r| r.coding == coding);
        let have = || {
            let mut c: Vec<&str> = rows.iter().map(|r| r.coding.as_str()).collect();
            c.sort();
            c.dedup();
            c.join(", ")
        };
        let original = if request.original == "measured" {
            let r = &rows[rows.len() - 1];
            [r.measured_X, r.measured_Y, r.measured_Z]
        } else {
            let r = newest(&request.original).ok_or_else(|| {
                LabError::Invalid(format!(
                    "original = `{}`: measurement {id} has no comparison with that coding; give `measured` or one of {}",
                    request.original,
                    have()
                ))
            })?;
            [r.rendered_X, r.rendered_Y, r.rendered_Z]
        };
        let observer = rows[rows.len() - 1].observer;
        if observer != profile.observer {
            return Err(LabError::Conflict(format!(
                "measurement {id} is compared in the {} observer and display profile {profile_id} in {}: \
                 calibrate the display with the daemon's observer",
                observer.name(),
                profile.observer.name()
            )));
        }
        let mut approximations = Vec::new();
        for (i, a) in request.approximations.iter().enumerate() {
            let r = newest(a).ok_or_else(|| {
                LabError::Invalid(format!(
                    "approximations[{i}] = `{a}`: measurement {id} has no comparison with that coding; it has {}",
                    have()
                ))
            })?;
            approximations.push((a.clone(), [r.rendered_X, r.rendered_Y, r.rendered_Z]));
        }
        let p = &request.presentation;
        let samples = p.piece_pixels() * f64::from(p.frames(p.stimulus_ms, NOMINAL_REFRESH_HZ));
        let check = check_colours(
            &profile,
            original,
            &approximations,
            request.output,
            samples,
            request.gamut,
        )
        .map_err(|e| LabError::Invalid(format!("display_profile_id {profile_id}: {e}")))?;
        Ok((
            Checked {
                scene,
                target,
                booth: m.summary.booth.clone(),
            },
            check,
        ))
    }

    /// Checks and stores an experiment.
    pub async fn create(&self, mut request: ExperimentRequest) -> Result<ExperimentRow, LabError> {
        let (checked, check) = self.check(&request).await?;
        let seed = request.seed.unwrap_or_else(|| {
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_nanos() as u64)
                .unwrap_or_default();
            splitmix64(nanos) & MAX_SEED
        });
        request.seed = Some(seed);
        if request.name.trim().is_empty() {
            request.name = format!("{}/{}", checked.scene, checked.target);
        }
        let request_json = serde_json::to_value(&request).expect("a request serialises");
        let check_json = serde_json::to_value(&check).expect("a check of finite numbers serialises");
        let id = self
            .store
            .insert_experiment(&NewExperiment {
                name: request.name.trim(),
                scene: &checked.scene,
                target: &checked.target,
                booth: &checked.booth,
                measurement_id: request.measurement_id,
                display_profile_id: request.display_profile_id,
                output_method: request.output.name(),
                seed: seed as i64,
                request: &request_json,
                check: &check_json,
            })
            .await?;
        self.get(id).await
    }

    pub async fn get(&self, id: i64) -> Result<ExperimentRow, LabError> {
        self.store
            .get_experiment(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("there is no experiment {id}")))
    }
}

/// An experiment's name is at most this many characters.
pub const MAX_NAME_CHARS: usize = 200;

/// A name for people: at most [`MAX_NAME_CHARS`] characters, no control
/// characters (NUL, ESC, line breaks…), which no list or terminal shows.
pub fn check_name(name: &str) -> Result<(), LabError> {
    let n = name.chars().count();
    if n > MAX_NAME_CHARS {
        return Err(LabError::Invalid(format!(
            "name: {n} characters; give at most {MAX_NAME_CHARS}"
        )));
    }
    if let Some((i, c)) = name.chars().enumerate().find(|(_, c)| c.is_control()) {
        return Err(LabError::Invalid(format!(
            "name: character {} is the control character U+{:04X}; give letters, digits, spaces and punctuation",
            i + 1,
            c as u32
        )));
    }
    Ok(())
}

/// What the check found out about the measurement.
#[derive(Clone, Debug)]
pub struct Checked {
    pub scene: String,
    pub target: String,
    pub booth: String,
}

/// The stored request and check of an experiment, parsed.
pub fn parts(e: &ExperimentRow) -> Result<(ExperimentRequest, StoredCheck), LabError> {
    let corrupt =
        |what: &str, err: serde_json::Error| LabError::Internal(format!("experiment {}: {what}: {err}", e.id));
    let request: ExperimentRequest =
        serde_json::from_value(e.request.clone()).map_err(|err| corrupt("request", err))?;
    let check: StoredCheck = serde_json::from_value(e.check.clone()).map_err(|err| corrupt("check", err))?;
    Ok((request, check))
}

/// The parts of a stored [`ColourCheck`] the session and analysis read.
#[derive(Clone, Debug, Deserialize)]
pub struct StoredCheck {
    pub original: StoredColour,
    pub approximations: Vec<StoredColour>,
    pub background: StoredColour,
    #[serde(default)]
    pub gamut: StoredGamut,
}

impl StoredCheck {
    /// The factor the `scale` gamut policy darkened every colour by (1 otherwise).
    pub fn gamut_scale_factor(&self) -> f64 {
        self.gamut.scale_factor
    }
}

/// The part of a stored gamut report the verification reads.
#[derive(Clone, Debug, Deserialize)]
pub struct StoredGamut {
    pub scale_factor: f64,
}

impl Default for StoredGamut {
    fn default() -> Self {
        StoredGamut { scale_factor: 1.0 }
    }
}

/// One colour of a stored check.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct StoredColour {
    pub name: String,
    /// The colour asked for, XYZ cd/m² (before the gamut policy).
    #[serde(default)]
    pub xyz: [f64; 3],
    #[serde(default)]
    pub out_of_gamut: bool,
    pub linear: [f64; 3],
    /// What the profile predicts the output method emits, XYZ cd/m².
    #[serde(default)]
    pub shown_xyz: [f64; 3],
    pub fractional_code: [f64; 3],
    pub codes_8bit: [u32; 3],
    #[serde(default)]
    pub delta_e00_intended: f64,
    #[serde(default)]
    pub delta_e00_shown: f64,
    #[serde(default)]
    pub distinct: bool,
    #[serde(default)]
    pub distinct_at_8bit: bool,
}
