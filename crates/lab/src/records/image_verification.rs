//! A stimulus set's coding verified on the display at the scene's targets
//! (issue 48, part 3): the scene's radiometer targets projected into the
//! image are where the instrument measures the screen, and its field
//! covers a disc of pixels around each
//! (`lightbooth_science::display::image_verification`).
//!
//! - **The plan** ([`ImageTargets`], `GET /api/stimulus-sets/{id}/targets`):
//!   each target of the set's scene, projected through the scene's camera
//!   at the set's size (`render::camera::targets_in_view`): its image
//!   point, whether it is inside the image and not hidden, and the booth's
//!   newest complete measurement of it in this booth. The field's radius in
//!   screen pixels follows from the instrument's field (the scene's
//!   radiometer's, 1° for CYLINDER), the viewing distance and the pixel
//!   pitch (`Presentation::field_radius_px`); the image is shown with each
//!   image pixel as `magnification` × `magnification` screen pixels (1 by
//!   default), and each image pixel weighs as many of its screen pixels as
//!   the field sees. When the image's angular size on the screen
//!   is not the camera's field of view (within 10 %), the plan and the
//!   result say so beside the numbers: the field then averages another part
//!   of the scene than the booth's instrument did. Only a set made from the daemon's camera images
//!   has a scene to project (an uploaded file names none).
//! - **The verification** ([`ImageVerificationRequest`]): per target, the
//!   measurement the page took while the display showed the coding with
//!   the instrument aimed at that target. Like an experiment's, only a
//!   measurement taken under the instrument hold of exactly
//!   [`hold_purpose`] (taken by the page), after the set was made, of no
//!   scene target and complete, verifies a target; one measurement for two
//!   targets is refused. Per target: ΔE00 intended → emitted, the
//!   quantisation's share (intended → predicted at the set's output) and
//!   the display against its profile (predicted → emitted), and booth →
//!   emitted.
//! - **The booth on the display**: the booth's measurement goes through the
//!   set's gamut policy as the image did (its linear RGB × the set's scale
//!   factor, each channel clipped to 0–1), so booth → emitted compares the
//!   light the image stands for with the light it emits, at the display's
//!   brightness.
//! - Stored with its request; a chart draws the luminance profile along
//!   the targets: the booth, the intended and the emitted.

use serde::{Deserialize, Serialize};

use crate::compare::white::measured_xyz;
use crate::error::LabError;
use crate::LabHandle;
use lightbooth_render::camera::targets_in_view;
use lightbooth_science::display::image_set::{output_index, OUTPUTS};
use lightbooth_science::display::image_verification::{
    assess_target, target_fields, TargetOnScreen, TargetVerification,
};
use lightbooth_science::display::Converter;
use lightbooth_science::psychophysics::presentation::Presentation;
use lightbooth_store::{MeasurementState, StimulusSetRow, StimulusSetVerificationRow};

/// Targets one verification may name, at most.
pub const MAX_TARGETS: usize = 128;

/// The purpose of the instrument hold a set's verification is measured
/// under; the page takes the hold with exactly this purpose.
pub fn hold_purpose(set_id: i64) -> String {
    format!("verification of stimulus set {set_id}")
}

/// Where the screen is: the viewing distance (the instrument where the
/// observer's eye is), the pixel pitch, and the instrument's field.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct ScreenGeometry {
    /// mm, 100–5000 (default 570, an experiment's).
    #[cfg_attr(feature = "openapi", schema(minimum = 100, maximum = 5000))]
    pub viewing_distance_mm: Option<f64>,
    /// mm, 0.05–2 (default 0.25: measure yours).
    #[cfg_attr(feature = "openapi", schema(minimum = 0.05, maximum = 2))]
    pub pixel_pitch_mm: Option<f64>,
    /// The instrument's field, full angle in degrees, 0.1–10 (default: the
    /// scene's radiometer's).
    #[cfg_attr(feature = "openapi", schema(minimum = 0.1, maximum = 10))]
    pub field_deg: Option<f64>,
    /// Screen pixels per image pixel, each way, 1–16 (default 1): the
    /// image shown magnified, so that it subtends the camera's view.
    #[cfg_attr(feature = "openapi", schema(minimum = 1, maximum = 16))]
    pub magnification: Option<u32>,
}

/// One target of the plan.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ImageTarget {
    pub id: String,
    /// The image point, pixels (x right, y down from the top-left corner).
    pub x: f64,
    pub y: f64,
    /// Inside the image and not hidden: it can be verified.
    pub verifiable: bool,
    /// The booth's newest complete measurement of it in this booth.
    pub booth_measurement_id: Option<i64>,
}

/// Where to aim, per target, to verify a set's coding.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ImageTargets {
    pub set_id: i64,
    pub scene: String,
    /// The hold the page measures under.
    pub hold_purpose: String,
    pub width: u32,
    pub height: u32,
    pub viewing_distance_mm: f64,
    pub pixel_pitch_mm: f64,
    pub field_deg: f64,
    /// Screen pixels per image pixel, each way.
    pub magnification: u32,
    /// The field on the screen, in screen pixels.
    pub field_radius_px: f64,
    /// The image's height as seen from the viewing distance, and the
    /// scene camera's vertical field of view it stands for, degrees.
    pub image_height_deg: f64,
    pub camera_fov_deg: f64,
    /// Said when the two differ by more than 10 %: the instrument's field
    /// then covers another part of the scene than the booth's instrument did.
    pub angular_size_note: Option<String>,
    pub targets: Vec<ImageTarget>,
}

/// One target measured.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct MeasuredTarget {
    pub target: String,
    pub measurement_id: i64,
}

/// `POST /api/stimulus-sets/{id}/verifications`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct ImageVerificationRequest {
    /// The coding shown.
    pub coding: String,
    #[cfg_attr(feature = "openapi", schema(min_items = 1, max_items = 128))]
    pub targets: Vec<MeasuredTarget>,
    #[serde(default)]
    pub screen: ScreenGeometry,
    /// The browser and its drawing path, as the page says.
    #[serde(default)]
    pub client: String,
}

/// A verification's result, as stored.
#[derive(Clone, Debug, Serialize)]
pub struct ImageVerification {
    pub set_id: i64,
    pub coding: String,
    pub output: String,
    pub field_radius_px: f64,
    pub magnification: u32,
    /// The set's gamut policy and its scale factor, applied to the booth's
    /// measurements as to the image.
    pub policy: String,
    pub scale_factor: f64,
    pub targets: Vec<TargetVerification>,
    /// The image's angular size against the camera's, when they differ
    /// (see [`ImageTargets::angular_size_note`]).
    pub angular_size_note: Option<String>,
    /// Over the targets: the largest ΔE00 intended → emitted, and booth →
    /// emitted where the booth was measured.
    pub max_delta_e00_intended_emitted: f64,
    pub max_delta_e00_booth_emitted: Option<f64>,
}

impl LabHandle {
    /// The targets of set `id` on the screen (see the module doc).
    pub async fn image_targets(&self, id: i64, screen: ScreenGeometry) -> Result<ImageTargets, LabError> {
        let set = self.stimulus_set(id).await?;
        let (Some(render_id), Some(scene_id)) = (set.render_id, set.scene.clone()) else {
            return Err(LabError::Conflict(format!(
                "stimulus set {id} was uploaded: it names no scene whose targets could be projected into it \
                 (make the set from the daemon's camera images to verify it at the targets)"
            )));
        };
        let render = self
            .store()
            .get_render(render_id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("stimulus set {id}'s render {render_id} is gone")))?;
        let catalogue = std::sync::Arc::clone(self.renders()?.catalogue());
        let entry = catalogue
            .get(&scene_id)
            .ok_or_else(|| LabError::NotFound(format!("stimulus set {id}'s scene `{scene_id}` is gone")))?;
        if entry.hash != render.scene_hash {
            return Err(LabError::Conflict(format!(
                "the scene file of `{scene_id}` changed since render {render_id}: its targets may not be where the \
                 image shows them"
            )));
        }
        let defaults = Presentation::default();
        let check = |v: Option<f64>, default: f64, range: std::ops::RangeInclusive<f64>, field: &str, unit: &str| {
            let v = v.unwrap_or(default);
            if range.contains(&v) {
                Ok(v)
            } else {
                Err(LabError::Invalid(format!(
                    "field `{field}`: {v} is outside {}–{} {unit}",
                    range.start(),
                    range.end()
                )))
            }
        };
        let distance = check(
            screen.viewing_distance_mm,
            defaults.viewing_distance_mm,
            100.0..=5000.0,
            "viewing_distance_mm",
            "mm",
        )?;
        let pitch = check(
            screen.pixel_pitch_mm,
            defaults.pixel_pitch_mm,
            0.05..=2.0,
            "pixel_pitch_mm",
            "mm",
        )?;
        let field_deg = check(
            screen.field_deg,
            entry.scene.radiometer.field_deg,
            0.1..=10.0,
            "field_deg",
            "degrees",
        )?;
        let magnification = screen.magnification.unwrap_or(1);
        if !(1..=16).contains(&magnification) {
            return Err(LabError::Invalid(format!(
                "field `magnification`: {magnification} is outside 1–16 screen pixels per image pixel"
            )));
        }
        let presentation = Presentation {
            viewing_distance_mm: distance,
            pixel_pitch_mm: pitch,
            ..defaults
        };
        let mut camera = entry.scene.camera.clone().ok_or_else(|| {
            LabError::Conflict(format!(
                "scene `{scene_id}` has no [camera]: its targets cannot be projected"
            ))
        })?;
        let shown_px = set.height as f64 * magnification as f64;
        let image_height_deg = 2.0 * (shown_px * pitch / 2.0 / distance).atan().to_degrees();
        let camera_fov_deg = camera.fov_deg;
        let ratio = image_height_deg / camera_fov_deg;
        let angular_size_note = (!(0.9..=1.1).contains(&ratio)).then(|| {
            // The height at which the image subtends the camera's view here.
            let wanted_px = 2.0 * distance * (camera_fov_deg.to_radians() / 2.0).tan() / pitch;
            format!(
                "the image is {image_height_deg:.1}° high on this screen and the camera's view it stands for is \
                 {camera_fov_deg:.1}°: the instrument's {field_deg}° field covers {:.0} % of the image's height, not the \
                 {field_deg}° of the scene the booth's instrument measured. Show the image at the camera's angular \
                 size (about {wanted_px:.0} px high at this distance and pitch: magnification {:.0} for this \
                 {}-px image) to measure the targets as the booth's instrument saw them.",
                100.0 * field_deg / image_height_deg,
                (wanted_px / set.height as f64).round().max(1.0),
                set.height
            )
        });
        camera.width = set.width;
        camera.height = set.height;
        let scene = std::sync::Arc::clone(&entry.scene);
        let in_view = tokio::task::spawn_blocking(move || targets_in_view(&scene, &camera))
            .await
            .map_err(|e| LabError::Internal(e.to_string()))?
            .map_err(|e| LabError::Internal(e.to_string()))?;
        let mut targets = Vec::with_capacity(in_view.len());
        for t in in_view {
            let booth = self
                .store()
                .latest_complete_in_booth(&scene_id, &t.id, self.booth())
                .await?;
            targets.push(ImageTarget {
                verifiable: t.inside && t.visible,
                booth_measurement_id: booth.map(|m| m.summary.id),
                id: t.id,
                x: t.x,
                y: t.y,
            });
        }
        Ok(ImageTargets {
            set_id: id,
            scene: scene_id,
            hold_purpose: hold_purpose(id),
            width: set.width,
            height: set.height,
            viewing_distance_mm: distance,
            pixel_pitch_mm: pitch,
            field_deg,
            magnification,
            field_radius_px: presentation.field_radius_px(field_deg),
            image_height_deg,
            camera_fov_deg,
            angular_size_note,
            targets,
        })
    }

    /// Verifies a set's coding from the measurements at its targets, and
    /// stores the result (see the module doc).
    pub async fn verify_image(
        &self,
        id: i64,
        request: ImageVerificationRequest,
    ) -> Result<StimulusSetVerificationRow, LabError> {
        if request.targets.is_empty() || request.targets.len() > MAX_TARGETS {
            return Err(LabError::Invalid(format!(
                "field `targets`: {} targets; give 1–{MAX_TARGETS}",
                request.targets.len()
            )));
        }
        let set = self.stimulus_set(id).await?;
        let coding_index = set.codings.iter().position(|c| *c == request.coding).ok_or_else(|| {
            LabError::Invalid(format!(
                "field `coding`: stimulus set {id} has no coding `{}` (it has {})",
                request.coding,
                set.codings.join(", ")
            ))
        })?;
        let plan = self.image_targets(id, request.screen).await?;
        let profile = self.display_profile(set.profile_id).await?.profile;
        let observer = profile.observer;
        let mut on_screen = Vec::with_capacity(request.targets.len());
        let mut emitted = Vec::with_capacity(request.targets.len());
        for (i, t) in request.targets.iter().enumerate() {
            let field = format!("targets[{i}]");
            let planned = plan.targets.iter().find(|p| p.id == t.target).ok_or_else(|| {
                LabError::Invalid(format!(
                    "field `{field}`: scene `{}` has no target `{}`",
                    plan.scene, t.target
                ))
            })?;
            if !planned.verifiable {
                return Err(LabError::Invalid(format!(
                    "field `{field}`: target `{}` is outside the image or hidden in it: nothing of it is shown",
                    t.target
                )));
            }
            if request.targets[..i]
                .iter()
                .any(|o| o.measurement_id == t.measurement_id || o.target == t.target)
            {
                return Err(LabError::Invalid(format!(
                    "field `{field}`: target `{}` or measurement {} is named twice (one measurement per target)",
                    t.target, t.measurement_id
                )));
            }
            emitted.push(self.display_measurement(&set, t.measurement_id, &field).await?);
            let booth_xyz = match planned.booth_measurement_id {
                Some(m) => {
                    let detail = self.measurement(m).await?;
                    measured_xyz(&detail, observer)
                        .map_err(LabError::Internal)?
                        .map(|x| x.to_array())
                }
                None => None,
            };
            on_screen.push(TargetOnScreen {
                id: t.target.clone(),
                x: planned.x,
                y: planned.y,
                booth_xyz,
            });
        }
        let linear_bytes = self.stimulus_set_linear(id, &request.coding).await?;
        let bits = OUTPUTS[output_index(&set.output).map_err(LabError::Internal)?].1;
        let scale_factor = set.report["gamut"]["scale_factor"].as_f64().unwrap_or(1.0);
        let (width, radius, magnification) = (set.width as usize, plan.field_radius_px, plan.magnification);
        let result = tokio::task::spawn_blocking(move || {
            let linear: Vec<[f32; 3]> = linear_bytes
                .chunks_exact(12)
                .map(|b| {
                    std::array::from_fn(|k| f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]]))
                })
                .collect();
            let converter = Converter::new(&profile).map_err(|e| LabError::Internal(e.to_string()))?;
            // The booth through the set's gamut policy (see the module doc).
            for t in &mut on_screen {
                t.booth_xyz = t.booth_xyz.map(|b| {
                    let l = converter.linear(b).map(|v| (v * scale_factor).clamp(0.0, 1.0));
                    converter.xyz(l)
                });
            }
            let fields = target_fields(&profile, &linear, width, bits, &on_screen, radius, magnification)
                .map_err(|e| LabError::Invalid(format!("field `targets`: {e}")))?;
            fields
                .iter()
                .zip(&emitted)
                .map(|(f, e)| assess_target(&profile, f, *e).map_err(|e| LabError::Internal(e.to_string())))
                .collect::<Result<Vec<_>, _>>()
        })
        .await
        .map_err(|e| LabError::Internal(e.to_string()))??;
        let verification = ImageVerification {
            set_id: id,
            coding: set.codings[coding_index].clone(),
            output: set.output.clone(),
            field_radius_px: radius,
            magnification,
            policy: set.policy.clone(),
            scale_factor,
            angular_size_note: plan.angular_size_note.clone(),
            max_delta_e00_intended_emitted: result.iter().map(|t| t.delta_e00_intended_emitted).fold(0.0, f64::max),
            max_delta_e00_booth_emitted: result.iter().filter_map(|t| t.delta_e00_booth_emitted).reduce(f64::max),
            targets: result,
        };
        let stored_request =
            serde_json::to_value(&request).map_err(|e| LabError::Internal(format!("a verification request: {e}")))?;
        let result = serde_json::to_value(&verification)
            .map_err(|e| LabError::Internal(format!("a verification's result: {e}")))?;
        let vid = self
            .store()
            .insert_stimulus_set_verification(id, &request.coding, &request.client, &stored_request, &result)
            .await?;
        tracing::info!(
            stimulus_set = id,
            verification = vid,
            coding = request.coding,
            "stimulus set verified"
        );
        self.image_verifications(id)
            .await?
            .into_iter()
            .find(|v| v.id == vid)
            .ok_or_else(|| LabError::Internal(format!("verification {vid} vanished")))
    }

    /// A set's verifications, oldest first.
    pub async fn image_verifications(&self, id: i64) -> Result<Vec<StimulusSetVerificationRow>, LabError> {
        self.stimulus_set(id).await?;
        Ok(self.store().stimulus_set_verifications(id).await?)
    }

    /// A verification's luminance profile along the targets, as SVG: the
    /// booth (through the set's gamut policy), the intended and the emitted Y.
    pub async fn image_verification_chart(&self, id: i64, verification: i64) -> Result<String, LabError> {
        let v = self
            .image_verifications(id)
            .await?
            .into_iter()
            .find(|v| v.id == verification)
            .ok_or_else(|| LabError::NotFound(format!("stimulus set {id} has no verification {verification}")))?;
        let targets: Vec<TargetVerification> = serde_json::from_value(v.result["targets"].clone())
            .map_err(|e| LabError::Internal(format!("verification {verification}'s targets: {e}")))?;
        tokio::task::spawn_blocking(move || profile_chart(&v.coding, &targets))
            .await
            .map_err(|e| LabError::Internal(e.to_string()))?
    }

    /// The XYZ of a measurement of the display showing set `set`'s image
    /// (see the module doc), in the profile's observer.
    async fn display_measurement(&self, set: &StimulusSetRow, id: i64, field: &str) -> Result<[f64; 3], LabError> {
        let m = self.measurement(id).await.map_err(|e| match e {
            LabError::NotFound(m) => LabError::Invalid(format!("field `{field}`: {m}")),
            other => other,
        })?;
        if let (Some(scene), Some(target)) = (&m.summary.scene, &m.summary.target) {
            return Err(LabError::Invalid(format!(
                "field `{field}`: measurement {id} is of the booth's scene {scene}/{target}, not of the display"
            )));
        }
        if m.summary.created_at < set.created_at {
            return Err(LabError::Invalid(format!(
                "field `{field}`: measurement {id} was taken before stimulus set {} was made, so not of its image",
                set.id
            )));
        }
        let wanted = hold_purpose(set.id);
        if m.summary.hold.as_ref().map(|h| h.purpose.as_str()) != Some(wanted.as_str()) {
            return Err(LabError::Invalid(format!(
                "field `{field}`: measurement {id} was not taken under the hold “{wanted}”, so nothing says the \
                 display showed the image: measure while the set's page shows it (or take POST /api/instrument/hold \
                 {{\"purpose\": \"{wanted}\"}} and name it in each measurement)"
            )));
        }
        if m.summary.state != MeasurementState::Complete {
            return Err(LabError::Conflict(format!(
                "field `{field}`: measurement {id} is {}: only a complete measurement verifies a target",
                m.summary.state.as_str()
            )));
        }
        let profile = self.display_profile(set.profile_id).await?.profile;
        measured_xyz(&m, profile.observer)
            .map_err(|e| LabError::Invalid(format!("field `{field}`: {e}")))?
            .map(|x| x.to_array())
            .ok_or_else(|| LabError::Conflict(format!("field `{field}`: measurement {id} holds no colour")))
    }
}

/// The luminance profile along the targets.
fn profile_chart(coding: &str, targets: &[TargetVerification]) -> Result<String, LabError> {
    use crate::charts::LineSeriesData;
    let ids: Vec<String> = targets.iter().map(|t| t.id.clone()).collect();
    let series = |name: &str, y: &dyn Fn(&TargetVerification) -> Option<f64>| LineSeriesData {
        name: name.into(),
        points: targets
            .iter()
            .enumerate()
            .filter_map(|(i, t)| y(t).map(|v| ((i + 1) as f64, v)))
            .collect(),
        errors: None,
    };
    let mut lines = vec![
        series("intended (the image as asked for)", &|t| Some(t.intended[1])),
        series("emitted (measured on the display)", &|t| Some(t.emitted[1])),
    ];
    let booth = series("booth (measured, through the set's gamut policy)", &|t| {
        t.booth_xyz.map(|b| b[1])
    });
    if !booth.points.is_empty() {
        lines.insert(0, booth);
    }
    crate::charts::profile_chart(
        &format!("{coding} on the display at the scene's targets"),
        &ids,
        "target",
        "luminance Y (cd/m²)",
        &lines,
    )
    .map_err(LabError::Internal)
}
