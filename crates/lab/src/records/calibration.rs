//! The calibrations from stored measurements: reads the measurements from
//! the store, checks that each is complete and has enough good samples,
//! runs the physics ([`lightbooth_science::calibration::reflectance`],
//! [`lightbooth_science::calibration::illuminant`]) on the raw samples, and stores the
//! result with its provenance. The I/O around the pure
//! [`lightbooth_science::calibration`]; the REST API and the CLI share it.

use lightbooth_science::calibration::illuminant::{self, Illuminant};
use lightbooth_science::calibration::reflectance::{self, OutOfRange, Reflectance};
use lightbooth_science::calibration::standard::WhiteStandard;
use lightbooth_science::calibration::{CalibrationError, MeanSpectrum};
use lightbooth_store::{
    IlluminantRow, MeasurementDetail, MeasurementState, NewCalibration, ReflectanceRow, StandardProvenance, Store,
    StoreError,
};

/// Why a calibration could not be made; the API maps these to 400, 404
/// (no such result), 409 and 500.
#[derive(Debug, thiserror::Error)]
pub enum MeasuredError {
    /// A field of the request is wrong (unknown measurement, bad name, bad CSV).
    #[error("{0}")]
    Invalid(String),
    /// A measurement is not complete.
    #[error("{0}")]
    WrongState(String),
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// A column name the scene CSV can carry: a letter, then letters, digits or
/// `_`, at most 64.
pub fn check_name(name: &str) -> Result<(), MeasuredError> {
    let ok = name.len() <= 64
        && name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if ok {
        Ok(())
    } else {
        Err(MeasuredError::Invalid(format!(
            "field `name`: `{name}` is not a column name (a letter, then letters, digits or `_`, at most 64)"
        )))
    }
}

/// The measurement `id` (named `field` in errors), complete, with its
/// good samples reduced to their mean and standard error.
async fn measured(store: &Store, field: &str, id: i64) -> Result<(MeasurementDetail, MeanSpectrum), MeasuredError> {
    let m = store
        .get_measurement(id)
        .await?
        .ok_or_else(|| MeasuredError::Invalid(format!("field `{field}`: no measurement {id}")))?;
    if m.summary.state != MeasurementState::Complete {
        return Err(MeasuredError::WrongState(format!(
            "field `{field}`: measurement {id} is {}; only a complete measurement gives a calibration",
            m.summary.state.as_str()
        )));
    }
    let grid = crate::measure::recorder::stored_spectrum(&m, "a reflectance or a lamp's spectrum")
        .map_err(|e| MeasuredError::Invalid(format!("field `{field}`: {e}")))?
        .0
        .to_vec();
    let good: Vec<&[f64]> = m
        .samples
        .iter()
        .filter(|s| s.usable)
        .filter_map(|s| s.radiance.as_deref())
        .collect();
    let mean = MeanSpectrum::from_samples(&format!("measurement {id} ({field})"), &grid, &good)
        .map_err(|e| MeasuredError::Invalid(e.to_string()))?;
    Ok((m, mean))
}

fn provenance(standard: &WhiteStandard) -> StandardProvenance {
    StandardProvenance {
        file: standard.file_name.clone(),
        sha256: standard.sha256.clone(),
        uncertainty_stated: standard.uncertainty_stated(),
    }
}

fn invalid(e: CalibrationError) -> MeasuredError {
    MeasuredError::Invalid(e.to_string())
}

/// Computes and stores ρ(λ) of `sample_id` against `standard_id`.
pub async fn create_reflectance(
    store: &Store,
    sample_id: i64,
    standard_id: i64,
    standard: &WhiteStandard,
    name: &str,
    note: &str,
) -> Result<ReflectanceRow, MeasuredError> {
    check_name(name)?;
    if sample_id == standard_id {
        return Err(MeasuredError::Invalid(format!(
            "fields `sample_measurement_id` and `standard_measurement_id` are both {sample_id}: \
             measure the white standard and the sample separately"
        )));
    }
    let (_, sample) = measured(store, "sample_measurement_id", sample_id).await?;
    let (_, white) = measured(store, "standard_measurement_id", standard_id).await?;
    let on_grid = standard.on_grid(&white.wavelength_nm).map_err(invalid)?;
    let r: Reflectance = reflectance::reflectance(&sample, &white, (&on_grid.0, &on_grid.1)).map_err(invalid)?;
    let prov = provenance(standard);
    let id = store
        .insert_reflectance(
            sample_id,
            standard_id,
            &NewCalibration {
                name,
                standard: &prov,
                note,
            },
            &r,
        )
        .await?;
    Ok(store.get_reflectance(id).await?.expect("the row just written"))
}

/// Computes and stores the lamp SPD from the white standard's measurement `id`.
pub async fn create_illuminant(
    store: &Store,
    id: i64,
    standard: &WhiteStandard,
    name: &str,
    note: &str,
) -> Result<IlluminantRow, MeasuredError> {
    check_name(name)?;
    let (m, white) = measured(store, "measurement_id", id).await?;
    let on_grid = standard.on_grid(&white.wavelength_nm).map_err(invalid)?;
    let s: Illuminant = illuminant::illuminant(&white, (&on_grid.0, &on_grid.1)).map_err(invalid)?;
    // A complete measurement has its luminance (the schema enforces it).
    let luminance = m
        .summary
        .luminance_cd_m2
        .ok_or_else(|| MeasuredError::Invalid(format!("field `measurement_id`: measurement {id} has no luminance")))?;
    let prov = provenance(standard);
    let row_id = store
        .insert_illuminant(
            id,
            luminance,
            &NewCalibration {
                name,
                standard: &prov,
                note,
            },
            &s,
        )
        .await?;
    Ok(store.get_illuminant(row_id).await?.expect("the row just written"))
}

/// Where a measurement came from, for a provenance line.
async fn describe(store: &Store, id: i64) -> Result<String, StoreError> {
    Ok(match store.get_measurement(id).await? {
        Some(m) => {
            let s = &m.summary;
            let place = match (&s.scene, &s.target) {
                (Some(scene), Some(target)) => format!("scene {scene}, target {target}"),
                _ => "no scene".to_string(),
            };
            format!(
                "measurement {id} ({place}; {} good samples; finished {} POSIX s)",
                s.good_samples,
                s.finished_at.unwrap_or(f64::NAN)
            )
        }
        None => format!("measurement {id} (no longer in the database)"),
    })
}

fn standard_line(s: &StandardProvenance) -> String {
    format!(
        "standard's calibration: {} (sha256 {}){}",
        s.file,
        s.sha256,
        if s.uncertainty_stated {
            ""
        } else {
            "; it states no uncertainty, taken as 0"
        }
    )
}

/// A stored reflectance as a scene spectrum CSV with its provenance header.
pub async fn reflectance_csv(
    store: &Store,
    row: &ReflectanceRow,
    out_of_range: OutOfRange,
) -> Result<String, MeasuredError> {
    let lines = vec![
        format!(
            "lightbooth reflectance {} `{}`, created {} POSIX s (UTC)",
            row.id, row.name, row.created_at
        ),
        "rho = L_sample / L_standard * rho_standard on the instrument's grid; \
         column <name>_u: its standard uncertainty (k = 1)"
            .to_string(),
        format!("sample: {}", describe(store, row.sample_measurement_id).await?),
        format!(
            "white standard: {}",
            describe(store, row.standard_measurement_id).await?
        ),
        standard_line(&row.standard),
        format!(
            "use in a scene: reflectance = \"spectra/{}.csv:{}\"",
            row.name, row.name
        ),
    ];
    let r = Reflectance {
        wavelength_nm: row.wavelength_nm.clone(),
        reflectance: row.reflectance.clone(),
        uncertainty: row.uncertainty.clone(),
        flags: row.flags.clone(),
    };
    reflectance::scene_csv(&r, &row.name, &lines, out_of_range).map_err(MeasuredError::WrongState)
}

/// A stored illuminant as a scene spectrum CSV with its provenance header.
pub async fn illuminant_csv(store: &Store, row: &IlluminantRow) -> Result<String, MeasuredError> {
    let lines = vec![
        format!(
            "lightbooth illuminant {} `{}`, created {} POSIX s (UTC)",
            row.id, row.name, row.created_at
        ),
        format!(
            "relative SPD = L_standard / rho_standard, 100 at {} nm; column <name>_u: its standard uncertainty (k = 1)",
            illuminant::NORMALISATION_NM
        ),
        format!(
            "white standard: {}; luminance {} cd/m2",
            describe(store, row.measurement_id).await?,
            row.luminance_cd_m2
        ),
        standard_line(&row.standard),
        format!(
            "use in a scene: spd = \"spectra/{}.csv:{}\" on a [[light]]",
            row.name, row.name
        ),
    ];
    let s = Illuminant {
        wavelength_nm: row.wavelength_nm.clone(),
        spd: row.spd.clone(),
        uncertainty: row.uncertainty.clone(),
    };
    illuminant::scene_csv(&s, &row.name, &lines).map_err(MeasuredError::Invalid)
}
