//! Stored reflectances and illuminants (`migrations/0007`): what
//! [`lightbooth_science::calibration`] computed, with its provenance — the measurements,
//! the standard's calibration file and SHA-256, the time.

use crate::BoxFuture;
use serde::Serialize;

use super::{json_array, now, Store, StoreError};
use lightbooth_science::calibration::illuminant::Illuminant;
use lightbooth_science::calibration::reflectance::{Reflectance, ReflectanceFlags};

/// The white standard's calibration a result was computed with.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct StandardProvenance {
    /// The calibration's file name (or the shipped standard's).
    pub file: String,
    /// SHA-256 of the file's bytes, hex.
    pub sha256: String,
    /// False when the calibration gave no uncertainty (taken as 0).
    pub uncertainty_stated: bool,
}

/// A stored reflectance, as the API sends it.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ReflectanceRow {
    pub id: i64,
    /// The column name of its scene CSV.
    pub name: String,
    pub sample_measurement_id: i64,
    pub standard_measurement_id: i64,
    pub standard: StandardProvenance,
    /// POSIX seconds, UTC.
    pub created_at: f64,
    pub wavelength_nm: Vec<f64>,
    /// ρ(λ) as computed (never clipped).
    pub reflectance: Vec<f64>,
    /// Standard uncertainty of ρ (k = 1).
    pub uncertainty: Vec<f64>,
    pub flags: ReflectanceFlags,
    pub note: String,
}

/// A stored lamp SPD, as the API sends it.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct IlluminantRow {
    pub id: i64,
    pub name: String,
    pub measurement_id: i64,
    pub standard: StandardProvenance,
    pub created_at: f64,
    pub wavelength_nm: Vec<f64>,
    /// Relative spectral power, 100 at 560 nm.
    pub spd: Vec<f64>,
    /// Standard uncertainty of `spd` (k = 1).
    pub uncertainty: Vec<f64>,
    /// The white standard's measured luminance, cd/m².
    #[serde(rename = "Y")]
    pub luminance_cd_m2: f64,
    pub note: String,
}

/// What identifies a result's inputs.
#[derive(Clone, Debug)]
pub struct NewCalibration<'a> {
    pub name: &'a str,
    pub standard: &'a StandardProvenance,
    pub note: &'a str,
}

#[derive(sqlx::FromRow)]
struct ReflectanceRecord {
    id: i64,
    name: String,
    sample_measurement_id: i64,
    standard_measurement_id: i64,
    standard_file: String,
    standard_sha256: String,
    standard_uncertainty_stated: bool,
    created_at: f64,
    wavelength_json: String,
    reflectance_json: String,
    uncertainty_json: String,
    above_one_json: String,
    below_zero_json: String,
    max_reflectance: f64,
    min_reflectance: f64,
    note: String,
}

#[derive(sqlx::FromRow)]
struct IlluminantRecord {
    id: i64,
    name: String,
    measurement_id: i64,
    standard_file: String,
    standard_sha256: String,
    standard_uncertainty_stated: bool,
    created_at: f64,
    wavelength_json: String,
    spd_json: String,
    uncertainty_json: String,
    luminance_cd_m2: f64,
    note: String,
}

fn array(text: &str, what: &str) -> Result<Vec<f64>, StoreError> {
    serde_json::from_str(text).map_err(|e| StoreError::Corrupt {
        what: what.into(),
        err: e.to_string(),
    })
}

impl TryFrom<ReflectanceRecord> for ReflectanceRow {
    type Error = StoreError;
    fn try_from(r: ReflectanceRecord) -> Result<ReflectanceRow, StoreError> {
        Ok(ReflectanceRow {
            id: r.id,
            name: r.name,
            sample_measurement_id: r.sample_measurement_id,
            standard_measurement_id: r.standard_measurement_id,
            standard: StandardProvenance {
                file: r.standard_file,
                sha256: r.standard_sha256,
                uncertainty_stated: r.standard_uncertainty_stated,
            },
            created_at: r.created_at,
            wavelength_nm: array(&r.wavelength_json, "reflectances.wavelength_json")?,
            reflectance: array(&r.reflectance_json, "reflectances.reflectance_json")?,
            uncertainty: array(&r.uncertainty_json, "reflectances.uncertainty_json")?,
            flags: ReflectanceFlags {
                above_one_nm: array(&r.above_one_json, "reflectances.above_one_json")?,
                below_zero_nm: array(&r.below_zero_json, "reflectances.below_zero_json")?,
                max: r.max_reflectance,
                min: r.min_reflectance,
            },
            note: r.note,
        })
    }
}

impl TryFrom<IlluminantRecord> for IlluminantRow {
    type Error = StoreError;
    fn try_from(r: IlluminantRecord) -> Result<IlluminantRow, StoreError> {
        Ok(IlluminantRow {
            id: r.id,
            name: r.name,
            measurement_id: r.measurement_id,
            standard: StandardProvenance {
                file: r.standard_file,
                sha256: r.standard_sha256,
                uncertainty_stated: r.standard_uncertainty_stated,
            },
            created_at: r.created_at,
            wavelength_nm: array(&r.wavelength_json, "illuminants.wavelength_json")?,
            spd: array(&r.spd_json, "illuminants.spd_json")?,
            uncertainty: array(&r.uncertainty_json, "illuminants.uncertainty_json")?,
            luminance_cd_m2: r.luminance_cd_m2,
            note: r.note,
        })
    }
}

impl Store {
    /// Stores a reflectance computed from `sample_id` against `standard_id`.
    pub fn insert_reflectance<'a>(
        &'a self,
        sample_id: i64,
        standard_id: i64,
        c: &'a NewCalibration<'a>,
        r: &'a Reflectance,
    ) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "INSERT INTO reflectances (name, sample_measurement_id, standard_measurement_id, standard_file, \
                 standard_sha256, standard_uncertainty_stated, created_at, wavelength_json, reflectance_json, \
                 uncertainty_json, above_one_json, below_zero_json, max_reflectance, min_reflectance, note) \
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15) RETURNING id",
            )
            .bind(c.name)
            .bind(sample_id)
            .bind(standard_id)
            .bind(&c.standard.file)
            .bind(&c.standard.sha256)
            .bind(c.standard.uncertainty_stated)
            .bind(now())
            .bind(json_array(&r.wavelength_nm))
            .bind(json_array(&r.reflectance))
            .bind(json_array(&r.uncertainty))
            .bind(json_array(&r.flags.above_one_nm))
            .bind(json_array(&r.flags.below_zero_nm))
            .bind(r.flags.max)
            .bind(r.flags.min)
            .bind(c.note)
            .fetch_one(pool)
            .await?))
        })
    }

    pub fn get_reflectance<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<ReflectanceRow>, StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| sqlx::query_as::<_, ReflectanceRecord>(
                "SELECT * FROM reflectances WHERE id = $1"
            )
            .bind(id)
            .fetch_optional(pool)
            .await?)
            .map(ReflectanceRow::try_from)
            .transpose()
        })
    }

    /// Every stored reflectance, newest first.
    pub fn list_reflectances<'a>(&'a self) -> BoxFuture<'a, Result<Vec<ReflectanceRow>, StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| sqlx::query_as::<_, ReflectanceRecord>(
                "SELECT * FROM reflectances ORDER BY id DESC"
            )
            .fetch_all(pool)
            .await?)
            .into_iter()
            .map(ReflectanceRow::try_from)
            .collect()
        })
    }

    /// Stores a lamp SPD computed from the white standard's measurement `measurement_id`.
    pub fn insert_illuminant<'a>(
        &'a self,
        measurement_id: i64,
        luminance_cd_m2: f64,
        c: &'a NewCalibration<'a>,
        s: &'a Illuminant,
    ) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "INSERT INTO illuminants (name, measurement_id, standard_file, standard_sha256, \
                 standard_uncertainty_stated, created_at, wavelength_json, spd_json, uncertainty_json, \
                 luminance_cd_m2, note) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11) RETURNING id",
            )
            .bind(c.name)
            .bind(measurement_id)
            .bind(&c.standard.file)
            .bind(&c.standard.sha256)
            .bind(c.standard.uncertainty_stated)
            .bind(now())
            .bind(json_array(&s.wavelength_nm))
            .bind(json_array(&s.spd))
            .bind(json_array(&s.uncertainty))
            .bind(luminance_cd_m2)
            .bind(c.note)
            .fetch_one(pool)
            .await?))
        })
    }

    pub fn get_illuminant<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<IlluminantRow>, StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| sqlx::query_as::<_, IlluminantRecord>(
                "SELECT * FROM illuminants WHERE id = $1"
            )
            .bind(id)
            .fetch_optional(pool)
            .await?)
            .map(IlluminantRow::try_from)
            .transpose()
        })
    }

    /// Every stored illuminant, newest first.
    pub fn list_illuminants<'a>(&'a self) -> BoxFuture<'a, Result<Vec<IlluminantRow>, StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| sqlx::query_as::<_, IlluminantRecord>(
                "SELECT * FROM illuminants ORDER BY id DESC"
            )
            .fetch_all(pool)
            .await?)
            .into_iter()
            .map(IlluminantRow::try_from)
            .collect()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::EngineKind;
    use crate::test_db::{on_both_engines, TestDb};
    use crate::{Average, NewMeasurement};
    use lightbooth_science::calibration::reflectance::reflectance;
    use lightbooth_science::calibration::MeanSpectrum;

    on_both_engines!(a_reflectance_keeps_its_provenance_and_every_value);

    async fn complete_measurement(store: &Store) -> i64 {
        let id = store
            .create_measurement(&NewMeasurement {
                booth: crate::Booth::default(),
                session_id: None,
                scene: None,
                target: None,
                samples: 2,
                settings_json: serde_json::json!({}),
                note: String::new(),
            })
            .await
            .unwrap();
        store.mark_running(id, None).await.unwrap();
        store
            .complete_measurement(
                id,
                &Average {
                    wavelength_nm: vec![500.0],
                    radiance: vec![1.0],
                    radiance_sd: vec![0.0],
                    luminance_cd_m2: 1.0,
                    x: Some(0.3),
                    y: Some(0.3),
                    luminance_cv: 0.0,
                    xyz: None,
                    observer: None,
                },
            )
            .await
            .unwrap();
        id
    }

    async fn a_reflectance_keeps_its_provenance_and_every_value(engine: EngineKind) {
        let db = TestDb::new(engine).await;
        let store = Store::open(&db.url).await.unwrap();
        let (a, b) = (complete_measurement(&store).await, complete_measurement(&store).await);
        let m = |v: f64| MeanSpectrum {
            wavelength_nm: vec![500.0, 504.0],
            mean: vec![v, v],
            standard_error: vec![0.01, 0.01],
            samples: 5,
        };
        let r = reflectance(&m(1.1), &m(1.0), (&[0.99, 0.99], &[0.005, 0.005])).unwrap();
        let standard = StandardProvenance {
            file: "cert.csv".into(),
            sha256: "ab".repeat(32),
            uncertainty_stated: true,
        };
        let c = NewCalibration {
            name: "tile",
            standard: &standard,
            note: "n",
        };
        let id = store.insert_reflectance(a, b, &c, &r).await.unwrap();
        let row = store.get_reflectance(id).await.unwrap().unwrap();
        assert_eq!((row.sample_measurement_id, row.standard_measurement_id), (a, b));
        assert_eq!(row.standard.sha256, "ab".repeat(32));
        assert!(
            row.standard.uncertainty_stated,
            "a flag: 0/1 on SQLite, a boolean on PostgreSQL"
        );
        assert_eq!(
            row.reflectance, r.reflectance,
            "stored as computed: 1.089, never clipped"
        );
        assert_eq!(row.flags, r.flags);
        assert_eq!(row.flags.above_one_nm, [500.0, 504.0]);
        assert_eq!(store.list_reflectances().await.unwrap().len(), 1);
        assert!(store.get_reflectance(id + 1).await.unwrap().is_none());
    }
}
