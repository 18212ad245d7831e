//! A display profile fitted from the stored measurements of the colours a
//! calibration showed (`/calibrate` posts them): each measurement read and
//! checked complete, its light taken as its instrument gave it (a
//! spectrum, a colorimeter's XYZ or a luminance meter's Y,
//! [`crate::measure::recorder::display_patch_light`]), the observer settled (a
//! colorimeter's own; never two mixed), the profile fitted
//! ([`lightbooth_science::display::fit_profile`]) and stored with the
//! patches' measurement ids.

use crate::error::LabError;
use crate::LabHandle;
use lightbooth_science::colorimetry::Observer;
use lightbooth_science::display::fit::MeasuredPatch;
use lightbooth_science::display::fit_profile;
use lightbooth_store::{DisplayProfileRow, MeasurementState};

/// The most patches one profile may be fitted from (the plan at 32 steps
/// has 108).
pub const MAX_PATCHES: usize = 256;

/// A colour shown and the complete measurement taken of it.
#[derive(Clone, Copy, Debug)]
pub struct ShownPatch {
    /// Drive of red, green, blue, 0–1.
    pub drive: [f64; 3],
    pub measurement_id: i64,
}

/// A profile to fit (see the module doc).
#[derive(Clone, Debug)]
pub struct ProfileRequest {
    pub name: String,
    pub note: String,
    /// The observer asked for by name; `None`: the instrument's own for a
    /// colorimeter or a luminance meter, else the default.
    pub observer: Option<String>,
    pub patches: Vec<ShownPatch>,
}

impl LabHandle {
    /// Fits and stores the profile of `request`; every refusal names the
    /// field (`patches[i]`, `observer`) and what to do.
    pub async fn fit_display_profile(&self, request: ProfileRequest) -> Result<DisplayProfileRow, LabError> {
        if request.patches.len() > MAX_PATCHES {
            return Err(LabError::Invalid(format!(
                "field `patches`: {} patches; at most {MAX_PATCHES}",
                request.patches.len()
            )));
        }
        let asked: Option<Observer> = match &request.observer {
            Some(o) => Some(
                o.parse()
                    .map_err(|e| LabError::Invalid(format!("field `observer`: {e}")))?,
            ),
            None => None,
        };
        let mut patches = Vec::with_capacity(request.patches.len());
        // The observer of the first colorimeter's or luminance meter's
        // patch, with where it came from.
        let mut instrument_observer: Option<(Observer, usize, String)> = None;
        for (i, p) in request.patches.iter().enumerate() {
            let m = self.measurement(p.measurement_id).await?;
            if m.summary.state != MeasurementState::Complete {
                return Err(LabError::Invalid(format!(
                    "field `patches[{i}]`: measurement {} is {}, not complete",
                    p.measurement_id,
                    m.summary.state.as_str()
                )));
            }
            let (light, observer) = crate::measure::recorder::display_patch_light(&m)
                .map_err(|e| LabError::Invalid(format!("field `patches[{i}]`: {e}")))?;
            if let Some(o) = observer {
                let model = m
                    .summary
                    .instrument_model
                    .clone()
                    .unwrap_or_else(|| "instrument".into());
                match &instrument_observer {
                    Some((first, j, _)) if *first != o => {
                        return Err(LabError::Invalid(format!(
                            "field `patches[{i}]`: measurement {} is in the {o} observer but patches[{j}] in {first}: \
                             calibrate with one instrument",
                            p.measurement_id
                        )))
                    }
                    Some(_) => {}
                    None => instrument_observer = Some((o, i, model)),
                }
            }
            patches.push(MeasuredPatch {
                drive: p.drive,
                light,
                measurement_id: Some(p.measurement_id),
            });
        }
        // A colorimeter's XYZ stay in the observer of its filters: the
        // profile takes it, and refuses another rather than mixing two.
        let observer = match (asked, &instrument_observer) {
            (Some(a), Some((o, _, model))) if a != *o => {
                return Err(LabError::Invalid(format!(
                    "field `observer`: the patches were measured by the {model} in the {o} observer, so the profile \
                     is in {o}; ask for `{o}` or leave `observer` out"
                )))
            }
            (_, Some((o, _, _))) => *o,
            (Some(a), None) => a,
            (None, None) => Observer::default(),
        };
        let profile = fit_profile(&patches, observer).map_err(|e| LabError::Invalid(e.to_string()))?;
        self.add_display_profile(&request.name, &request.note, &profile).await
    }
}
