//! [`LabHandle`]: the lab as a daemon's front ends see it, one handle whose
//! methods the HTTP handlers call, and never the store, the queues or the
//! renderer directly.
//!
//! It holds the daemon's booth instrument ([`BoothInstrument`]: asking
//! for, cancelling and holding measurements), its renders, studies and
//! camera images ([`RenderJobs`], absent when the daemon runs without the
//! renderer), the oddity experiments ([`Experiments`]) and the store the
//! records are read from. A record asked for by id that does not exist is
//! [`LabError::NotFound`] naming it; what this daemon cannot do at all is
//! [`LabError::Unavailable`]. Cheap to clone.

use std::sync::Arc;

use lightbooth_instrument::Reading;
use lightbooth_science::colorimetry::{Observer, Xyz};
use lightbooth_store::{
    Booth, BoothRow, ComparisonRow, DisplayProfileRow, ExperimentSessionRow, IlluminantRow, InstrumentRow,
    LuminanceComparisonRow, MeasurementDetail, MeasurementFilter, MeasurementPage, ReflectanceRow, RenderRow,
    SessionRow, Store, StudyRow,
};

use crate::compare::image_map::DeltaEMap;
use crate::compare::overview::ScenesOverview;
use crate::compare::summary::SceneComparisons;
use crate::computed::Computed;
use crate::database_watch::DatabaseWatch;
use crate::download::{Download, FileFormat};
use crate::error::LabError;
use crate::experiments::analysis::Analysis;
use crate::experiments::Experiments;
use crate::measure::booth_instrument::BoothInstrument;
use crate::measure::files;
use crate::queue::{Queue, QueueSources};
use crate::records::calibration::{self, MeasuredError};
use crate::render::jobs::RenderJobs;
use crate::requests::SceneInfo;
use lightbooth_science::calibration::reflectance::OutOfRange;
use lightbooth_science::calibration::standard::WhiteStandard;

/// The files of an experiment's analysis ([`LabHandle::experiment_file`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnalysisFile {
    /// One row per observer and approximation
    /// ([`analysis_csv`](crate::experiments::analysis::analysis_csv)).
    AnalysisCsv,
    /// The analysis CSV's columns as MATLAB column vectors.
    AnalysisMat,
    /// Each observer's (and the pooled) fitted threshold and predictions
    /// ([`thresholds_csv`](crate::experiments::analysis::thresholds_csv)).
    ThresholdsCsv,
}

/// What a daemon without the renderer answers when asked to render.
const NO_RENDERER: &str = "this daemon runs without the renderer";

/// A measurement's XYZ and chromaticity in one observer
/// ([`LabHandle::measurement_colorimetry`]).
#[derive(Clone, Debug, serde::Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MeasuredColorimetry {
    pub id: i64,
    /// The observer of `XYZ`, `x` and `y`.
    #[cfg_attr(feature = "openapi", schema(value_type = String, example = "cie-2015-10"))]
    pub observer: Observer,
    /// `true`: computed now from the stored mean spectrum; `false`: the
    /// colorimeter's own XYZ, in the observer it measured in.
    pub recomputed_from_spectrum: bool,
    #[serde(rename = "XYZ")]
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub xyz: Xyz,
    pub x: f64,
    pub y: f64,
}

/// The lab of one daemon (see the module doc).
#[derive(Clone)]
pub struct LabHandle {
    store: Store,
    observer: Observer,
    instrument: BoothInstrument,
    renders: Option<Arc<RenderJobs>>,
    experiments: Experiments,
    computed: Arc<Computed>,
    database: DatabaseWatch,
    scanning: crate::measure::scan::ScanGate,
}

impl LabHandle {
    /// The lab on `store`, measuring with `instrument` (in its booth),
    /// rendering with `renders` when given, and computing every colour
    /// it reports in `observer`.
    pub fn new(
        store: Store,
        observer: Observer,
        instrument: BoothInstrument,
        renders: Option<Arc<RenderJobs>>,
    ) -> LabHandle {
        LabHandle {
            experiments: Experiments::new(store.clone()),
            // Summaries in the booth's comparison observer (see
            // `comparison_observer`): the instrument's is fixed for the daemon's life.
            computed: Arc::new(Computed::new(store.clone(), comparison_observer(&instrument, observer))),
            database: DatabaseWatch::new(store.clone()),
            scanning: Default::default(),
            store,
            observer,
            instrument,
            renders,
        }
    }

    /// Whether an instrument scan is under way ([`crate::measure::scan`]).
    pub(crate) fn scan_gate(&self) -> &crate::measure::scan::ScanGate {
        &self.scanning
    }

    /// The booth this daemon measures in.
    /// The database, for the lab's own modules.
    pub(crate) fn store(&self) -> &Store {
        &self.store
    }

    pub fn booth(&self) -> &Booth {
        self.instrument.booth()
    }

    /// The observer of every x,y, XYZ, CIELAB and ΔE this lab computes.
    pub fn observer(&self) -> Observer {
        self.observer
    }

    /// The booth's instrument: measurements asked for and cancelled, its
    /// live status, its queue and the calibration's hold.
    pub fn instrument(&self) -> &BoothInstrument {
        &self.instrument
    }

    /// The renders, studies and camera images, or why there are none.
    pub fn renders(&self) -> Result<&RenderJobs, LabError> {
        self.renders
            .as_deref()
            .ok_or_else(|| LabError::Unavailable(NO_RENDERER.into()))
    }

    /// The oddity experiments and their sessions.
    pub fn experiments(&self) -> &Experiments {
        &self.experiments
    }

    /// The heavy results, computed once per version of what they read
    /// (see [`crate::computed`]).
    pub fn computed(&self) -> &Computed {
        &self.computed
    }

    /// An experiment's analysis of every trial stored so far, computed
    /// once for them ([`crate::computed`]).
    pub async fn experiment_analysis(&self, id: i64) -> Result<Arc<Analysis>, LabError> {
        self.computed.analysis(id).await
    }

    /// The analyses of experiments `ids` for one figure, each id once, at
    /// most [`MAX_FIGURE_EXPERIMENTS`](crate::computed::MAX_FIGURE_EXPERIMENTS).
    pub async fn experiment_analyses(&self, ids: &[i64]) -> Result<Vec<Arc<Analysis>>, LabError> {
        self.computed.analyses(ids).await
    }

    /// Whether the database answers (`None`) or why not, as of a moment
    /// ago (see [`crate::database_watch`]: one ping at a time however many
    /// ask).
    pub async fn database_error(&self) -> Option<String> {
        self.database.error().await
    }

    // ---- scenes ----

    /// The scenes, in the study's order (an error without the renderer).
    pub fn scenes(&self) -> Result<Vec<SceneInfo>, LabError> {
        Ok(self.renders()?.scenes())
    }

    /// The scenes, or none without the renderer (a measurement may name no scene).
    pub fn scenes_if_any(&self) -> Vec<SceneInfo> {
        self.renders.as_deref().map(RenderJobs::scenes).unwrap_or_default()
    }

    /// One scene, or [`LabError::NotFound`] listing the available ones.
    pub fn scene(&self, id: &str) -> Result<SceneInfo, LabError> {
        let all = self.scenes()?;
        all.iter().find(|s| s.id == id).cloned().ok_or_else(|| {
            let names: Vec<&str> = all.iter().map(|s| s.id.as_str()).collect();
            LabError::NotFound(format!("no scene `{id}`; available: {}", names.join(", ")))
        })
    }

    /// The observer this booth's comparisons are made and summarised in:
    /// the instrument's own for a colorimeter or a luminance meter (its XYZ
    /// or Y cannot be recomputed in another; the renders are weighted with
    /// its observer instead), this lab's for a spectroradiometer.
    pub fn comparison_observer(&self) -> Observer {
        comparison_observer(&self.instrument, self.observer)
    }

    /// Every scene at a glance in this booth (see [`crate::compare::overview`]),
    /// in the booth's comparison observer, kept while its inputs are
    /// unchanged ([`crate::computed`]).
    pub async fn scenes_overview(&self) -> Result<Arc<ScenesOverview>, LabError> {
        self.computed.scenes_overview(self.scenes()?, self.booth()).await
    }

    /// A scene's newest comparisons in the booth's comparison observer
    /// ([`Self::comparison_observer`]), per coding, computed once for them
    /// ([`crate::computed`]).
    pub async fn scene_comparisons(&self, scene: &str) -> Result<Arc<SceneComparisons>, LabError> {
        self.scene(scene)?;
        self.computed.scene_comparisons(scene).await
    }

    /// CIELAB ΔE00 per pixel between camera images `id` and `against`
    /// (two codings of one render, the same size), with the scene's white
    /// ([`crate::compare::image_map::delta_e_map`]), on the blocking pool.
    pub async fn image_delta_e(&self, id: i64, against: i64) -> Result<DeltaEMap, LabError> {
        let jobs = self.renders()?.images();
        let (a_info, a) = jobs.data(id)?;
        let (b_info, b) = jobs.data(against)?;
        if a_info.render_id != b_info.render_id {
            return Err(LabError::Conflict(format!(
                "image {id} is of render {} and image {against} of render {}: a ΔE map compares two codings of one render",
                a_info.render_id, b_info.render_id
            )));
        }
        let (white, source) = self.cielab_white(&a_info.scene).await?;
        tokio::task::spawn_blocking(move || {
            let map = crate::compare::image_map::delta_e_map(&a, id, &b, against, white, source)?;
            // One set's coding against its reference: the paired noise.
            let reference = a.set().reference;
            let other = if b.index() == reference { a.index() } else { b.index() };
            Ok(
                if a.same_set(&b) && other != reference && (a.index() == reference || b.index() == reference) {
                    let d = a.set().difference(other, white);
                    map.with_paired(&d)
                } else {
                    map
                },
            )
        })
        .await
        .map_err(|e| LabError::Internal(e.to_string()))?
    }

    /// That ΔE00 map as a false-colour PNG (viridis from 0 to its
    /// `scale_max`).
    pub async fn image_delta_e_png(&self, id: i64, against: i64) -> Result<Vec<u8>, LabError> {
        let map = self.image_delta_e(id, against).await?;
        tokio::task::spawn_blocking(move || crate::render::image_views::delta_e_png(&map))
            .await
            .map_err(|e| LabError::Internal(e.to_string()))?
    }

    /// A scene's comparisons as a file to save, CSV or MAT
    /// ([`crate::compare::files`]), made once per kept summary.
    pub async fn scene_comparisons_file(&self, scene: &str, format: FileFormat) -> Result<Download, LabError> {
        use crate::compare::files;
        let c = self.scene_comparisons(scene).await?;
        let make = match format {
            FileFormat::Csv => files::comparisons_csv,
            FileFormat::Mat => files::comparisons_mat,
            FileFormat::Exr => {
                return Err(LabError::NotFound(format!(
                    "scene `{scene}`'s comparisons have no EXR file: ask for csv or mat"
                )))
            }
        };
        let bytes = self.computed.output(&c, format.extension(), make).await?;
        Ok(Download::new(format, &format!("comparisons_{scene}"), bytes))
    }

    /// An experiment's analysis as a file to save ([`AnalysisFile`]), made
    /// once per kept analysis.
    pub async fn experiment_file(&self, id: i64, file: AnalysisFile) -> Result<Download, LabError> {
        use crate::experiments::analysis::{analysis_csv, analysis_mat, thresholds_csv};
        let a = self.experiment_analysis(id).await?;
        /// Writes one file of an analysis.
        type Write = fn(&Analysis) -> Result<Vec<u8>, String>;
        let (format, what, make): (_, _, Write) = match file {
            AnalysisFile::AnalysisCsv => (FileFormat::Csv, "analysis", |a| Ok(analysis_csv(a).into_bytes())),
            AnalysisFile::AnalysisMat => (FileFormat::Mat, "analysis", analysis_mat),
            AnalysisFile::ThresholdsCsv => (FileFormat::Csv, "thresholds", |a| Ok(thresholds_csv(a).into_bytes())),
        };
        let bytes = self
            .computed
            .output(&a, &format!("{what}.{}", format.extension()), make)
            .await?;
        Ok(Download::new(format, &format!("experiment-{id}-{what}"), bytes))
    }

    /// A chart of a scene's comparisons as SVG: `chromaticity.svg`,
    /// `profile.svg` (luminance along the targets), `rms.svg`, `de.svg`
    /// (each coding's rms_rel and mean ΔE ± 1 SD) or `speed.svg` (render
    /// time against ΔE). Each but `speed.svg` (which also reads the scene's
    /// renders) is drawn once per kept summary ([`crate::computed`]).
    pub async fn scene_chart(&self, scene: &str, chart: &str) -> Result<Arc<Vec<u8>>, LabError> {
        use crate::compare::charts;
        let c = self.scene_comparisons(scene).await?;
        let info = self.scene(scene)?;
        if c.rows.is_empty() {
            return Err(LabError::NotFound(format!(
                "scene `{scene}` has no comparisons yet: measure its targets first"
            )));
        }
        let draw: fn(&SceneComparisons, &SceneInfo) -> Result<String, String> = match chart {
            "chromaticity.svg" => |c, info| charts::chromaticity(c, info, c.observer),
            "profile.svg" => charts::profile,
            "rms.svg" => |c, _| charts::rms(c),
            "de.svg" => |c, _| charts::delta_e(c),
            "speed.svg" => {
                return Ok(Arc::new(
                    charts::speed(self, &c).await.map_err(LabError::Internal)?.into_bytes(),
                ))
            }
            other => {
                return Err(LabError::NotFound(format!(
                    "no chart `{other}`: choose chromaticity.svg, profile.svg, rms.svg, de.svg or speed.svg"
                )))
            }
        };
        self.computed
            .output(&c, chart, move |c| draw(c, &info).map(String::into_bytes))
            .await
    }

    /// The CIELAB white of a scene in this booth now in this lab's
    /// observer, with its source.
    pub async fn cielab_white(&self, scene: &str) -> Result<(Xyz, String), LabError> {
        self.renders()?.cielab_white(scene, self.booth(), self.observer).await
    }

    /// The (scene, target) pairs of `scenes` (every scene when `None`) with
    /// no complete measurement in `booth`, in the study's order.
    pub async fn unmeasured_targets(
        &self,
        scenes: Option<&[&str]>,
        booth: &Booth,
    ) -> Result<Vec<(String, String)>, LabError> {
        let measured = self.store.measured_targets(booth).await?;
        Ok(self
            .scenes_if_any()
            .iter()
            .filter(|s| scenes.is_none_or(|c| c.contains(&s.id.as_str())))
            .flat_map(|s| s.targets.iter().map(move |t| (s.id.clone(), t.clone())))
            .filter(|pair| !measured.contains(pair))
            .collect())
    }

    /// Whether a study against `booth`'s measurements of `scenes` (every
    /// scene when `None`) can run in this lab's observer, checked before it
    /// is queued: each target's newest complete measurement there must give
    /// an XYZ in it (a colorimeter's only in its own observer, a luminance
    /// meter's never), and so must the booth's instrument when it is to
    /// measure the missing targets first (`measures_missing`). A
    /// [`LabError::Conflict`] saying why and what to do otherwise.
    pub async fn check_study_measurements(
        &self,
        scenes: Option<&[&str]>,
        booth: &Booth,
        measures_missing: bool,
    ) -> Result<(), LabError> {
        let observer = self.observer;
        let refused = |why: String| {
            LabError::Conflict(format!(
                "a study against booth {booth}'s measurements works in the daemon's observer ({observer}) and \
                 cannot run: {why}; or start it with \"against\": \"reference\""
            ))
        };
        if measures_missing {
            let model = self.instrument.capabilities().model;
            match self.instrument.capabilities().reading {
                Reading::Luminance { .. } => {
                    return Err(refused(format!(
                        "the {model} measures luminance only, and the study compares x, y and ΔE: measure with a \
                         colorimeter or a spectroradiometer"
                    )))
                }
                Reading::Tristimulus { observer: own } if own != observer => {
                    return Err(refused(format!(
                        "the {model} measures XYZ in the {own} observer, which cannot be recomputed in another: \
                         serve with --observer {own}, or measure with a spectroradiometer"
                    )))
                }
                _ => {}
            }
        }
        for scene in self
            .scenes_if_any()
            .iter()
            .filter(|s| scenes.is_none_or(|c| c.contains(&s.id.as_str())))
        {
            for target in &scene.targets {
                if let Some(m) = self.store.latest_complete_in_booth(&scene.id, target, booth).await? {
                    crate::compare::white::measured_xyz(&m, observer).map_err(refused)?;
                }
            }
        }
        Ok(())
    }

    // ---- renders ----

    /// A scene's renders, newest first.
    pub async fn renders_of_scene(&self, scene: &str) -> Result<Vec<RenderRow>, LabError> {
        self.scene(scene)?;
        Ok(self.store.list_renders(Some(scene)).await?)
    }

    pub async fn render(&self, id: i64) -> Result<RenderRow, LabError> {
        self.store
            .get_render(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no render {id}")))
    }

    /// A complete render's camera view (a PNG).
    pub async fn render_preview(&self, id: i64) -> Result<Vec<u8>, LabError> {
        self.store.render_preview(id).await?.ok_or_else(|| {
            LabError::NotFound(format!(
                "render {id} has no preview (not finished, or no [camera] in its scene)"
            ))
        })
    }

    // ---- measurements ----

    pub async fn measurements(&self, filter: &MeasurementFilter) -> Result<MeasurementPage, LabError> {
        Ok(self.store.list_measurements(filter).await?)
    }

    /// A measurement with every raw sample.
    pub async fn measurement(&self, id: i64) -> Result<MeasurementDetail, LabError> {
        self.store
            .get_measurement(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no measurement {id}")))
    }

    /// A measurement's spectra as a file to save, CSV or MAT
    /// ([`crate::measure::files`]); a measurement without a spectrum (a
    /// colorimeter's, a luminance meter's) is refused, naming why.
    pub async fn measurement_file(&self, id: i64, format: FileFormat) -> Result<Download, LabError> {
        let m = self.measurement(id).await?;
        let bytes = match format {
            FileFormat::Csv => files::stored_spectrum_csv(&m)?,
            FileFormat::Mat => files::stored_spectrum_mat(&m)?,
            FileFormat::Exr => {
                return Err(LabError::NotFound(format!(
                    "measurement {id} has no EXR file: ask for its spectra as csv or mat"
                )))
            }
        };
        Ok(Download::new(format, &format!("measurement_{id}"), bytes))
    }

    /// A measurement's spectra drawn as SVG: the mean, ±1 SD and each sample.
    pub async fn measurement_chart(&self, id: i64) -> Result<Vec<u8>, LabError> {
        files::stored_spectrum_chart(&self.measurement(id).await?)
    }

    /// A measurement's colorimetry in `observer`: recomputed from its mean
    /// spectrum (a spectroradiometer's, in any observer), or a
    /// colorimeter's own XYZ in the observer it was made in. Another
    /// observer for a colorimeter's XYZ, or a luminance meter's
    /// measurement, is refused ([`LabError::Conflict`], saying why): an XYZ
    /// cannot be turned into another observer's.
    pub async fn measurement_colorimetry(&self, id: i64, observer: Observer) -> Result<MeasuredColorimetry, LabError> {
        let m = self.measurement(id).await?;
        let xyz = crate::compare::white::measured_xyz(&m, observer)
            .map_err(LabError::Conflict)?
            .ok_or_else(|| {
                LabError::Conflict(format!(
                    "measurement {id} is {}: it has no spectrum and no XYZ yet",
                    m.summary.state.as_str()
                ))
            })?;
        let xy = xyz.chromaticity();
        Ok(MeasuredColorimetry {
            id,
            observer,
            recomputed_from_spectrum: m.radiance.is_some(),
            xyz,
            x: xy.x,
            y: xy.y,
        })
    }

    /// A measurement's comparisons with every coding.
    pub async fn comparisons_of_measurement(&self, id: i64) -> Result<Vec<ComparisonRow>, LabError> {
        self.measurement(id).await?;
        let mut rows = self.store.comparisons_for_measurement(id).await?;
        // Each render's rows together (the store lists them by id), their
        // codings in the one order; stable within a coding.
        rows.sort_by_key(|r| (r.render_id, lightbooth_render::coding_order(&r.coding)));
        Ok(rows)
    }

    /// A luminance meter's measurement compared in luminance alone.
    pub async fn luminance_comparisons_of_measurement(&self, id: i64) -> Result<Vec<LuminanceComparisonRow>, LabError> {
        self.measurement(id).await?;
        Ok(self.store.luminance_comparisons_for_measurement(id).await?)
    }

    // ---- the booth's records ----

    /// Every booth sharing this database.
    pub async fn booths(&self) -> Result<Vec<BoothRow>, LabError> {
        Ok(self.store.list_booths().await?)
    }

    /// Every instrument this database has seen.
    pub async fn instruments(&self) -> Result<Vec<InstrumentRow>, LabError> {
        Ok(self.store.list_instruments().await?)
    }

    pub async fn sessions(&self) -> Result<Vec<SessionRow>, LabError> {
        Ok(self.store.list_sessions().await?)
    }

    /// Records a measuring session of `operator` (not blank; trimmed).
    pub async fn create_session(&self, operator: &str, notes: &str) -> Result<i64, LabError> {
        let operator = operator.trim();
        if operator.is_empty() {
            return Err(LabError::Invalid("field `operator`: must not be empty".into()));
        }
        Ok(self.store.create_session(operator, notes).await?)
    }

    /// Every job of this booth waiting or under way (see [`crate::queue`]).
    pub async fn queue(&self) -> Result<Queue, LabError> {
        let status = self.instrument.status();
        let renders = self.renders.as_deref();
        Ok(crate::queue::queue(&QueueSources {
            store: &self.store,
            booth: self.booth(),
            status: &status,
            renders,
            progress: renders.and_then(RenderJobs::progress),
        })
        .await?)
    }

    // ---- studies ----

    pub async fn studies(&self) -> Result<Vec<StudyRow>, LabError> {
        Ok(self.store.list_studies().await?)
    }

    pub async fn study(&self, id: i64) -> Result<StudyRow, LabError> {
        self.store
            .get_study(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no study {id}")))
    }

    /// A file of a study's report.
    pub async fn study_file(&self, id: i64, name: &str) -> Result<Vec<u8>, LabError> {
        self.store
            .study_file(id, name)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("study {id} has no file `{name}`")))
    }

    // ---- experiments ----

    /// Every experiment, newest first.
    pub async fn experiment_list(&self) -> Result<Vec<lightbooth_store::ExperimentRow>, LabError> {
        Ok(self.store.list_experiments().await?)
    }

    /// An experiment's sessions, oldest first.
    pub async fn sessions_of_experiment(&self, id: i64) -> Result<Vec<ExperimentSessionRow>, LabError> {
        self.experiments.get(id).await?;
        Ok(self.store.sessions_of_experiment(id).await?)
    }

    // ---- display profiles ----

    pub async fn display_profiles(&self) -> Result<Vec<DisplayProfileRow>, LabError> {
        Ok(self.store.list_display_profiles().await?)
    }

    pub async fn display_profile(&self, id: i64) -> Result<DisplayProfileRow, LabError> {
        self.store
            .get_display_profile(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no display profile {id}")))
    }

    /// Stores a fitted display profile; its row.
    pub async fn add_display_profile(
        &self,
        name: &str,
        note: &str,
        profile: &lightbooth_science::display::DisplayProfile,
    ) -> Result<DisplayProfileRow, LabError> {
        let id = self.store.insert_display_profile(name, note, profile).await?;
        self.display_profile(id).await
    }

    // ---- reflectances and illuminants measured in the booth ----

    /// A sample's reflectance from its measurement and a white standard's
    /// (see [`calibration::create_reflectance`]).
    pub async fn create_reflectance(
        &self,
        sample_id: i64,
        standard_id: i64,
        standard: &WhiteStandard,
        name: &str,
        note: &str,
    ) -> Result<ReflectanceRow, LabError> {
        Ok(calibration::create_reflectance(&self.store, sample_id, standard_id, standard, name, note).await?)
    }

    pub async fn reflectances(&self) -> Result<Vec<ReflectanceRow>, LabError> {
        Ok(self.store.list_reflectances().await?)
    }

    pub async fn reflectance(&self, id: i64) -> Result<ReflectanceRow, LabError> {
        self.store
            .get_reflectance(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no reflectance {id}")))
    }

    /// A reflectance as a scene spectrum CSV.
    pub async fn reflectance_csv(&self, row: &ReflectanceRow, out_of_range: OutOfRange) -> Result<String, LabError> {
        Ok(calibration::reflectance_csv(&self.store, row, out_of_range).await?)
    }

    /// A lamp's relative SPD from its measurement on a white standard (see
    /// [`calibration::create_illuminant`]).
    pub async fn create_illuminant(
        &self,
        measurement_id: i64,
        standard: &WhiteStandard,
        name: &str,
        note: &str,
    ) -> Result<IlluminantRow, LabError> {
        Ok(calibration::create_illuminant(&self.store, measurement_id, standard, name, note).await?)
    }

    pub async fn illuminants(&self) -> Result<Vec<IlluminantRow>, LabError> {
        Ok(self.store.list_illuminants().await?)
    }

    pub async fn illuminant(&self, id: i64) -> Result<IlluminantRow, LabError> {
        self.store
            .get_illuminant(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no illuminant {id}")))
    }

    /// An illuminant as a scene spectrum CSV.
    pub async fn illuminant_csv(&self, row: &IlluminantRow) -> Result<String, LabError> {
        Ok(calibration::illuminant_csv(&self.store, row).await?)
    }
}

impl From<MeasuredError> for LabError {
    fn from(e: MeasuredError) -> Self {
        match e {
            MeasuredError::Invalid(m) => LabError::Invalid(m),
            MeasuredError::WrongState(m) => LabError::Conflict(m),
            MeasuredError::Store(e) => e.into(),
        }
    }
}

/// The observer `instrument`'s comparisons are made in: its own for a
/// colorimeter or a luminance meter, `lab`'s for a spectroradiometer.
fn comparison_observer(instrument: &BoothInstrument, lab: Observer) -> Observer {
    match instrument.capabilities().reading {
        Reading::Tristimulus { observer } | Reading::Luminance { observer } => observer,
        Reading::Spectrum => lab,
    }
}
