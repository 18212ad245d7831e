//! Measurements and their raw samples: queued, running, each sample as it
//! is taken, then complete with the average (or failed, interrupted,
//! cancelled, with what was kept).

use super::*;
use crate::BoxFuture;

/// The key of a measurement's settings that records a simulated truth's
/// relative standard error of Y ([`Store::record_simulated_truth`]).
pub const SIMULATED_TRUTH_KEY: &str = "simulated_truth_relative_se";

impl Store {
    /// Records a requested measurement as `queued`.
    pub fn create_measurement<'a>(&'a self, m: &'a NewMeasurement) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move { self.create_held_measurement(m, None).await })
    }

    /// Records an instrument hold taken in `booth` for `purpose`; its id,
    /// drawn from the database so that no two holds share one, across
    /// daemon restarts and the daemons of one database (issue 46).
    pub fn record_instrument_hold<'a>(
        &'a self,
        booth: &'a Booth,
        purpose: &'a str,
    ) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| {
                sqlx::query_scalar(
                    "INSERT INTO instrument_holds (booth, purpose, taken_at, daemon_id) VALUES ($1, $2, $3, $4) \
                     RETURNING id",
                )
                .bind(booth.as_str())
                .bind(purpose)
                .bind(now())
                .bind(self.daemon_id)
                .fetch_one(pool)
                .await?
            }))
        })
    }

    /// Records a requested measurement as `queued`, taken under the
    /// instrument hold `hold` (its id and purpose) when one is given.
    pub fn create_held_measurement<'a>(
        &'a self,
        m: &'a NewMeasurement,
        hold: Option<(i64, &'a str)>,
    ) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| {
                sqlx::query_scalar(
                "INSERT INTO measurements (booth, session_id, scene, target, samples_requested, settings_json, state, note, created_at, daemon_id, hold_id, hold_purpose) \
                 VALUES ($1, $2, $3, $4, $5, $6, 'queued', $7, $8, $9, $10, $11) RETURNING id",
            )
            .bind(m.booth.as_str())
            .bind(m.session_id)
            .bind(&m.scene)
            .bind(&m.target)
            .bind(m.samples as i64)
            .bind(m.settings_json.to_string())
            .bind(&m.note)
            .bind(now())
            .bind(self.daemon_id)
            .bind(hold.map(|h| h.0))
            .bind(hold.map(|h| h.1))
            .fetch_one(pool)
            .await?
            }))
        })
    }

    /// `queued → running`, naming the instrument that takes it.
    pub fn mark_running<'a>(&'a self, id: i64, instrument_id: Option<i64>) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            let n = with_pool!(self, |pool| {
                sqlx::query(
                    "UPDATE measurements SET state = 'running', instrument_id = $1, started_at = $2, \
                 daemon_id = COALESCE($4, daemon_id) WHERE id = $3 AND state = 'queued'",
                )
                .bind(instrument_id)
                .bind(now())
                .bind(id)
                .bind(self.daemon_id)
                .execute(pool)
                .await?
                .rows_affected()
            });
            if n != 1 {
                return Err(StoreError::Conflict(format!("measurement {id} is not queued")));
            }
            Ok(())
        })
    }

    /// Writes one raw sample, as it is taken.
    pub fn insert_sample<'a>(&'a self, measurement_id: i64, s: &'a NewSample) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| {
                sqlx::query(
                "INSERT INTO samples (measurement_id, idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2, xyz_json) \
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9)",
            )
            .bind(measurement_id)
            .bind(s.index as i64)
            .bind(s.taken_at)
            .bind(s.code)
            .bind(&s.message)
            .bind(s.usable)
            .bind(s.radiance.as_ref().map(|r| json_array(r)))
            .bind(s.luminance_cd_m2)
            .bind(s.instrument_xyz.map(|v| json_array(&v)))
            .execute(pool)
            .await?
            .rows_affected()
            });
            Ok(())
        })
    }

    /// Records on measurement `id` that a simulated instrument took it, aimed
    /// at a truth of relative standard error of Y `relative_se` (kept in its
    /// settings, read back as [`MeasurementDetail::simulated_truth_relative_se`]).
    pub fn record_simulated_truth<'a>(&'a self, id: i64, relative_se: f64) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            let settings: Option<String> = with_pool!(self, |pool| {
                sqlx::query_scalar("SELECT settings_json FROM measurements WHERE id = $1")
                    .bind(id)
                    .fetch_optional(pool)
                    .await?
            });
            let Some(settings) = settings else {
                return Err(StoreError::Conflict(format!("no measurement {id}")));
            };
            let mut value: serde_json::Value =
                serde_json::from_str(&settings).unwrap_or_else(|_| serde_json::json!({}));
            if !value.is_object() {
                value = serde_json::json!({});
            }
            value[SIMULATED_TRUTH_KEY] = serde_json::json!(relative_se);
            with_pool!(self, |pool| {
                sqlx::query("UPDATE measurements SET settings_json = $1 WHERE id = $2")
                    .bind(value.to_string())
                    .bind(id)
                    .execute(pool)
                    .await?
                    .rows_affected()
            });
            Ok(())
        })
    }

    /// `running → complete` with the average; one transaction.
    pub fn complete_measurement<'a>(&'a self, id: i64, a: &'a Average) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            let n = with_pool!(self, |pool| {
                sqlx::query(
                "UPDATE measurements SET state = 'complete', finished_at = $1, wavelength_json = $2, radiance_json = $3, \
                 radiance_sd_json = $4, luminance_cd_m2 = $5, x = $6, y = $7, luminance_cv = $8, observer = $9, xyz_x = $10, \
                 xyz_y = $11, xyz_z = $12 WHERE id = $13 AND state = 'running'",
            )
            .bind(now())
            // No spectrum (a colorimeter's measurement): NULL, not `[]`.
            .bind((!a.radiance.is_empty()).then(|| json_array(&a.wavelength_nm)))
            .bind((!a.radiance.is_empty()).then(|| json_array(&a.radiance)))
            .bind((!a.radiance.is_empty()).then(|| json_array(&a.radiance_sd)))
            .bind(a.luminance_cd_m2)
            .bind(a.x)
            .bind(a.y)
            .bind(a.luminance_cv)
            .bind(a.observer.map(|o| o.name()))
            .bind(a.xyz.map(|v| v[0]))
            .bind(a.xyz.map(|v| v[1]))
            .bind(a.xyz.map(|v| v[2]))
            .bind(id)
            .execute(pool)
            .await?
            .rows_affected()
            });
            if n != 1 {
                return Err(StoreError::Conflict(format!("measurement {id} is not running")));
            }
            self.wrote();
            Ok(())
        })
    }

    /// Ends an unfinished measurement as failed, interrupted or cancelled.
    pub fn end_measurement<'a>(
        &'a self,
        id: i64,
        state: MeasurementState,
        error: &'a str,
    ) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            debug_assert!(state.is_final() && state != MeasurementState::Complete);
            with_pool!(self, |pool| {
                sqlx::query(
                "UPDATE measurements SET state = $1, error = $2, finished_at = $3 WHERE id = $4 AND state IN ('queued', 'running')",
            )
            .bind(state.as_str())
            .bind(error)
            .bind(now())
            .bind(id)
            .execute(pool)
            .await?
            .rows_affected()
            });
            Ok(())
        })
    }

    /// `queued → cancelled`, only while it is still queued (so a measurement
    /// the instrument has started is never ended here). True when it was.
    pub fn cancel_queued<'a>(&'a self, id: i64, message: &'a str) -> BoxFuture<'a, Result<bool, StoreError>> {
        Box::pin(async move {
            let n = with_pool!(self, |pool| {
                sqlx::query(
                "UPDATE measurements SET state = 'cancelled', error = $1, finished_at = $2 WHERE id = $3 AND state = 'queued'",
            )
            .bind(message)
            .bind(now())
            .bind(id)
            .execute(pool)
            .await?
            .rows_affected()
            });
            Ok(n == 1)
        })
    }

    /// The version of what the scenes' overview reads besides the
    /// comparisons (`lightbooth_lab::compare::overview`): the number of
    /// complete measurements of `booth` and the newest of them, and the
    /// newest render with a preview image.
    pub fn overview_inputs<'a>(&'a self, booth: &'a Booth) -> BoxFuture<'a, Result<crate::InputsVersion, StoreError>> {
        Box::pin(async move {
            let (complete, newest, preview): (i64, i64, i64) = with_pool!(self, |pool| sqlx::query_as(
                "SELECT (SELECT COUNT(*) FROM measurements WHERE booth = $1 AND state = 'complete'), \
                 (SELECT COALESCE(MAX(id), 0) FROM measurements WHERE booth = $1 AND state = 'complete'), \
                 (SELECT COALESCE(MAX(id), 0) FROM renders WHERE state = 'complete' AND preview_png IS NOT NULL)",
            )
            .bind(booth.as_str())
            .fetch_one(pool)
            .await?);
            Ok(crate::InputsVersion([complete, newest, preview, 0]))
        })
    }

    /// The ids of the queued and running measurements of `booth`, oldest first.
    pub fn unfinished_measurements_in_booth<'a>(
        &'a self,
        booth: &'a Booth,
    ) -> BoxFuture<'a, Result<Vec<i64>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "SELECT id FROM measurements WHERE booth = $1 AND state IN ('queued', 'running') ORDER BY id",
            )
            .bind(booth.as_str())
            .fetch_all(pool)
            .await?))
        })
    }

    /// Every (scene, target) with at least one complete measurement in `booth`.
    pub fn measured_targets<'a>(
        &'a self,
        booth: &'a Booth,
    ) -> BoxFuture<'a, Result<Vec<(String, String)>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_as(
                "SELECT DISTINCT scene, target FROM measurements \
                 WHERE state = 'complete' AND scene IS NOT NULL AND target IS NOT NULL AND booth = $1",
            )
            .bind(booth.as_str())
            .fetch_all(pool)
            .await?))
        })
    }

    /// The complete measurements of a scene target taken in `booth` that
    /// have no comparison (colour or luminance) and no comparison queued or
    /// running on a render worker, oldest first: those left uncompared.
    pub fn uncompared_measurements<'a>(&'a self, booth: &'a Booth) -> BoxFuture<'a, Result<Vec<i64>, StoreError>> {
        Box::pin(async move {
            let ids: Vec<(i64,)> = with_pool!(self, |pool| sqlx::query_as(
                "SELECT m.id FROM measurements m \
                 WHERE m.state = 'complete' AND m.scene IS NOT NULL AND m.target IS NOT NULL AND m.booth = $1 \
                 AND NOT EXISTS (SELECT 1 FROM comparisons c WHERE c.measurement_id = m.id) \
                 AND NOT EXISTS (SELECT 1 FROM luminance_comparisons l WHERE l.measurement_id = m.id) \
                 AND NOT EXISTS (SELECT 1 FROM worker_jobs w WHERE w.kind = 'comparison' \
                     AND w.subject_id = m.id AND w.state IN ('queued', 'running')) \
                 ORDER BY m.id",
            )
            .bind(booth.as_str())
            .fetch_all(pool)
            .await?);
            Ok(ids.into_iter().map(|(id,)| id).collect())
        })
    }

    /// One measurement with all its samples.
    pub fn get_measurement<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<MeasurementDetail>, StoreError>> {
        Box::pin(async move {
            let sql = format!(
                "SELECT {MEASUREMENT_COLUMNS}, wavelength_json, radiance_json, radiance_sd_json, settings_json \
                 FROM measurements WHERE id = $1"
            );
            let record: Option<MeasurementDetailRecord> =
                with_pool!(self, |pool| sqlx::query_as(&sql).bind(id).fetch_optional(pool).await?);
            let Some(record) = record else {
                return Ok(None);
            };
            let mut summary = MeasurementSummary::try_from(record.summary)?;
            self.fill_partial_averages(std::slice::from_mut(&mut summary)).await?;
            let sample_records: Vec<SampleRecord> = with_pool!(self, |pool| {
                sqlx::query_as(
                "SELECT idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2, xyz_json FROM samples \
                 WHERE measurement_id = $1 ORDER BY idx",
            )
            .bind(id)
            .fetch_all(pool)
            .await?
            });
            let mut samples = sample_records
                .into_iter()
                .map(SampleRow::try_from)
                .collect::<Result<Vec<_>, StoreError>>()?;
            // Each sample's Y from its spectrum with the measurement's observer,
            // the same one as the measurement's `Y` (never the instrument's own).
            let observer = summary.observer.unwrap_or(self.observer);
            // A sample without a spectrum (a colorimeter's) has the Y it reported,
            // in the observer the measurement names.
            for s in &mut samples {
                s.luminance_cd_m2 = match &s.radiance {
                    Some(values) => sample_luminance(values, observer),
                    None => s.instrument_xyz.map(|v| v[1]).or(s.instrument_luminance_cd_m2),
                };
            }
            Ok(Some(MeasurementDetail {
                summary,
                wavelength_nm: parse_opt_array(record.wavelength_json, "wavelengths")?,
                radiance: parse_opt_array(record.radiance_json, "mean radiance")?,
                radiance_sd: parse_opt_array(record.radiance_sd_json, "radiance SD")?,
                simulated_truth_relative_se: serde_json::from_str::<serde_json::Value>(&record.settings_json)
                    .ok()
                    .and_then(|v| v.get(SIMULATED_TRUTH_KEY).and_then(|v| v.as_f64())),
                samples,
            }))
        })
    }

    /// A page of measurements, newest first, with optional filters.
    pub fn list_measurements<'a>(
        &'a self,
        f: &'a MeasurementFilter,
    ) -> BoxFuture<'a, Result<MeasurementPage, StoreError>> {
        Box::pin(async move {
            // The filters' values, in the order of their `$N` placeholders.
            let mut values: Vec<String> = Vec::new();
            let mut conditions = Vec::new();
            for (column, value) in [
                ("booth", f.booth.as_ref().map(|b| b.as_str().to_string())),
                ("scene", f.scene.clone()),
                ("target", f.target.clone()),
                ("state", f.state.map(|s| s.as_str().to_string())),
            ] {
                if let Some(v) = value {
                    values.push(v);
                    conditions.push(format!("{column} = ${}", values.len()));
                }
            }
            if let Some(model) = &f.instrument_model {
                values.push(model.clone());
                conditions.push(format!(
                    "instrument_id IN (SELECT i.id FROM instruments i WHERE i.model = ${})",
                    values.len()
                ));
            }
            // No `WHERE 1 = 1`: an unfiltered COUNT(*) then uses SQLite's fast path.
            let where_sql = if conditions.is_empty() {
                String::new()
            } else {
                format!(" WHERE {}", conditions.join(" AND "))
            };
            // Unfiltered or by booth alone, the total is the booths' counts
            // (migration 0014): counting the rows costs O(rows) per request.
            let count_sql = match (&f.booth, values.len()) {
                (_, 0) => "SELECT CAST(COALESCE(SUM(measurements), 0) AS BIGINT) FROM booth_measurement_counts".to_string(),
                (Some(_), 1) => {
                    "SELECT CAST(COALESCE(SUM(measurements), 0) AS BIGINT) FROM booth_measurement_counts WHERE booth = $1"
                        .into()
                }
                _ => format!("SELECT COUNT(*) FROM measurements{where_sql}"),
            };
            let limit = f.limit.unwrap_or(50).clamp(1, 1000);
            let offset = f.offset.unwrap_or(0).max(0);
            // The page's ids come from the primary key alone; only those rows'
            // columns (and sample counts) are computed. With the columns in the
            // paging query itself, SQLite evaluates them for every skipped row.
            // `before_id` pages by the primary key (an index range, the same
            // cost at any depth); the total ignores it, as it ignores `offset`.
            let page_where = match (f.before_id, where_sql.is_empty()) {
                (None, _) => where_sql.clone(),
                (Some(before), true) => format!(" WHERE id < {before}"),
                (Some(before), false) => format!("{where_sql} AND id < {before}"),
            };
            let list_sql = format!(
                "SELECT {MEASUREMENT_COLUMNS} FROM measurements WHERE id IN (\
                 SELECT id FROM measurements{page_where} ORDER BY id DESC LIMIT {limit} OFFSET {offset}) ORDER BY id DESC"
            );
            let (total, records): (i64, Vec<MeasurementRecord>) = with_pool!(self, |pool| {
                let mut count = sqlx::query_scalar(&count_sql);
                let mut list = sqlx::query_as(&list_sql);
                for v in &values {
                    count = count.bind(v.as_str());
                    list = list.bind(v.as_str());
                }
                (count.fetch_one(pool).await?, list.fetch_all(pool).await?)
            });
            let mut items = records
                .into_iter()
                .map(MeasurementSummary::try_from)
                .collect::<Result<Vec<_>, _>>()?;
            self.fill_partial_averages(&mut items).await?;
            Ok(MeasurementPage {
                total,
                limit,
                offset,
                items,
            })
        })
    }

    /// The newest complete measurement of a scene target taken in `booth`:
    /// the CIELAB white of that booth's comparisons (each booth has its own
    /// lamps, so another booth's white never stands in for it).
    pub fn latest_complete_in_booth<'a>(
        &'a self,
        scene: &'a str,
        target: &'a str,
        booth: &'a Booth,
    ) -> BoxFuture<'a, Result<Option<MeasurementDetail>, StoreError>> {
        Box::pin(async move {
            let id: Option<i64> = with_pool!(self, |pool| {
                sqlx::query_scalar(
                    "SELECT id FROM measurements WHERE scene = $1 AND target = $2 AND booth = $3 AND state = 'complete' \
                     ORDER BY id DESC LIMIT 1",
                )
                .bind(scene)
                .bind(target)
                .bind(booth.as_str())
                .fetch_optional(pool)
                .await?
            });
            match id {
                Some(id) => self.get_measurement(id).await,
                None => Ok(None),
            }
        })
    }

    /// The booth a measurement was taken in; `None` when there is no such
    /// measurement.
    pub fn measurement_booth<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<Booth>, StoreError>> {
        Box::pin(async move {
            let booth: Option<String> = with_pool!(self, |pool| {
                sqlx::query_scalar("SELECT booth FROM measurements WHERE id = $1")
                    .bind(id)
                    .fetch_optional(pool)
                    .await?
            });
            booth
                .map(|b| {
                    b.parse().map_err(|e: String| StoreError::Corrupt {
                        what: format!("measurement {id}'s booth"),
                        err: e,
                    })
                })
                .transpose()
        })
    }
}
