//! A scene's comparisons summarised per coding, as the API, its CSV and MAT
//! files and the scene's charts give them: the newest comparison of every
//! (target, coding) of one observer, and each coding's rms_rel and mean ± SD
//! of ΔE over the scene's targets ([`lightbooth_science::comparison::summarize`]).
//!
//! Only rows of the asked observer are summarised: rows of another (from a
//! run with another `--observer`) are never summarised or charted with them.
//!
//! Each coding's figures also carry their uncertainty
//! ([`lightbooth_science::uncertainty::propagate`]): the measurements' own
//! spectra drawn within their repeatability (the samples' SD/√n per
//! wavelength) and within the stated accuracy of the instrument that took
//! them ([`lightbooth_instrument::accuracy`]), the render's noise from its
//! standard error, so every ΔE, Δx, Δy, relative ΔY and rms_rel says
//! whether it is beyond the render's noise, beyond the measurement's
//! repeatability and beyond the instrument's stated accuracy. On the
//! simulated booth the measurement's truth is a converged render whose own
//! standard error (recorded with each measurement,
//! [`MeasurementDetail::simulated_truth_relative_se`]) is counted with the
//! repeatability and named in the result. The draws
//! are seeded by the scene, so a page shows the same intervals on every
//! load and every coding is judged against the same draws.

use std::collections::HashMap;

use lightbooth_instrument::accuracy::stated_accuracy_of;
use lightbooth_science::colorimetry::{Observer, Xyz};
use lightbooth_science::comparison::{mean_sd, summarize, PointDifference, SceneSummary};
use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};
use lightbooth_science::uncertainty::{
    propagate, MeasuredRenderedPoint, MonteCarloDraws, SceneComparison, SceneUncertainty,
};
use lightbooth_store::{ComparisonRow, MeasurementDetail, Store, StoreError};

/// One coding's figures of merit over a scene's targets.
#[derive(Clone)]
pub struct CodingSummary {
    /// The coding, as the rows name it (`rgb`, `nstep9`, …).
    pub coding: String,
    pub summary: SceneSummary,
    /// Mean Y ratio rendered/measured.
    pub mean_y_ratio: f64,
    /// The figures' uncertainty and claims, its points in the order of
    /// [`CodingSummary::rows`]; or why it could not be propagated (a
    /// colorimeter's measurement has no spectrum, measurements by two models
    /// share no stated accuracy…).
    pub uncertainty: Result<CodingUncertainty, String>,
}

/// A coding's propagated uncertainty, with what its points are.
#[derive(Clone)]
pub struct CodingUncertainty {
    /// The instrument model whose stated accuracy was propagated.
    pub instrument_model: String,
    pub propagated: SceneUncertainty,
    /// The comparison row (`rows`' id) of each point of `propagated`.
    pub row_ids: Vec<i64>,
}

/// A scene's newest comparisons and their summary per coding.
#[derive(Clone)]
pub struct SceneComparisons {
    pub scene: String,
    /// The observer of every row and summary.
    pub observer: Observer,
    /// One per coding, in the study's order ([`coding_order`]).
    pub codings: Vec<CodingSummary>,
    /// The newest comparison of every (target, coding).
    pub rows: Vec<ComparisonRow>,
}

/// The newest comparisons of `scene` with `observer`, summarised per coding.
pub async fn scene_comparisons(store: &Store, scene: &str, observer: Observer) -> Result<SceneComparisons, StoreError> {
    let rows: Vec<ComparisonRow> = store
        .latest_comparisons(scene)
        .await?
        .into_iter()
        .filter(|r| r.observer == observer)
        .collect();
    let mut measurements = HashMap::new();
    for r in &rows {
        if let std::collections::hash_map::Entry::Vacant(slot) = measurements.entry(r.measurement_id) {
            if let Some(m) = store.get_measurement(r.measurement_id).await? {
                slot.insert(m);
            }
        }
    }
    Ok(summarise(scene, observer, rows, &measurements))
}

/// The summary per coding of `rows` (all of `observer`), each with its
/// uncertainty from the `measurements` the rows compare.
fn summarise(
    scene: &str,
    observer: Observer,
    rows: Vec<ComparisonRow>,
    measurements: &HashMap<i64, MeasurementDetail>,
) -> SceneComparisons {
    // The store lists rows by target and coding name (nstep27 before
    // nstep3): each target's codings in the one coding order instead.
    let mut rows = rows;
    rows.sort_by(|a, b| {
        a.target
            .cmp(&b.target)
            .then_with(|| coding_order(&a.coding).cmp(&coding_order(&b.coding)))
    });
    let mut codings: Vec<String> = rows.iter().map(|r| r.coding.clone()).collect();
    codings.sort_by_key(|c| coding_order(c));
    codings.dedup();
    let codings = codings
        .into_iter()
        .map(|coding| {
            let of_coding: Vec<&ComparisonRow> = rows.iter().filter(|r| r.coding == coding).collect();
            let points: Vec<PointDifference> = of_coding.iter().map(|r| point_of(r)).collect();
            let (mean_y_ratio, _) = mean_sd(points.iter().map(|p| p.y_ratio));
            let uncertainty = coding_uncertainty(scene, observer, &of_coding, measurements);
            CodingSummary {
                coding,
                summary: summarize(&points),
                mean_y_ratio,
                uncertainty,
            }
        })
        .collect();
    SceneComparisons {
        scene: scene.to_string(),
        observer,
        codings,
        rows,
    }
}

/// The Monte Carlo propagation of one coding's rows (see the module doc).
fn coding_uncertainty(
    scene: &str,
    observer: Observer,
    rows: &[&ComparisonRow],
    measurements: &HashMap<i64, MeasurementDetail>,
) -> Result<CodingUncertainty, String> {
    let white = rows
        .first()
        .map(|r| Xyz::new(r.white_X, r.white_Y, r.white_Z))
        .ok_or("no rows")?;
    let mut points = Vec::with_capacity(rows.len());
    for r in rows {
        let id = r.measurement_id;
        let m = measurements
            .get(&id)
            .ok_or_else(|| format!("measurement {id} is gone"))?;
        points.push((m, Xyz::new(r.rendered_X, r.rendered_Y, r.rendered_Z), r.rendered_Y_se));
    }
    let (instrument_model, propagated) = propagate_measured(scene, observer, white, &points)?;
    Ok(CodingUncertainty {
        instrument_model,
        propagated,
        row_ids: rows.iter().map(|r| r.id).collect(),
    })
}

/// Propagates one coding's points, each (the measurement, the rendered XYZ,
/// its Y standard error), with the stated accuracy of the one model that
/// measured them all; seeded by the scene ([`seed_of`]). Gives
/// the model's name and the propagation, or why there is none.
pub fn propagate_measured(
    scene: &str,
    observer: Observer,
    white: Xyz,
    points: &[(&MeasurementDetail, Xyz, f64)],
) -> Result<(String, SceneUncertainty), String> {
    let mut model: Option<String> = None;
    let mut drawn = Vec::with_capacity(points.len());
    for (m, rendered, rendered_y_se) in points {
        let this_model = m
            .summary
            .instrument_model
            .clone()
            .unwrap_or_else(|| "unknown instrument".into());
        match &model {
            Some(first) if *first != this_model => {
                return Err(format!(
                    "the targets were measured with two models ({first} and {this_model}), whose stated \
                     accuracies are not one systematic error"
                ))
            }
            _ => model = Some(this_model),
        }
        drawn.push(measured_rendered_point(m, *rendered, *rendered_y_se)?);
    }
    let instrument_model = model.ok_or("no points")?;
    let accuracy = stated_accuracy_of(&instrument_model);
    let draws = MonteCarloDraws {
        seed: seed_of(scene),
        ..MonteCarloDraws::default()
    };
    let scene = SceneComparison {
        points: drawn,
        white,
        observer,
    };
    let propagated = propagate(&scene, &accuracy, draws).map_err(|e| e.to_string())?;
    Ok((instrument_model, propagated))
}

/// One point of a propagation: the measurement's mean spectrum with the
/// standard uncertainty of that mean per wavelength (the usable samples'
/// SD/√n), and the rendering with its standard error. The render's
/// standard error is known for Y; X and Z are given the same relative
/// error (an approximation: a path tracer's X, Y, Z errors are of one size
/// relative to their values when the light is near white). A measurement
/// a simulated instrument took carries its truth's relative SE, counted
/// with the repeatability ([`lightbooth_science::uncertainty`], "The
/// simulated truth"). Used by the scene pages and the study alike.
pub fn measured_rendered_point(
    m: &MeasurementDetail,
    rendered: Xyz,
    rendered_y_se: f64,
) -> Result<MeasuredRenderedPoint, String> {
    let id = m.summary.id;
    let (Some(wl), Some(mean), Some(sd)) = (&m.wavelength_nm, &m.radiance, &m.radiance_sd) else {
        return Err(format!(
            "measurement {id} has no spectrum with its spread (the {} measures no spectrum), so its \
             colorimetry cannot be drawn within its uncertainty",
            m.summary.instrument_model.as_deref().unwrap_or("instrument")
        ));
    };
    let n = m
        .samples
        .iter()
        .filter(|s| s.usable && s.radiance.is_some())
        .count()
        .max(1) as f64;
    let grid = Grid::from_wavelengths(wl.clone()).map_err(|e| format!("measurement {id}: {e}"))?;
    let measured = Spectrum::new(grid, SpectralUnit::SpectralRadiance, mean.clone())
        .map_err(|e| format!("measurement {id}: {e}"))?;
    let relative_se = if rendered.y > 0.0 {
        rendered_y_se / rendered.y
    } else {
        0.0
    };
    Ok(MeasuredRenderedPoint {
        measured,
        measured_standard_uncertainty: sd.iter().map(|v| v / n.sqrt()).collect(),
        rendered,
        rendered_standard_error: Xyz::new(rendered.x * relative_se, rendered_y_se, rendered.z * relative_se),
        // A simulated instrument's truth is a render: its SE, recorded with
        // the measurement, joins the budget (none for a real instrument).
        truth_relative_se: m.simulated_truth_relative_se,
    })
}

/// A fixed seed per scene (FNV-1a of its name, cut to 53 bits so that JSON
/// readers keep it exactly): the same draws on every load of a page, and
/// the same draws of the measurements for every coding of the scene, so
/// codings whose renderings are equal get equal claims (common random
/// numbers; a seed per coding once called one of two equal rms_rel beyond
/// the repeatability and the other not).
pub fn seed_of(scene: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in scene.bytes() {
        h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
    }
    h & ((1 << 53) - 1)
}

/// A stored comparison row as the figures of merit it holds.
fn point_of(r: &ComparisonRow) -> PointDifference {
    PointDifference {
        observer: r.observer,
        measured: Xyz::new(r.measured_X, r.measured_Y, r.measured_Z),
        rendered: Xyz::new(r.rendered_X, r.rendered_Y, r.rendered_Z),
        y_ratio: r.Y_ratio,
        xy_distance: r.xy_distance,
        de76: r.dE76,
        de00: r.dE00,
    }
}

/// The one order of codings (rgb, srgb, nstepN by N, spectral), defined
/// where codings are.
pub use lightbooth_render::coding_order;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{queued_measurement, store_in};
    use lightbooth_science::colorimetry::xyz_from_radiance;
    use lightbooth_store::Average;

    /// A measurement of WHITE's patch completed at once with a flat spectrum
    /// and no spread (a noiseless instrument), on the PR-650's 4 nm grid.
    async fn noiseless_measurement(store: &Store, truth_relative_se: Option<f64>) -> (i64, Xyz) {
        let id = queued_measurement(store, Some(("white", "patch"))).await;
        if let Some(se) = truth_relative_se {
            store.record_simulated_truth(id, se).await.unwrap();
        }
        store.mark_running(id, None).await.unwrap();
        let wavelength_nm: Vec<f64> = (0..101).map(|i| 380.0 + 4.0 * f64::from(i)).collect();
        let radiance = vec![0.01; 101];
        let s = Spectrum::new(
            Grid::from_wavelengths(wavelength_nm.clone()).unwrap(),
            SpectralUnit::SpectralRadiance,
            radiance.clone(),
        )
        .unwrap();
        let average = Average {
            wavelength_nm,
            radiance,
            radiance_sd: vec![0.0; 101],
            luminance_cd_m2: 0.0,
            x: Some(0.0),
            y: Some(0.0),
            luminance_cv: 0.0,
            xyz: None,
            observer: None,
        };
        store.complete_measurement(id, &average).await.unwrap();
        (id, xyz_from_radiance(&s, Observer::JuddVos).unwrap())
    }

    /// Issue 46, through the store and the lab: a noiseless simulated
    /// instrument's measurement of a truth converged to 0.1 %, and a
    /// rendering 0.15 % brighter (1.5 of the truth's SEs, the "Y ratio
    /// 1.001" of the report): with the truth's SE recorded it is within the
    /// repeatability and the noise, and the result names the SE; the same
    /// measurement without the record (as every simulated one was) calls
    /// the exact rendering beyond both.
    #[tokio::test]
    async fn a_simulated_measurements_truth_se_keeps_an_exact_rendering_within_the_budget() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let white = Xyz::new(95.0, 100.0, 108.9);
        let propagated = |id: i64, xyz: Xyz| {
            let store = store.clone();
            async move {
                let m = store.get_measurement(id).await.unwrap().unwrap();
                let rendered = xyz.scaled(1.0015);
                propagate_measured("white", Observer::JuddVos, white, &[(&m, rendered, 1e-5 * rendered.y)])
                    .unwrap()
                    .1
            }
        };
        let (simulated, xyz) = noiseless_measurement(&store, Some(1e-3)).await;
        let detail = store.get_measurement(simulated).await.unwrap().unwrap();
        assert_eq!(detail.simulated_truth_relative_se, Some(1e-3));
        let u = propagated(simulated, xyz).await;
        assert_eq!(u.simulated_truth_relative_se, Some(1e-3));
        let (noise, repeat) = (u.rms_rel.claims.beyond_noise, u.rms_rel.claims.beyond_repeatability);
        assert!(
            !noise && !repeat,
            "rms_rel beyond noise {noise}, repeatability {repeat}"
        );
        assert!(!u.points[0].de00.claims.beyond_repeatability);

        let (real, xyz) = noiseless_measurement(&store, None).await;
        let u = propagated(real, xyz).await;
        assert_eq!(u.simulated_truth_relative_se, None);
        assert!(u.rms_rel.claims.beyond_noise && u.rms_rel.claims.beyond_repeatability);
    }

    #[test]
    fn codings_sort_as_the_study_lists_them_with_n_step_by_its_number() {
        let mut codings = vec!["spectral", "nstep16", "rgb", "nstep3", "srgb", "nstep9"];
        codings.sort_by_key(|c| coding_order(c));
        assert_eq!(codings, ["rgb", "srgb", "nstep3", "nstep9", "nstep16", "spectral"]);
    }

    /// The comparisons' JSON, CSV and MAT listed each target's codings in
    /// the store's text order (nstep27 before nstep3, spectral before srgb):
    /// rows and summaries in the one coding order.
    #[test]
    fn codings_listed_in_text_order_nstep27_before_nstep3() {
        let row = |id: i64, target: &str, coding: &str| ComparisonRow {
            id,
            measurement_id: 1,
            render_id: 1,
            scene: "cylinder".into(),
            target: target.into(),
            coding: coding.into(),
            observer: Observer::JuddVos,
            white_source: "scene file".into(),
            white_X: 95.0,
            white_Y: 100.0,
            white_Z: 108.0,
            measured_X: 30.0,
            measured_Y: 31.0,
            measured_Z: 32.0,
            rendered_X: 30.5,
            rendered_Y: 31.5,
            rendered_Z: 32.5,
            rendered_Y_se: 0.01,
            measured_Y_se: None,
            Y_beyond_noise: None,
            Y_ratio: 31.5 / 31.0,
            xy_distance: 1e-3,
            dE76: 1.0,
            dE00: 0.8,
            created_at: 0.0,
        };
        // As the store gives them: by target, then coding name.
        let mut text_order = Vec::new();
        for target in ["h01", "h02"] {
            for coding in ["nstep27", "nstep3", "nstep81", "nstep9", "rgb", "spectral", "srgb"] {
                text_order.push(row(text_order.len() as i64 + 1, target, coding));
            }
        }
        let s = summarise("cylinder", Observer::JuddVos, text_order, &HashMap::new());
        let natural = ["rgb", "srgb", "nstep3", "nstep9", "nstep27", "nstep81", "spectral"];
        let codings: Vec<&str> = s.codings.iter().map(|c| c.coding.as_str()).collect();
        assert_eq!(codings, natural);
        let rows: Vec<(&str, &str)> = s.rows.iter().map(|r| (r.target.as_str(), r.coding.as_str())).collect();
        let expected: Vec<(&str, &str)> = ["h01", "h02"]
            .iter()
            .flat_map(|t| natural.iter().map(move |c| (*t, *c)))
            .collect();
        assert_eq!(rows, expected);
    }
}
