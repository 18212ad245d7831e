//! The records the store reads and writes. Their serde names are what the
//! REST API sends: valid MATLAB identifiers, numbers as numbers, spectra as
//! plain numeric arrays.
//!
//! What a query returns is read by `#[derive(sqlx::FromRow)]` records (the
//! columns as stored, the same on both engines) and turned into these
//! records by `TryFrom`, which parses stored JSON and names what is corrupt.

use serde::{Deserialize, Serialize};

use super::{Booth, MeasurementState, StoreError};
use lightbooth_science::colorimetry::{Observer, Xyz};

#[derive(Clone, Debug, Serialize, sqlx::FromRow)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct InstrumentRow {
    pub id: i64,
    pub model: String,
    /// The booth it was last seen in (`serve --booth`).
    pub booth: String,
    /// Empty when the instrument does not report one.
    pub serial: String,
    pub port: Option<String>,
    pub first_seen: f64,
    pub last_seen: f64,
}

/// A booth as the database knows it: from its measurements and instruments.
#[derive(Clone, Debug, Serialize, sqlx::FromRow)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct BoothRow {
    pub booth: String,
    /// Measurements taken (or queued) in it.
    pub measurements: i64,
    /// Of which queued or running now.
    pub unfinished: i64,
    /// POSIX seconds of its newest measurement's request; null without one.
    pub last_measurement_at: Option<f64>,
}

#[derive(Clone, Debug, Serialize, sqlx::FromRow)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SessionRow {
    pub id: i64,
    pub operator: String,
    pub notes: String,
    pub started_at: f64,
}

/// What is needed to queue a measurement.
#[derive(Clone, Debug)]
pub struct NewMeasurement {
    /// The booth it is taken in.
    pub booth: Booth,
    pub session_id: Option<i64>,
    pub scene: Option<String>,
    pub target: Option<String>,
    pub samples: usize,
    pub settings_json: serde_json::Value,
    pub note: String,
}

/// One raw sample as the instrument gave it.
#[derive(Clone, Debug)]
pub struct NewSample {
    pub index: usize,
    pub taken_at: f64,
    pub code: i64,
    pub message: String,
    /// False when the sample must never be averaged (stale buffer, error code).
    pub usable: bool,
    /// W/(sr·m²·nm) on the instrument's native grid; None when there is no valid spectrum.
    pub radiance: Option<Vec<f64>>,
    pub luminance_cd_m2: Option<f64>,
    /// X, Y, Z (cd/m²) as the instrument reported them, when it did (a
    /// colorimeter's only reading).
    pub instrument_xyz: Option<[f64; 3]>,
}

/// The average of a complete measurement.
#[derive(Clone, Debug)]
pub struct Average {
    pub wavelength_nm: Vec<f64>,
    pub radiance: Vec<f64>,
    pub radiance_sd: Vec<f64>,
    pub luminance_cd_m2: f64,
    /// CIE 1931 x, y of the mean spectrum (what the instrument itself
    /// reports), or of a colorimeter's mean XYZ; none from a luminance meter.
    pub x: Option<f64>,
    pub y: Option<f64>,
    pub luminance_cv: f64,
    /// XYZ of the mean spectrum computed by lightbooth with `observer` (the
    /// daemon's or the study's), cd/m² scale.
    pub xyz: Option<[f64; 3]>,
    pub observer: Option<Observer>,
}

/// A measurement without its spectra: what listings show.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MeasurementSummary {
    pub id: i64,
    /// The booth it was taken in (`serve --booth`; `default` for one booth).
    pub booth: String,
    pub session_id: Option<i64>,
    pub instrument_id: Option<i64>,
    /// The model of the instrument that took it ("PR-650", "PR-655", "PR-670").
    pub instrument_model: Option<String>,
    /// Its serial number, when it reports one.
    pub instrument_serial: Option<String>,
    pub scene: Option<String>,
    pub target: Option<String>,
    pub samples_requested: i64,
    pub samples_taken: i64,
    pub state: MeasurementState,
    pub error: Option<String>,
    pub note: String,
    /// POSIX seconds, UTC.
    pub created_at: f64,
    pub started_at: Option<f64>,
    pub finished_at: Option<f64>,
    /// Luminance of the mean spectrum, cd/m², computed by lightbooth with
    /// `observer`: always `XYZ[1]` (the same observer as `x`, `y`, `XYZ`
    /// and every comparison of the measurement); a colorimeter's is its own
    /// XYZ's, a luminance meter's its own luminance, in its `observer`.
    #[serde(rename = "Y")]
    pub luminance_cd_m2: Option<f64>,
    /// The instrument's own luminance of the mean spectrum, cd/m² (CIE 1931
    /// 2°, Km = 683 lm/W, as the instrument computes it). Shown labelled as
    /// the instrument's and never charted.
    #[serde(rename = "instrument_Y")]
    pub instrument_luminance_cd_m2: Option<f64>,
    /// The instrument's own chromaticity: CIE 1931 2° x of the mean
    /// spectrum, as the instrument reports it. Never charted next to lightbooth's
    /// values (those are `x`, `y` with `observer`).
    pub instrument_x: Option<f64>,
    /// The instrument's own CIE 1931 2° y (see `instrument_x`).
    pub instrument_y: Option<f64>,
    /// The observer of `x`, `y` and `XYZ`: `judd-vos-1978`, `cie-1931`, `cie-1964-10`, `cie-2015-2` or `cie-2015-10`
    /// (the daemon's `--observer` when the measurement completed).
    #[cfg_attr(feature = "openapi", schema(value_type = Option<String>))]
    pub observer: Option<Observer>,
    /// x of the mean spectrum computed by lightbooth with `observer`.
    pub x: Option<f64>,
    /// y of the mean spectrum computed by lightbooth with `observer`.
    pub y: Option<f64>,
    /// X, Y, Z (cd/m² scale) of the mean spectrum with `observer`.
    #[serde(rename = "XYZ")]
    pub xyz: Option<[f64; 3]>,
    /// Coefficient of variation of the samples' luminance.
    pub luminance_cv: Option<f64>,
    /// Samples good enough to average (quality code OK, a valid spectrum).
    pub good_samples: i64,
    /// True when `Y`, `x`, `y` and `luminance_cv` are the average of the good
    /// samples of a measurement that did not complete (interrupted or
    /// cancelled): a partial result, never a complete measurement.
    pub partial: bool,
    /// The instrument hold it was taken under (a display calibration or
    /// verification, `POST /api/instrument/hold`); null when taken freely.
    pub hold: Option<MeasurementHold>,
}

/// The instrument hold a measurement was taken under: what held the
/// instrument, so a verification knows the display showed its colour.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MeasurementHold {
    pub id: i64,
    /// What held it, e.g. `verification of experiment 3`.
    pub purpose: String,
}

/// One stored raw sample.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SampleRow {
    pub index: usize,
    /// POSIX seconds, UTC.
    pub time: f64,
    /// The instrument's quality code (0 = OK).
    pub code: i64,
    pub message: String,
    pub usable: bool,
    /// W/(sr·m²·nm) on `wavelength_nm` of the measurement; null when the instrument gave none.
    pub radiance: Option<Vec<f64>>,
    /// Luminance of this sample's spectrum, cd/m², with the measurement's
    /// `observer` (null without a spectrum).
    #[serde(rename = "Y")]
    pub luminance_cd_m2: Option<f64>,
    /// The luminance the instrument itself reported for this sample (its
    /// CIE 1931 `Y`, four significant digits on a PR-650); never charted.
    #[serde(rename = "instrument_Y")]
    pub instrument_luminance_cd_m2: Option<f64>,
    /// X, Y, Z (cd/m²) as the instrument itself reported them for this
    /// sample (a colorimeter's reading; null when it sent none).
    #[serde(rename = "instrument_XYZ")]
    pub instrument_xyz: Option<[f64; 3]>,
}

/// A measurement with its average spectrum and every raw sample.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MeasurementDetail {
    #[serde(flatten)]
    pub summary: MeasurementSummary,
    /// The instrument's native grid, nm.
    pub wavelength_nm: Option<Vec<f64>>,
    /// Mean spectral radiance, W/(sr·m²·nm).
    pub radiance: Option<Vec<f64>>,
    /// Per-wavelength standard deviation of the usable samples, W/(sr·m²·nm).
    pub radiance_sd: Option<Vec<f64>>,
    /// When a simulated instrument took it: the relative standard error of
    /// Y of the truth it was aimed at (a converged render, itself an
    /// estimate; 0.001 = 0.1 %), which comparisons count in their error
    /// budget. Null for a real instrument.
    pub simulated_truth_relative_se: Option<f64>,
    pub samples: Vec<SampleRow>,
}

/// Filters and paging for listing measurements.
#[derive(Clone, Debug, Default, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema, utoipa::IntoParams))]
#[cfg_attr(feature = "openapi", into_params(parameter_in = Query))]
#[serde(deny_unknown_fields)]
pub struct MeasurementFilter {
    /// One booth's measurements only.
    #[cfg_attr(feature = "openapi", schema(value_type = Option<String>))]
    #[cfg_attr(feature = "openapi", param(value_type = Option<String>))]
    pub booth: Option<Booth>,
    /// Only those taken by this instrument model (`PR-650`, `PR-655`, `PR-670`).
    pub instrument_model: Option<String>,
    pub scene: Option<String>,
    pub target: Option<String>,
    pub state: Option<MeasurementState>,
    /// 1–1000, default 50.
    #[cfg_attr(feature = "openapi", param(minimum = 1, maximum = 1000))]
    pub limit: Option<i64>,
    #[cfg_attr(feature = "openapi", param(minimum = 0))]
    pub offset: Option<i64>,
    /// Only measurements with an id below this one: the page after a page
    /// whose last (oldest) item has this id. Unlike `offset`, it costs the
    /// same at any depth; `total` still counts every match.
    pub before_id: Option<i64>,
}

#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MeasurementPage {
    pub total: i64,
    pub limit: i64,
    pub offset: i64,
    pub items: Vec<MeasurementSummary>,
}

/// The summary columns (no spectra: listings stay small and fast).
pub(super) const MEASUREMENT_COLUMNS: &str = "id, booth, session_id, instrument_id, scene, target, samples_requested, \
    (SELECT COUNT(*) FROM samples s WHERE s.measurement_id = measurements.id) AS samples_taken, \
    (SELECT COUNT(*) FROM samples s WHERE s.measurement_id = measurements.id AND s.usable = TRUE) AS good_samples, \
    state, error, note, created_at, started_at, finished_at, luminance_cd_m2, x, y, luminance_cv, \
    observer, xyz_x, xyz_y, xyz_z, \
    (SELECT i.model FROM instruments i WHERE i.id = measurements.instrument_id) AS instrument_model, \
    (SELECT i.serial FROM instruments i WHERE i.id = measurements.instrument_id) AS instrument_serial, \
    hold_id, hold_purpose";

/// The columns of [`MEASUREMENT_COLUMNS`], as stored.
#[derive(sqlx::FromRow)]
pub(super) struct MeasurementRecord {
    id: i64,
    booth: String,
    session_id: Option<i64>,
    instrument_id: Option<i64>,
    scene: Option<String>,
    target: Option<String>,
    samples_requested: i64,
    samples_taken: i64,
    good_samples: i64,
    state: String,
    error: Option<String>,
    note: String,
    created_at: f64,
    started_at: Option<f64>,
    finished_at: Option<f64>,
    luminance_cd_m2: Option<f64>,
    x: Option<f64>,
    y: Option<f64>,
    luminance_cv: Option<f64>,
    observer: Option<String>,
    xyz_x: Option<f64>,
    xyz_y: Option<f64>,
    xyz_z: Option<f64>,
    instrument_model: Option<String>,
    instrument_serial: Option<String>,
    hold_id: Option<i64>,
    hold_purpose: Option<String>,
}

/// A measurement's summary columns and its average spectra.
#[derive(sqlx::FromRow)]
pub(super) struct MeasurementDetailRecord {
    #[sqlx(flatten)]
    pub summary: MeasurementRecord,
    pub wavelength_json: Option<String>,
    pub radiance_json: Option<String>,
    pub radiance_sd_json: Option<String>,
    pub settings_json: String,
}

/// An observer name stored in a column (NULL → `None`).
fn observer_column(name: Option<String>, column: &str) -> Result<Option<Observer>, StoreError> {
    name.map(|n| {
        n.parse().map_err(|e: String| StoreError::Corrupt {
            what: format!("{column} column"),
            err: e,
        })
    })
    .transpose()
}

impl TryFrom<MeasurementRecord> for MeasurementSummary {
    type Error = StoreError;
    fn try_from(r: MeasurementRecord) -> Result<MeasurementSummary, StoreError> {
        let xyz = match (r.xyz_x, r.xyz_y, r.xyz_z) {
            (Some(x), Some(y), Some(z)) => Some([x, y, z]),
            _ => None,
        };
        let observer = observer_column(r.observer, "observer")?;
        // A complete measurement without XYZ is a luminance meter's: its Y is
        // the instrument's own, in the observer stored with it.
        let luminance = xyz.map(|v| v[1]).or(observer.and(r.luminance_cd_m2));
        Ok(MeasurementSummary {
            id: r.id,
            booth: r.booth,
            session_id: r.session_id,
            instrument_id: r.instrument_id,
            instrument_model: r.instrument_model,
            // Stored as '' when the instrument does not say.
            instrument_serial: r.instrument_serial.filter(|s| !s.is_empty()),
            scene: r.scene,
            target: r.target,
            samples_requested: r.samples_requested,
            samples_taken: r.samples_taken,
            state: r.state.parse().map_err(|e: String| StoreError::Corrupt {
                what: "measurement state".into(),
                err: e,
            })?,
            error: r.error,
            note: r.note,
            created_at: r.created_at,
            started_at: r.started_at,
            finished_at: r.finished_at,
            // Lightbooth's Y is the observer's, from the stored XYZ; the
            // stored luminance column is the instrument's CIE 1931 value.
            luminance_cd_m2: luminance,
            instrument_luminance_cd_m2: r.luminance_cd_m2,
            instrument_x: r.x,
            instrument_y: r.y,
            observer,
            x: xyz.map(|v| Xyz::from_array(v).chromaticity().x),
            y: xyz.map(|v| Xyz::from_array(v).chromaticity().y),
            xyz,
            luminance_cv: r.luminance_cv,
            good_samples: r.good_samples,
            partial: false,
            hold: r.hold_id.map(|id| MeasurementHold {
                id,
                purpose: r.hold_purpose.unwrap_or_default(),
            }),
        })
    }
}

/// One stored sample, as stored.
#[derive(sqlx::FromRow)]
pub(super) struct SampleRecord {
    idx: i64,
    taken_at: f64,
    code: i64,
    message: String,
    usable: bool,
    radiance_json: Option<String>,
    luminance_cd_m2: Option<f64>,
    xyz_json: Option<String>,
}

impl TryFrom<SampleRecord> for SampleRow {
    type Error = StoreError;
    fn try_from(r: SampleRecord) -> Result<SampleRow, StoreError> {
        Ok(SampleRow {
            index: r.idx as usize,
            time: r.taken_at,
            code: r.code,
            message: r.message,
            usable: r.usable,
            radiance: super::parse_opt_array(r.radiance_json, "sample radiance")?,
            // Filled from the spectrum with the measurement's observer by
            // `Store::get_measurement`, which knows it.
            luminance_cd_m2: None,
            instrument_luminance_cd_m2: r.luminance_cd_m2,
            instrument_xyz: super::parse_opt_array(r.xyz_json, "sample XYZ")?
                .map(|v: Vec<f64>| {
                    <[f64; 3]>::try_from(v.as_slice()).map_err(|_| StoreError::Corrupt {
                        what: "sample XYZ".into(),
                        err: format!("{} values, not 3", v.len()),
                    })
                })
                .transpose()?,
        })
    }
}

/// What is needed to record a render.
#[derive(Clone, Debug)]
pub struct NewRender {
    pub scene: String,
    pub scene_hash: String,
    pub settings_json: serde_json::Value,
    pub codings: Vec<String>,
    pub seed: u64,
}

#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct RenderRow {
    pub id: i64,
    pub scene: String,
    pub scene_hash: String,
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub settings: serde_json::Value,
    pub codings: Vec<String>,
    pub seed: i64,
    pub state: String,
    pub error: Option<String>,
    pub created_at: f64,
    pub finished_at: Option<f64>,
    pub wall_seconds: Option<f64>,
    /// The renderer's JSON result (per target and coding), once complete;
    /// null before.
    #[cfg_attr(feature = "openapi", schema(value_type = Option<Object>))]
    pub result: Option<serde_json::Value>,
}

pub(super) const RENDER_COLUMNS: &str = "id, scene, scene_hash, settings_json, codings, seed, state, error, \
    created_at, finished_at, wall_seconds, result_json";

/// The columns of [`RENDER_COLUMNS`], as stored.
#[derive(sqlx::FromRow)]
pub(super) struct RenderRecord {
    id: i64,
    scene: String,
    scene_hash: String,
    settings_json: String,
    codings: String,
    seed: i64,
    state: String,
    error: Option<String>,
    created_at: f64,
    finished_at: Option<f64>,
    wall_seconds: Option<f64>,
    result_json: Option<String>,
}

/// Stored JSON text (NULL → `None`), or which column of which table is corrupt.
fn parse_json(text: Option<String>, what: &str) -> Result<Option<serde_json::Value>, StoreError> {
    text.map(|t| {
        serde_json::from_str(&t).map_err(|e| StoreError::Corrupt {
            what: what.into(),
            err: e.to_string(),
        })
    })
    .transpose()
}

impl TryFrom<RenderRecord> for RenderRow {
    type Error = StoreError;
    fn try_from(r: RenderRecord) -> Result<RenderRow, StoreError> {
        Ok(RenderRow {
            id: r.id,
            scene: r.scene,
            scene_hash: r.scene_hash,
            settings: parse_json(Some(r.settings_json), "renders.settings_json")?.unwrap_or(serde_json::Value::Null),
            codings: r
                .codings
                .split(',')
                .filter(|s| !s.is_empty())
                .map(str::to_string)
                .collect(),
            seed: r.seed,
            state: r.state,
            error: r.error,
            created_at: r.created_at,
            finished_at: r.finished_at,
            wall_seconds: r.wall_seconds,
            result: parse_json(r.result_json, "renders.result_json")?,
        })
    }
}

/// One comparison to store: XYZ triples on the measurement's scale (cd/m²).
#[derive(Clone, Debug)]
pub struct NewComparison {
    pub measurement_id: i64,
    pub render_id: i64,
    pub scene: String,
    pub target: String,
    pub coding: String,
    /// The observer of every XYZ of the row (and so of its ΔE).
    pub observer: Observer,
    pub white_source: String,
    pub white: [f64; 3],
    pub measured: [f64; 3],
    /// Standard error of the measured Y, cd/m².
    pub measured_y_se: f64,
    pub rendered: [f64; 3],
    pub rendered_y_se: f64,
    pub y_ratio: f64,
    pub xy_distance: f64,
    pub de76: f64,
    pub de00: f64,
}

/// A stored comparison, as the API and the CSV/MAT downloads give it. Field
/// names follow the colorimetric symbols (X, Y, Z) so MATLAB tables read well.
#[allow(non_snake_case)]
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ComparisonRow {
    pub id: i64,
    pub measurement_id: i64,
    pub render_id: i64,
    pub scene: String,
    pub target: String,
    pub coding: String,
    /// The observer of every XYZ, x,y and ΔE of the row.
    #[cfg_attr(feature = "openapi", schema(value_type = String))]
    pub observer: Observer,
    /// The CIELAB reference white the scene declares (`[cielab_white]` in
    /// its file) and where its value came from (a measurement, the rendering
    /// standing in until it is measured, or the scene file).
    pub white_source: String,
    pub white_X: f64,
    pub white_Y: f64,
    pub white_Z: f64,
    pub measured_X: f64,
    pub measured_Y: f64,
    pub measured_Z: f64,
    pub rendered_X: f64,
    pub rendered_Y: f64,
    pub rendered_Z: f64,
    pub rendered_Y_se: f64,
    /// Standard error of the measured Y (samples' SD/√n); null on rows
    /// stored before it was recorded.
    pub measured_Y_se: Option<f64>,
    /// |rendered Y − measured Y| > k·√(rendered_Y_se² + measured_Y_se²),
    /// k = 3 ([`lightbooth_science::comparison::BEYOND_NOISE_K`]); null without measured_Y_se.
    pub Y_beyond_noise: Option<bool>,
    pub Y_ratio: f64,
    pub xy_distance: f64,
    pub dE76: f64,
    pub dE00: f64,
    pub created_at: f64,
}

/// A row of `comparisons`, as stored.
#[derive(sqlx::FromRow)]
pub(super) struct ComparisonRecord {
    id: i64,
    measurement_id: i64,
    render_id: i64,
    scene: String,
    target: String,
    coding: String,
    observer: String,
    white_source: String,
    white_x: f64,
    white_y: f64,
    white_z: f64,
    measured_x: f64,
    measured_y: f64,
    measured_z: f64,
    rendered_x: f64,
    rendered_y: f64,
    rendered_z: f64,
    rendered_y_se: f64,
    measured_y_se: Option<f64>,
    y_ratio: f64,
    xy_distance: f64,
    de76: f64,
    de00: f64,
    created_at: f64,
}

impl From<ComparisonRecord> for ComparisonRow {
    fn from(r: ComparisonRecord) -> ComparisonRow {
        ComparisonRow {
            // Rows are written by this program; an unknown name would be a bug,
            // shown as the default rather than failing every listing.
            observer: r.observer.parse().unwrap_or_default(),
            measured_Y_se: r.measured_y_se,
            Y_beyond_noise: r
                .measured_y_se
                .map(|m| lightbooth_science::comparison::beyond_noise(r.rendered_y - r.measured_y, r.rendered_y_se, m)),
            id: r.id,
            measurement_id: r.measurement_id,
            render_id: r.render_id,
            scene: r.scene,
            target: r.target,
            coding: r.coding,
            white_source: r.white_source,
            white_X: r.white_x,
            white_Y: r.white_y,
            white_Z: r.white_z,
            measured_X: r.measured_x,
            measured_Y: r.measured_y,
            measured_Z: r.measured_z,
            rendered_X: r.rendered_x,
            rendered_Y: r.rendered_y,
            rendered_Z: r.rendered_z,
            rendered_Y_se: r.rendered_y_se,
            Y_ratio: r.y_ratio,
            xy_distance: r.xy_distance,
            dE76: r.de76,
            dE00: r.de00,
            created_at: r.created_at,
        }
    }
}

/// A luminance meter's measurement against one coding, to be stored: the
/// luminances alone (a luminance meter gives no colour, so no x, y or ΔE).
#[derive(Clone, Debug)]
pub struct NewLuminanceComparison {
    pub measurement_id: i64,
    pub render_id: i64,
    pub scene: String,
    pub target: String,
    pub coding: String,
    /// The observer whose ȳ weights both luminances.
    pub observer: Observer,
    /// Measured Y and its standard error (samples' SD/√n), cd/m².
    pub measured_y: f64,
    pub measured_y_se: f64,
    /// Rendered Y and its Monte Carlo standard error, cd/m².
    pub rendered_y: f64,
    pub rendered_y_se: f64,
    pub y_ratio: f64,
}

/// A stored luminance-only comparison (a luminance meter's measurement
/// against one coding), as the API gives it: the luminance ratio, whether
/// the difference is beyond noise, and no colour.
#[allow(non_snake_case)]
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct LuminanceComparisonRow {
    pub id: i64,
    pub measurement_id: i64,
    pub render_id: i64,
    pub scene: String,
    pub target: String,
    pub coding: String,
    /// The observer whose ȳ weights both luminances.
    #[cfg_attr(feature = "openapi", schema(value_type = String))]
    pub observer: Observer,
    pub measured_Y: f64,
    /// Standard error of the measured Y (samples' SD/√n).
    pub measured_Y_se: f64,
    pub rendered_Y: f64,
    pub rendered_Y_se: f64,
    /// Rendered Y over measured Y.
    pub Y_ratio: f64,
    /// |rendered Y − measured Y| > k·√(rendered_Y_se² + measured_Y_se²),
    /// k = 3 ([`lightbooth_science::comparison::BEYOND_NOISE_K`]).
    pub Y_beyond_noise: bool,
    pub created_at: f64,
}

/// A row of `luminance_comparisons`, as stored.
#[derive(sqlx::FromRow)]
pub(super) struct LuminanceComparisonRecord {
    id: i64,
    measurement_id: i64,
    render_id: i64,
    scene: String,
    target: String,
    coding: String,
    observer: String,
    measured_y: f64,
    measured_y_se: f64,
    rendered_y: f64,
    rendered_y_se: f64,
    y_ratio: f64,
    created_at: f64,
}

impl From<LuminanceComparisonRecord> for LuminanceComparisonRow {
    fn from(r: LuminanceComparisonRecord) -> LuminanceComparisonRow {
        LuminanceComparisonRow {
            // Rows are written by this program (see ComparisonRow's).
            observer: r.observer.parse().unwrap_or_default(),
            Y_beyond_noise: lightbooth_science::comparison::beyond_noise(
                r.rendered_y - r.measured_y,
                r.rendered_y_se,
                r.measured_y_se,
            ),
            id: r.id,
            measurement_id: r.measurement_id,
            render_id: r.render_id,
            scene: r.scene,
            target: r.target,
            coding: r.coding,
            measured_Y: r.measured_y,
            measured_Y_se: r.measured_y_se,
            rendered_Y: r.rendered_y,
            rendered_Y_se: r.rendered_y_se,
            Y_ratio: r.y_ratio,
            created_at: r.created_at,
        }
    }
}

/// A study run as the API lists it.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct StudyRow {
    pub id: i64,
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub request: serde_json::Value,
    pub state: String,
    pub error: Option<String>,
    pub created_at: f64,
    pub finished_at: Option<f64>,
    pub wall_seconds: Option<f64>,
    /// Every figure (only in the detail).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub result: Option<serde_json::Value>,
    /// The report's files, served at `/api/studies/{id}/files/{name}`.
    pub files: Vec<String>,
}

/// A row of `studies`, as stored; `result_json` only when selected (the
/// detail), absent from listings.
#[derive(sqlx::FromRow)]
pub(super) struct StudyRecord {
    id: i64,
    request_json: String,
    state: String,
    error: Option<String>,
    created_at: f64,
    finished_at: Option<f64>,
    wall_seconds: Option<f64>,
    #[sqlx(default)]
    result_json: Option<String>,
}

impl TryFrom<StudyRecord> for StudyRow {
    type Error = StoreError;
    fn try_from(r: StudyRecord) -> Result<StudyRow, StoreError> {
        Ok(StudyRow {
            id: r.id,
            request: parse_json(Some(r.request_json), "studies.request_json")?.unwrap_or_default(),
            state: r.state,
            error: r.error,
            created_at: r.created_at,
            finished_at: r.finished_at,
            wall_seconds: r.wall_seconds,
            result: parse_json(r.result_json, "studies.result_json")?,
            files: Vec::new(),
        })
    }
}
