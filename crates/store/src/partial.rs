//! What an unfinished measurement still says: the average of the good
//! samples of an interrupted or cancelled measurement, computed when it is
//! read (so measurements interrupted by a crash or a pulled cable get one
//! too) and always marked `partial`. It is never written as the
//! measurement's average: only a complete measurement has one, and only a
//! complete measurement is ever compared or used by a study.
//!
//! The average is the one a complete measurement gets
//! ([`average_samples`](lightbooth_instrument::average_samples)): the mean
//! spectrum of the usable samples, its `Y`, `x`, `y`, `XYZ` with the
//! store's observer ([`Store::with_observer`]), the instrument's own CIE
//! 1931 values beside them (`instrument_Y`, `instrument_x`,
//! `instrument_y`), and the luminance CV over those samples. A
//! colorimeter's or luminance meter's samples (no spectrum) give their mean
//! XYZ or luminance in the instrument's own observer, as its complete
//! measurements do.

use std::time::{Duration, UNIX_EPOCH};

use super::{parse_opt_array, MeasurementState, MeasurementSummary, Store, StoreError};
use lightbooth_instrument::{average_samples, InstrumentInfo, QualityCode, QualityKind, Reading, Sample};
use lightbooth_science::spectrum::{SpectralUnit, Spectrum};

impl Store {
    /// Fills `Y`, `x`, `y`, `luminance_cv` and `partial` of every interrupted
    /// or cancelled measurement in `items` that has good samples.
    pub(super) async fn fill_partial_averages(&self, items: &mut [MeasurementSummary]) -> Result<(), StoreError> {
        for m in items.iter_mut() {
            let unfinished = matches!(m.state, MeasurementState::Interrupted | MeasurementState::Cancelled);
            if !unfinished || m.good_samples == 0 || m.instrument_luminance_cd_m2.is_some() {
                continue;
            }
            let reading = m
                .instrument_model
                .as_deref()
                .and_then(lightbooth_instrument::reading_of_model)
                .unwrap_or(Reading::Spectrum);
            if reading != Reading::Spectrum {
                self.fill_partial_reading(m, reading).await?;
                continue;
            }
            let rows: Vec<(i64, f64, Option<String>, Option<f64>)> = with_pool!(self, |pool| sqlx::query_as(
                "SELECT idx, taken_at, radiance_json, luminance_cd_m2 FROM samples \
                 WHERE measurement_id = $1 AND usable = TRUE AND radiance_json IS NOT NULL ORDER BY idx",
            )
            .bind(m.id)
            .fetch_all(pool)
            .await?);
            let mut samples = Vec::with_capacity(rows.len());
            for (idx, taken_at, radiance_json, luminance) in rows {
                let values = parse_opt_array(radiance_json, "sample radiance")?.unwrap_or_default();
                samples.push((idx, taken_at, values, luminance));
            }
            let observer = m.observer.unwrap_or(self.observer);
            match partial_average(samples) {
                Ok(avg) => {
                    // The instrument's CIE 1931 values, labelled as its own;
                    // `Y`, `x`, `y`, `XYZ` with the observer, as for a
                    // complete measurement.
                    m.instrument_luminance_cd_m2 = Some(avg.luminance_cd_m2);
                    m.instrument_x = avg.x;
                    m.instrument_y = avg.y;
                    match avg
                        .mean
                        .as_ref()
                        .ok_or_else(|| "no spectrum".to_string())
                        .and_then(|mean| {
                            lightbooth_science::colorimetry::xyz_from_radiance(mean, observer)
                                .map_err(|e| e.to_string())
                        }) {
                        Ok(xyz) => {
                            let xy = xyz.chromaticity();
                            m.luminance_cd_m2 = Some(xyz.y);
                            m.x = Some(xy.x);
                            m.y = Some(xy.y);
                            m.xyz = Some(xyz.to_array());
                            m.observer = Some(observer);
                        }
                        Err(e) => tracing::warn!(measurement_id = m.id, error = %e, "no XYZ of the partial average"),
                    }
                    m.luminance_cv = Some(avg.luminance_cv);
                    m.partial = true;
                }
                Err(e) => tracing::warn!(measurement_id = m.id, error = %e, "no partial average"),
            }
        }
        Ok(())
    }

    /// The partial average of a colorimeter's or a luminance meter's
    /// samples: their mean XYZ (or luminance) and the CV of their
    /// luminance, in the instrument's own observer, as a complete
    /// measurement of it has.
    async fn fill_partial_reading(&self, m: &mut MeasurementSummary, reading: Reading) -> Result<(), StoreError> {
        let rows: Vec<(i64, f64, Option<String>, Option<f64>)> = with_pool!(self, |pool| sqlx::query_as(
            "SELECT idx, taken_at, xyz_json, luminance_cd_m2 FROM samples \
             WHERE measurement_id = $1 AND usable = TRUE ORDER BY idx",
        )
        .bind(m.id)
        .fetch_all(pool)
        .await?);
        let mut samples = Vec::with_capacity(rows.len());
        for (idx, taken_at, xyz_json, luminance) in rows {
            let xyz = parse_opt_array(xyz_json, "sample XYZ")?.and_then(|v| <[f64; 3]>::try_from(v).ok());
            samples.push(Sample {
                index: idx as usize,
                time: UNIX_EPOCH + Duration::from_secs_f64(taken_at.max(0.0)),
                code: QualityCode {
                    code: 0,
                    kind: QualityKind::Ok,
                    message: "stored as usable".into(),
                },
                radiance: None,
                luminance,
                instrument_xyz: xyz,
            });
        }
        let info = InstrumentInfo {
            model: m.instrument_model.clone().unwrap_or_default(),
            serial: None,
            firmware: None,
            grid: lightbooth_science::spectrum::Grid::one_nm(),
        };
        match average_samples(info, reading, samples) {
            Ok(avg) => {
                let (xyz, observer) = match reading {
                    Reading::Tristimulus { observer } => (avg.instrument_xyz, Some(observer)),
                    Reading::Luminance { observer } => (None, Some(observer)),
                    Reading::Spectrum => (None, None),
                };
                let xy = xyz.map(|v| lightbooth_science::colorimetry::Xyz::from_array(v).chromaticity());
                m.instrument_luminance_cd_m2 = Some(avg.luminance_cd_m2);
                m.luminance_cd_m2 = xyz.map(|v| v[1]).or(Some(avg.luminance_cd_m2));
                m.xyz = xyz;
                m.x = xy.map(|c| c.x);
                m.y = xy.map(|c| c.y);
                m.observer = observer;
                m.luminance_cv = Some(avg.luminance_cv);
                m.partial = true;
            }
            Err(e) => tracing::warn!(measurement_id = m.id, error = %e, "no partial average"),
        }
        Ok(())
    }
}

/// The average of stored good samples `(index, time, radiance, Y)`. The
/// store keeps sample spectra on the instrument's native grid without the
/// grid itself; it is found from their length
/// ([`lightbooth_instrument::native_grid_of_length`]),
/// and any other length is an error, not a guess.
fn partial_average(
    samples: Vec<(i64, f64, Vec<f64>, Option<f64>)>,
) -> Result<lightbooth_instrument::AveragedMeasurement, String> {
    let len = samples.first().map_or(0, |s| s.2.len());
    let grid = lightbooth_instrument::native_grid_of_length(len).ok_or_else(|| {
        format!("stored samples have {len} spectral values: no instrument lightbooth drives has that grid (101 or 201 points)")
    })?;
    let samples = samples
        .into_iter()
        .map(|(index, time, values, luminance)| {
            if values.len() != grid.len() {
                return Err(format!(
                    "sample {index} has {} spectral values, not the {} of the series' first sample",
                    values.len(),
                    grid.len()
                ));
            }
            Ok(Sample {
                index: index as usize,
                time: UNIX_EPOCH + Duration::from_secs_f64(time.max(0.0)),
                code: QualityCode {
                    code: 0,
                    kind: QualityKind::Ok,
                    message: "stored as usable".into(),
                },
                radiance: Some(
                    Spectrum::new(grid.clone(), SpectralUnit::SpectralRadiance, values).map_err(|e| e.to_string())?,
                ),
                luminance,
                instrument_xyz: None,
            })
        })
        .collect::<Result<Vec<_>, String>>()?;
    let info = InstrumentInfo {
        model: "stored samples".into(),
        serial: None,
        firmware: None,
        grid,
    };
    average_samples(info, lightbooth_instrument::Reading::Spectrum, samples)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An interrupted PR-670 measurement's stored samples have 201 values;
    /// the partial average assumed the PR-650's 101 and refused them.
    #[test]
    fn partial_averages_of_pr670_samples_were_refused() {
        let samples = vec![
            (0, 1.0, vec![1.0; 201], Some(10.0)),
            (1, 2.0, vec![3.0; 201], Some(30.0)),
        ];
        let m = partial_average(samples).unwrap();
        assert_eq!(
            m.mean.as_ref().unwrap().grid().wavelengths()[1],
            382.0,
            "the PR-670's 2 nm grid"
        );
        assert!(m
            .mean
            .as_ref()
            .unwrap()
            .values()
            .iter()
            .all(|v| (v - 2.0).abs() < 1e-12));
        let pr650 = partial_average(vec![(0, 1.0, vec![1.0; 101], None)]).unwrap();
        assert_eq!(pr650.mean.as_ref().unwrap().grid().wavelengths()[1], 384.0);
        let e = partial_average(vec![(0, 1.0, vec![1.0; 81], None)]).unwrap_err();
        assert!(e.contains("81"), "{e}");
    }
}
