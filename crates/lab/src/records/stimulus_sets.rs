//! Image stimulus sets (issue 48, part 2): the codings of one rendered
//! image converted through a stored display profile with one gamut policy
//! for one output method (`lightbooth_science::display::image_set`), stored
//! with where they came from, and served to the pages as what the display
//! will be asked to show.
//!
//! - **From the daemon's camera images** ([`StimulusSetRequest`]): any
//!   image of a set rendered from the same paths names the set; every
//!   coding of it is converted, against the set's reference. The images are
//!   in the daemon's memory; the stimulus set is stored, so it outlives
//!   them (its provenance keeps the render, scene and image settings).
//! - **From an uploaded OpenEXR** ([`ExrUpload`]): a layered file (a layer
//!   per coding with `X`, `Y`, `Z`, as `lightbooth render --image-coding`
//!   and `GET /api/images/{id}/set.exr` write it) with the uploader's stated
//!   provenance, kept with the file's SHA-256 and size.
//! - **Checked before any work**: the profile exists, passed its checks and
//!   knows its primaries' colour (not a luminance meter's γ-only profile);
//!   its observer is the images' (XYZ of two observers are not comparable);
//!   the image has at most [`MAX_SET_PIXELS`] pixels and the set at most
//!   [`MAX_SET_BYTES`] of per-pixel data. Each refusal names the field.
//! - **Stored, not recomputed**: the report, each coding's linear RGB after
//!   the gamut policy (the pages apply the profile's γ and the output method
//!   themselves, as for the pie) and each coding's ΔE00 map against the
//!   reference as the display shows both at the set's output; the map's
//!   PNG is encoded from the stored values when asked for, on the blocking
//!   pool.

use std::path::Path;

use serde::Deserialize;
use sha2::{Digest, Sha256};

use crate::error::LabError;
use crate::LabHandle;
use lightbooth_science::colorimetry::Observer;
use lightbooth_science::display::image_set::{image_set, output_index, ImageSet, OUTPUTS};
use lightbooth_science::display::stimulus::GamutPolicy;
use lightbooth_science::display::{DisplayProfile, Emission};
use lightbooth_store::{NewStimulusSet, StimulusSetBlob, StimulusSetRow};

/// Pixels of one image a set may have (1920 × 1080).
pub const MAX_SET_PIXELS: u64 = 1920 * 1080;
/// Bytes of per-pixel data one set may store (linear RGB and a ΔE00 map
/// per coding: 16 bytes per pixel and coding).
pub const MAX_SET_BYTES: u64 = 256 << 20;

/// A set from the daemon's camera images: `POST /api/stimulus-sets`.
#[derive(Clone, Debug, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct StimulusSetRequest {
    /// Any image of a set of codings rendered from the same paths
    /// (`POST /api/renders/{id}/images` with `codings`): every coding of
    /// the set is converted, against its reference.
    pub image_id: i64,
    /// The stored display profile to convert through.
    pub display_profile_id: i64,
    /// `scale` (the default, as an experiment's: every colour darkened by
    /// one factor until all fit), `clip` or `fail`.
    #[cfg_attr(feature = "openapi", schema(pattern = "^(scale|clip|fail)$"))]
    pub gamut: Option<String>,
    /// `noisy_bit` (the default, as an experiment's), `8bit`, `10bit` or `12bit`.
    #[cfg_attr(feature = "openapi", schema(pattern = "^(8bit|noisy_bit|10bit|12bit)$"))]
    pub output: Option<String>,
}

/// A set from an uploaded layered OpenEXR: `POST /api/stimulus-sets/exr`.
#[derive(Clone, Debug)]
pub struct ExrUpload {
    pub bytes: Vec<u8>,
    /// What the file is, in the uploader's words (who rendered it, how);
    /// required, stored as text.
    pub provenance: String,
    pub display_profile_id: i64,
    pub gamut: Option<String>,
    pub output: Option<String>,
}

/// The checked profile, policy and output of a request.
struct Conversion {
    profile_id: i64,
    profile: DisplayProfile,
    policy: GamutPolicy,
    output: String,
}

/// One image's codings as XYZ, with where they came from.
struct Source {
    source: &'static str,
    render_id: Option<i64>,
    scene: Option<String>,
    provenance: serde_json::Value,
    width: u32,
    height: u32,
    observer: Observer,
    codings: Vec<(String, Vec<[f64; 3]>)>,
    reference: usize,
}

impl LabHandle {
    /// Makes and stores a set from the camera images this daemon keeps.
    pub async fn create_stimulus_set(&self, request: StimulusSetRequest) -> Result<StimulusSetRow, LabError> {
        let conversion = self
            .conversion(
                request.display_profile_id,
                request.gamut.as_deref(),
                request.output.as_deref(),
            )
            .await?;
        let (info, image) = self.renders()?.images().data(request.image_id).map_err(|e| match e {
            LabError::NotFound(m) => LabError::NotFound(format!("field `image_id`: {m}")),
            LabError::Conflict(m) => LabError::Conflict(format!("field `image_id`: {m}")),
            other => other,
        })?;
        let first = &image.set().images[0];
        let (width, height, observer, count) = (first.width, first.height, first.observer, image.set().images.len());
        check_size(width, height, count)?;
        let reference = image.set().reference;
        // Each coding's XYZ per pixel, off the async runtime.
        let codings = tokio::task::spawn_blocking(move || {
            image
                .set()
                .images
                .iter()
                .map(|img| {
                    let k = img.xyz_index();
                    let (x, y, z) = (img.plane(k), img.plane(k + 1), img.plane(k + 2));
                    let xyz = x
                        .iter()
                        .zip(&y)
                        .zip(&z)
                        .map(|((x, y), z)| [*x as f64, *y as f64, *z as f64])
                        .collect();
                    (img.coding.to_string(), xyz)
                })
                .collect::<Vec<_>>()
        })
        .await
        .map_err(|e| LabError::Internal(e.to_string()))?;
        let source = Source {
            source: "render",
            render_id: Some(info.render_id),
            scene: Some(info.scene.clone()),
            provenance: serde_json::json!({
                "image_ids": info.set,
                "reference_image_id": info.reference_id,
                "settings": info.settings,
                "paths": info.paths,
                "passes": info.passes,
                "stop": info.stop,
            }),
            width,
            height,
            observer,
            codings,
            reference,
        };
        self.store_set(source, conversion).await
    }

    /// Makes and stores a set from an uploaded layered OpenEXR.
    pub async fn create_stimulus_set_from_exr(&self, upload: ExrUpload) -> Result<StimulusSetRow, LabError> {
        if upload.provenance.trim().is_empty() {
            return Err(LabError::Invalid(
                "field `provenance`: say what the file is (who rendered it, with what); it is stored with the set"
                    .into(),
            ));
        }
        let conversion = self
            .conversion(
                upload.display_profile_id,
                upload.gamut.as_deref(),
                upload.output.as_deref(),
            )
            .await?;
        let observer = conversion.profile.observer;
        let sha256: String = Sha256::digest(&upload.bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        let size = upload.bytes.len();
        let provenance = upload.provenance.clone();
        let layers = tokio::task::spawn_blocking(move || {
            use crate::export::image::{create_private_folder, export_folder};
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_nanos())
                .unwrap_or(0);
            let dir = export_folder(&std::env::temp_dir(), std::process::id(), 0, nanos);
            create_private_folder(&dir).map_err(LabError::Internal)?;
            let path = dir.join("upload.exr");
            let read = std::fs::write(&path, &upload.bytes)
                .map_err(|e| LabError::Internal(format!("{}: {e}", path.display())))
                .and_then(|()| read_layers(&path, observer));
            let _ = std::fs::remove_dir_all(&dir);
            read
        })
        .await
        .map_err(|e| LabError::Internal(e.to_string()))??;
        let (layers, reference_name) = layers;
        let (w, h) = (layers[0].1.width, layers[0].1.height);
        check_size(w, h, layers.len())?;
        let reference = reference_name
            .as_ref()
            .and_then(|r| layers.iter().position(|(c, _)| c == r))
            .unwrap_or(layers.len() - 1);
        let names: Vec<String> = layers.iter().map(|(c, _)| c.clone()).collect();
        let source = Source {
            source: "upload",
            render_id: None,
            scene: None,
            provenance: serde_json::json!({
                "stated": provenance,
                "file_sha256": sha256,
                "file_bytes": size,
                "layers": names,
                "xyz_from": layers[0].1.source,
            }),
            width: w,
            height: h,
            observer,
            codings: layers.into_iter().map(|(c, img)| (c, img.xyz)).collect(),
            reference,
        };
        self.store_set(source, conversion).await
    }

    /// A stored set, without its per-pixel data.
    pub async fn stimulus_set(&self, id: i64) -> Result<StimulusSetRow, LabError> {
        self.store()
            .get_stimulus_set(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no stimulus set {id}")))
    }

    /// Every stored set, newest first.
    pub async fn stimulus_sets(&self) -> Result<Vec<StimulusSetRow>, LabError> {
        Ok(self.store().list_stimulus_sets().await?)
    }

    /// A coding's linear RGB after the gamut policy: f32 little-endian, R G
    /// B per pixel, rows top to bottom (what the display is asked to show,
    /// before the profile's γ and the output method).
    pub async fn stimulus_set_linear(&self, id: i64, coding: &str) -> Result<Vec<u8>, LabError> {
        let (row, index) = self.set_coding(id, coding).await?;
        let blob = self.blob(id, StimulusSetBlob::Linear).await?;
        let n = row.width as usize * row.height as usize * 12;
        Ok(blob[index * n..(index + 1) * n].to_vec())
    }

    /// A coding's ΔE00 map against the reference, as the display shows both
    /// at the set's output: a false-colour PNG (viridis from 0 to the set's
    /// largest ΔE00 rounded up to 1, 2, 2.5 or 5 × 10ᵏ, the same scale for
    /// every coding of the set: the report's `delta_e_map_scale_max`) and
    /// that scale's top.
    pub async fn stimulus_set_delta_e_png(&self, id: i64, coding: &str) -> Result<(Vec<u8>, f64), LabError> {
        let (row, index) = self.set_coding(id, coding).await?;
        let blob = self.blob(id, StimulusSetBlob::ShownDeltaE).await?;
        let top = row.report["delta_e_map_scale_max"]
            .as_f64()
            .ok_or_else(|| LabError::Internal(format!("stimulus set {id}'s report has no delta_e_map_scale_max")))?;
        tokio::task::spawn_blocking(move || {
            let all = f32s(&blob);
            let n = row.width as usize * row.height as usize;
            let rgb: Vec<u8> = all[index * n..(index + 1) * n]
                .iter()
                .flat_map(|v| lightbooth_science::display::stimulus_files::viridis(*v as f64 / top))
                .collect();
            let png = crate::render::image_views::rgb_png(row.width, row.height, &rgb)?;
            Ok((png, top))
        })
        .await
        .map_err(|e| LabError::Internal(e.to_string()))?
    }

    async fn set_coding(&self, id: i64, coding: &str) -> Result<(StimulusSetRow, usize), LabError> {
        let row = self.stimulus_set(id).await?;
        let index = row.codings.iter().position(|c| c == coding).ok_or_else(|| {
            LabError::NotFound(format!(
                "stimulus set {id} has no coding `{coding}` (it has {})",
                row.codings.join(", ")
            ))
        })?;
        Ok((row, index))
    }

    async fn blob(&self, id: i64, which: StimulusSetBlob) -> Result<Vec<u8>, LabError> {
        self.store()
            .stimulus_set_blob(id, which)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no stimulus set {id}")))
    }

    /// The profile, policy and output of a request, checked.
    async fn conversion(
        &self,
        profile_id: i64,
        gamut: Option<&str>,
        output: Option<&str>,
    ) -> Result<Conversion, LabError> {
        let policy: GamutPolicy = gamut
            .unwrap_or("scale")
            .parse()
            .map_err(|e| LabError::Invalid(format!("field `gamut`: {e}")))?;
        let output = output.unwrap_or("noisy_bit").to_string();
        output_index(&output).map_err(|e| LabError::Invalid(format!("field `output`: {e}")))?;
        let row = self.store().get_display_profile(profile_id).await?.ok_or_else(|| {
            LabError::NotFound(format!(
                "field `display_profile_id`: there is no display profile {profile_id} (calibrate the display first: /calibrate)"
            ))
        })?;
        if !row.failures.is_empty() {
            return Err(LabError::Conflict(format!(
                "field `display_profile_id`: profile {profile_id} failed its checks ({}); calibrate the display again",
                row.failures.join("; ")
            )));
        }
        if let Emission::Luminance { .. } = row.profile.emission {
            return Err(LabError::Conflict(format!(
                "field `display_profile_id`: profile {profile_id} was calibrated with a luminance meter (γ only, no \
                 primaries' colour) and cannot convert colours; calibrate with a colorimeter or a spectroradiometer"
            )));
        }
        Ok(Conversion {
            profile_id,
            profile: row.profile,
            policy,
            output,
        })
    }

    /// Converts and stores a set.
    async fn store_set(&self, source: Source, c: Conversion) -> Result<StimulusSetRow, LabError> {
        if source.observer != c.profile.observer {
            return Err(LabError::Conflict(format!(
                "field `display_profile_id`: profile {} is in the {} observer and the images in the {}; \
                 XYZ of two observers are not comparable: use a profile fitted in the images' observer",
                c.profile_id, c.profile.observer, source.observer
            )));
        }
        let output = output_index(&c.output).map_err(LabError::Invalid)?;
        let profile = c.profile.clone();
        let policy = c.policy;
        let codings = source.codings;
        let reference = source.reference;
        let (set, names, (linear, shown_delta_e)) = tokio::task::spawn_blocking(move || {
            let set = image_set(&profile, &codings, reference, policy)
                .map_err(|e| LabError::Invalid(format!("field `gamut`: {e}")))?;
            let bytes = per_pixel(&set, output);
            Ok::<_, LabError>((set, codings.into_iter().map(|(c, _)| c).collect::<Vec<_>>(), bytes))
        })
        .await
        .map_err(|e| LabError::Internal(e.to_string()))??;
        let mut report = serde_json::to_value(&set).map_err(|e| LabError::Internal(format!("a set's report: {e}")))?;
        // The maps' one scale: 0 to the set's largest ΔE00 at its output,
        // rounded up to 1, 2, 2.5 or 5 × 10ᵏ.
        let largest = set
            .shown_delta_e
            .iter()
            .flat_map(|per_output| per_output[output].iter())
            .fold(0.0f32, |m, v| m.max(*v));
        report["delta_e_map_scale_max"] = crate::compare::image_map::nice_ceiling(largest as f64).into();
        let new = NewStimulusSet {
            booth: self.booth().clone(),
            source: source.source,
            render_id: source.render_id,
            scene: source.scene,
            provenance: source.provenance,
            profile_id: c.profile_id,
            policy: serde_json::to_value(c.policy)
                .ok()
                .and_then(|v| v.as_str().map(String::from))
                .unwrap_or_default(),
            output: c.output,
            width: source.width,
            height: source.height,
            reference: names[reference].clone(),
            codings: names,
            observer: source.observer.to_string(),
            report,
            linear,
            shown_delta_e,
        };
        let id = self.store().insert_stimulus_set(&new).await?;
        tracing::info!(
            stimulus_set = id,
            codings = new.codings.join(","),
            profile = c.profile_id,
            "stimulus set stored"
        );
        self.stimulus_set(id).await
    }
}

/// Refuses an image larger than the limits (see the module doc).
fn check_size(width: u32, height: u32, codings: usize) -> Result<(), LabError> {
    let pixels = width as u64 * height as u64;
    let bytes = pixels * codings as u64 * 16;
    if pixels > MAX_SET_PIXELS || bytes > MAX_SET_BYTES {
        return Err(LabError::Invalid(format!(
            "the image is {width} × {height} in {codings} codings ({} MB of per-pixel data); a stimulus set holds at \
             most {MAX_SET_PIXELS} pixels and {} MB: render a smaller image",
            bytes >> 20,
            MAX_SET_BYTES >> 20
        )));
    }
    Ok(())
}

/// The set's linear RGB and its ΔE00 maps at output `o`, as stored.
fn per_pixel(set: &ImageSet, o: usize) -> (Vec<u8>, Vec<u8>) {
    debug_assert!(o < OUTPUTS.len());
    let linear = set
        .linear
        .iter()
        .flatten()
        .flat_map(|rgb| rgb.iter().flat_map(|v| v.to_le_bytes()))
        .collect();
    let maps = set
        .shown_delta_e
        .iter()
        .flat_map(|per_output| per_output[o].iter().flat_map(|v| v.to_le_bytes()))
        .collect();
    (linear, maps)
}

fn f32s(bytes: &[u8]) -> Vec<f32> {
    bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

type Layers = (
    Vec<(String, lightbooth_report::export::exr_read::XyzImage)>,
    Option<String>,
);

/// An uploaded file's coding layers, or why not (a single image is refused:
/// a set needs its codings).
fn read_layers(path: &Path, observer: Observer) -> Result<Layers, LabError> {
    match lightbooth_report::export::exr_read::read_xyz_exr_layers(path, observer) {
        Ok(Some(l)) => Ok((l.layers, l.reference)),
        Ok(None) => Err(LabError::Invalid(
            "the body: an OpenEXR file without coding layers (`<coding>.X`, `.Y`, `.Z`); a stimulus set needs the \
             codings of one image, as `lightbooth render --image-coding a,b` or GET /api/images/{id}/set.exr write them"
                .into(),
        )),
        Err(e) => Err(LabError::Invalid(format!("the body: {e}"))),
    }
}
