//! A scene's CIELAB reference white, from its `[cielab_white]` declaration
//! (see [`lightbooth_render::scene`]): the same rule for the study and the
//! daemon's comparisons, so a scene's comparisons never depend on
//! measurement order; and a stored measurement's XYZ, for both.
//!
//! - A target white (`target`, optionally `scene`) names a scene file and a
//!   target; [`resolve_white`] finds its newest complete measurement in the
//!   caller's booth (or, until there is one, the caller's rendering of it,
//!   and says so) — the one white policy of the daemon and the study.
//! - A diffuser white (`light_on_perfect_diffuser`) and an explicit `xyz`
//!   are computed here from the scene alone.

use std::path::{Path, PathBuf};

use lightbooth_render::scene::CielabWhite;
use lightbooth_render::{self as render, Scene};
use lightbooth_science::colorimetry::{xyz_from_radiance, Observer, Xyz};
use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};
use lightbooth_store::{Booth, MeasurementDetail, Store, StoreError};

/// Where a scene's white comes from, resolved.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneWhite {
    /// The newest measurement (else the converged rendering) of `target` in
    /// the scene file `scene_path` (scene id `scene_id`, its file stem).
    Target {
        scene_id: String,
        scene_path: PathBuf,
        target: String,
    },
    /// A white computed from the scene file alone; `source` says how.
    Fixed { xyz: Xyz, source: String },
}

impl SceneWhite {
    /// Whether a measurement of `scene_id`/`target` is this white's source.
    pub fn is_target(&self, scene_id: &str, target: &str) -> bool {
        matches!(self, SceneWhite::Target { scene_id: s, target: t, .. } if s == scene_id && t == target)
    }
}

/// The white `scene` (loaded from `scene_path`) declares, with `observer`
/// for a computed one. A scene without `[cielab_white]`, or one naming a
/// scene file or target that does not exist, is an error naming the file
/// and key.
pub fn scene_white(scene_path: &Path, scene: &Scene, observer: Observer) -> Result<SceneWhite, String> {
    let file = scene_path.display();
    let declared = scene.cielab_white.as_ref().ok_or_else(|| {
        format!(
            "{file}: cielab_white: the scene declares no CIELAB reference white; add a [cielab_white] table \
             (target = \"ID\", light_on_perfect_diffuser = true with point and normal, or xyz = [X, Y, Z])"
        )
    })?;
    match declared {
        CielabWhite::Target { scene: None, target } => Ok(SceneWhite::Target {
            scene_id: scene_id(scene_path),
            scene_path: scene_path.to_path_buf(),
            target: target.clone(),
        }),
        CielabWhite::Target {
            scene: Some(other),
            target,
        } => {
            let other_path = scene_path.with_file_name(format!("{other}.toml"));
            let other_scene = render::load_scene(&other_path)
                .map_err(|e| format!("{file}: cielab_white.scene: `{other}` ({}): {e}", other_path.display()))?;
            if other_scene.target(target).is_none() {
                return Err(format!(
                    "{file}: cielab_white.target: scene `{other}` has no target `{target}` (targets: {})",
                    other_scene.targets().join(", ")
                ));
            }
            Ok(SceneWhite::Target {
                scene_id: other.clone(),
                scene_path: other_path,
                target: target.clone(),
            })
        }
        CielabWhite::LightOnPerfectDiffuser { point, normal } => {
            let radiance = scene.light_on_perfect_diffuser(*point, *normal);
            let xyz = xyz_from_radiance(&radiance, observer).map_err(|e| format!("{file}: cielab_white: {e}"))?;
            Ok(SceneWhite::Fixed {
                xyz,
                source: format!(
                    "the scene's light on a perfect diffuser at ({:.4}, {:.4}, {:.4}) m ({})",
                    point.x,
                    point.y,
                    point.z,
                    scene_id(scene_path)
                ),
            })
        }
        CielabWhite::Xyz(xyz) => Ok(SceneWhite::Fixed {
            xyz: Xyz::from_array(*xyz),
            source: format!("XYZ stated in the scene file ({})", scene_id(scene_path)),
        }),
    }
}

/// A rendering of a target white: what a caller of [`resolve_white`] falls
/// back on while the white is not measured in its booth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RenderedWhite {
    /// The daemon's: the `spectral` coding of render `render_id`, a complete
    /// render at the daemon's comparison settings (never one rendered for
    /// the asking).
    Render { render_id: i64, xyz: Xyz },
    /// The study's: its converged reference rendering.
    Reference(Xyz),
}

/// Why [`resolve_white`] (or [`measured_in_booth`]) found no white.
#[derive(Debug)]
pub enum WhiteError<E> {
    /// The store failed looking for the white's measurement.
    Store(StoreError),
    /// The white's newest measurement in the booth gives no XYZ in the
    /// observer ([`measured_xyz`]'s error, naming the measurement).
    Measurement(String),
    /// The caller's fallback failed (its own error, e.g. "render it first").
    Fallback(E),
}

impl<E: From<StoreError>> WhiteError<E> {
    /// The caller's error: a store error through `From`, a measurement's
    /// through `measurement`, the fallback's as it was.
    pub fn into_error(self, measurement: impl FnOnce(String) -> E) -> E {
        match self {
            WhiteError::Store(e) => e.into(),
            WhiteError::Measurement(m) => measurement(m),
            WhiteError::Fallback(e) => e,
        }
    }
}

/// The newest complete measurement of `scene_id`/`target` taken in `booth`
/// (never another booth's) and its XYZ with `observer`; `None` when there
/// is none, or the newest holds no colour yet ([`measured_xyz`]).
pub async fn measured_in_booth<E>(
    store: &Store,
    booth: &Booth,
    scene_id: &str,
    target: &str,
    observer: Observer,
) -> Result<Option<(MeasurementDetail, Xyz)>, WhiteError<E>> {
    let Some(m) = store
        .latest_complete_in_booth(scene_id, target, booth)
        .await
        .map_err(WhiteError::Store)?
    else {
        return Ok(None);
    };
    Ok(measured_xyz(&m, observer)
        .map_err(WhiteError::Measurement)?
        .map(|xyz| (m, xyz)))
}

/// The CIELAB white `white` resolves to now, and its source (the
/// `white_source` of a comparison row and of a study's scene): the one
/// white policy of the daemon's comparisons and of the study.
///
/// - A fixed white (a diffuser's, an explicit XYZ) is its own.
/// - A target white is its newest complete measurement taken in the booth
///   of `measured_in` (never another booth's): "measurement ID
///   (SCENE/TARGET)".
/// - Else the caller's `rendered(scene id, scene file, target)`: "render ID
///   spectral (SCENE/TARGET; not yet measured)" (the daemon's latest
///   render), "reference render (SCENE/TARGET; not measured)" (the study's
///   reference render). With `measured_in` `None` (the study against its
///   reference renders: no measurement is consulted) the fallback answers
///   alone and its source does not mention measuring: "reference render
///   (SCENE/TARGET)".
pub async fn resolve_white<E>(
    white: &SceneWhite,
    measured_in: Option<(&Store, &Booth)>,
    observer: Observer,
    rendered: impl AsyncFnOnce(&str, &Path, &str) -> Result<RenderedWhite, E>,
) -> Result<(Xyz, String), WhiteError<E>> {
    let (scene_id, scene_path, target) = match white {
        SceneWhite::Fixed { xyz, source } => return Ok((*xyz, source.clone())),
        SceneWhite::Target {
            scene_id,
            scene_path,
            target,
        } => (scene_id, scene_path, target),
    };
    if let Some((store, booth)) = measured_in {
        if let Some((m, xyz)) = measured_in_booth(store, booth, scene_id, target, observer).await? {
            return Ok((xyz, format!("measurement {} ({scene_id}/{target})", m.summary.id)));
        }
    }
    let unmeasured = measured_in.is_some();
    Ok(
        match rendered(scene_id, scene_path, target)
            .await
            .map_err(WhiteError::Fallback)?
        {
            RenderedWhite::Render { render_id, xyz } => {
                let note = if unmeasured { "; not yet measured" } else { "" };
                (xyz, format!("render {render_id} spectral ({scene_id}/{target}{note})"))
            }
            RenderedWhite::Reference(xyz) => {
                let note = if unmeasured { "; not measured" } else { "" };
                (xyz, format!("reference render ({scene_id}/{target}{note})"))
            }
        },
    )
}

/// A scene's id: its file stem (as the daemon names scenes).
pub fn scene_id(path: &Path) -> String {
    path.file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or_default()
        .to_string()
}

/// The XYZ of a stored measurement's mean spectral radiance with
/// `observer`; `None` when the row holds no spectrum and no XYZ (a
/// measurement that never completed). A colorimeter's measurement (XYZ,
/// no spectrum) gives its XYZ only in the observer it was made in, and is
/// an error in another; a luminance meter's is an error. Used for the
/// truth of a study against measurements and for a comparison's white alike.
pub fn measured_xyz(m: &MeasurementDetail, observer: Observer) -> Result<Option<Xyz>, String> {
    let id = m.summary.id;
    let (Some(wl), Some(radiance)) = (&m.wavelength_nm, &m.radiance) else {
        let model = m.summary.instrument_model.as_deref().unwrap_or("instrument");
        return match (m.summary.xyz, m.summary.observer) {
            (Some(xyz), Some(own)) if own == observer => Ok(Some(Xyz::from_array(xyz))),
            (Some(_), Some(own)) => Err(format!(
                "measurement {id}: the {model} measured XYZ in the {own} observer, not in {observer}; a \
                 colorimeter's XYZ cannot be recomputed in another observer (use {own}, or measure with a \
                 spectroradiometer)"
            )),
            (None, Some(_)) if m.summary.state == lightbooth_store::MeasurementState::Complete => Err(format!(
                "measurement {id}: the {model} measured luminance only, no colour: this needs a colorimeter or a \
                 spectroradiometer"
            )),
            _ => Ok(None),
        };
    };
    let grid = Grid::from_wavelengths(wl.clone()).map_err(|e| format!("measurement {id}: {e}"))?;
    let s = Spectrum::new(grid, SpectralUnit::SpectralRadiance, radiance.clone())
        .map_err(|e| format!("measurement {id}: {e}"))?;
    xyz_from_radiance(&s, observer)
        .map(Some)
        .map_err(|e| format!("measurement {id}: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{queued_measurement, store_in};
    use lightbooth_store::{Average, Store};

    /// A queued measurement of WHITE's Spectralon, completed at once with
    /// `radiance` on `wavelength_nm` (what the store holds of an average;
    /// the instrument's own figures are left zero, unused here).
    async fn stored_average(store: &Store, wavelength_nm: Vec<f64>, radiance: Vec<f64>) -> i64 {
        let id = queued_measurement(store, Some(("white", "patch"))).await;
        store.mark_running(id, None).await.unwrap();
        let len = radiance.len();
        let average = Average {
            wavelength_nm,
            radiance,
            radiance_sd: vec![0.0; len],
            luminance_cd_m2: 0.0,
            x: Some(0.0),
            y: Some(0.0),
            luminance_cv: 0.0,
            xyz: None,
            observer: None,
        };
        store.complete_measurement(id, &average).await.unwrap();
        id
    }

    /// An equal-energy spectrum has CIE 1931 chromaticity (1/3, 1/3): the
    /// colour-matching functions are normalised to equal integrals (CIE
    /// 15:2004, §7.1, illuminant E; the tabulated 1 nm sums agree within
    /// 0.04 %), here over the PR-650's 380–780 nm at 4 nm, which leaves out
    /// < 0.01 % of each integral. Its luminance is
    /// Km·L·∫ȳ dλ with Km = 683 lm/W and ∫ȳ dλ = 106.857 nm (the sum of the
    /// 1 nm table, CIE 15:2004 Table T.4).
    #[tokio::test]
    async fn an_equal_energy_measurement_has_the_chromaticity_of_illuminant_e() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let wavelength_nm: Vec<f64> = (0..101).map(|i| 380.0 + 4.0 * f64::from(i)).collect();
        let radiance = 1e-3; // W/(sr·m²·nm)
        let id = stored_average(&store, wavelength_nm, vec![radiance; 101]).await;
        let detail = store.get_measurement(id).await.unwrap().unwrap();

        let xyz = measured_xyz(&detail, Observer::Cie1931).unwrap().expect("a spectrum");
        let lightbooth_science::colorimetry::Chromaticity { x, y } = xyz.chromaticity();
        assert!(
            (x - 1.0 / 3.0).abs() < 2e-4 && (y - 1.0 / 3.0).abs() < 2e-4,
            "x, y = {x}, {y}"
        );
        let luminance = 683.0 * radiance * 106.857;
        assert!(
            (xyz.y / luminance - 1.0).abs() < 2e-3,
            "Y = {} cd/m² against {luminance}",
            xyz.y
        );
    }

    #[tokio::test]
    async fn a_measurement_without_a_spectrum_has_no_xyz_and_a_bad_one_names_itself() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let queued = queued_measurement(&store, None).await;
        let detail = store.get_measurement(queued).await.unwrap().unwrap();
        assert_eq!(measured_xyz(&detail, Observer::JuddVos), Ok(None));

        // Wavelengths that do not increase: no grid, and the error says which row.
        let id = stored_average(&store, vec![500.0, 400.0], vec![1.0, 1.0]).await;
        let detail = store.get_measurement(id).await.unwrap().unwrap();
        let error = measured_xyz(&detail, Observer::JuddVos).unwrap_err();
        assert!(error.starts_with(&format!("measurement {id}: ")), "{error}");
    }

    /// A colorimeter's measurement (issue 33): the samples' own XYZ stored
    /// as they came, the average's XYZ in the colorimeter's observer (the
    /// daemon's is another), no spectrum; its XYZ is given in its own
    /// observer only, and a luminance meter's measurement is no colour.
    #[tokio::test]
    async fn a_colorimeters_xyz_is_kept_in_its_observer_and_refused_in_another() {
        use crate::measure::recorder::{average_row, comparable_xyz, sample_row};
        use lightbooth_instrument::{average_samples, InstrumentInfo, Reading, Sample};
        use lightbooth_science::spectrum::Grid;
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let info = InstrumentInfo {
            model: "ColorCAL MkII".into(),
            serial: None,
            firmware: None,
            grid: Grid::pr650(),
        };
        let reading = Reading::Tristimulus {
            observer: Observer::Cie1931,
        };
        let samples: Vec<Sample> = [[40.0, 50.0, 10.0], [44.0, 54.0, 12.0]]
            .into_iter()
            .enumerate()
            .map(|(index, xyz)| Sample {
                index,
                time: std::time::SystemTime::now(),
                code: lightbooth_instrument::pr650::codes::quality_code(0),
                radiance: None,
                luminance: Some(xyz[1]),
                instrument_xyz: Some(xyz),
            })
            .collect();
        let id = queued_measurement(&store, Some(("white", "patch"))).await;
        store.mark_running(id, None).await.unwrap();
        for s in &samples {
            store.insert_sample(id, &sample_row(s, reading)).await.unwrap();
        }
        let avg = average_samples(info, reading, samples).unwrap();
        // Compared in its own observer whatever the daemon's.
        for daemon in [Observer::Cie1931, Observer::JuddVos] {
            let (xyz, observer) = comparable_xyz(&avg, daemon).unwrap();
            assert_eq!((xyz.to_array(), observer), ([42.0, 52.0, 11.0], Observer::Cie1931));
        }
        // The daemon's observer is Judd–Vos: the stored XYZ stays CIE 1931's.
        store
            .complete_measurement(id, &average_row(&avg, Observer::JuddVos))
            .await
            .unwrap();
        let detail = store.get_measurement(id).await.unwrap().unwrap();
        assert_eq!(detail.summary.observer, Some(Observer::Cie1931));
        assert!(detail.radiance.is_none() && detail.wavelength_nm.is_none());
        assert_eq!(detail.samples[1].instrument_xyz, Some([44.0, 54.0, 12.0]));
        assert_eq!(detail.samples[1].luminance_cd_m2, Some(54.0));
        assert!(detail.samples.iter().all(|s| s.usable));
        assert_eq!(
            measured_xyz(&detail, Observer::Cie1931).unwrap().map(|x| x.to_array()),
            Some([42.0, 52.0, 11.0])
        );
        let error = measured_xyz(&detail, Observer::JuddVos).unwrap_err();
        assert!(
            error.starts_with(&format!(
                "measurement {id}: the instrument measured XYZ in the cie-1931 observer"
            )),
            "{error}"
        );

        // A luminance meter's: Y, no colour.
        let lum = queued_measurement(&store, None).await;
        store.mark_running(lum, None).await.unwrap();
        let average = Average {
            wavelength_nm: vec![],
            radiance: vec![],
            radiance_sd: vec![],
            luminance_cd_m2: 31.0,
            x: None,
            y: None,
            luminance_cv: 0.0,
            xyz: None,
            observer: Some(Observer::Cie1931),
        };
        store.complete_measurement(lum, &average).await.unwrap();
        let detail = store.get_measurement(lum).await.unwrap().unwrap();
        let error = measured_xyz(&detail, Observer::Cie1931).unwrap_err();
        assert!(error.contains("luminance only"), "{error}");
    }
}
