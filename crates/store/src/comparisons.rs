//! Comparisons of measurements with every coding, and their whites kept
//! current.

use super::*;
use crate::BoxFuture;

impl Store {
    /// Stores the comparisons of one measurement against one render, all
    /// codings in one transaction (all or nothing).
    pub fn insert_comparisons<'a>(&'a self, rows: &'a [NewComparison]) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| {
                let mut tx = pool.begin().await?;
                for c in rows {
                    sqlx::query(
                        "INSERT INTO comparisons (measurement_id, render_id, scene, target, coding, white_source, \
                         white_x, white_y, white_z, measured_x, measured_y, measured_z, rendered_x, rendered_y, rendered_z, \
                         rendered_y_se, y_ratio, xy_distance, de76, de00, created_at, observer, measured_y_se) \
                         VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, $18, $19, $20, \
                         $21, $22, $23)",
                    )
                    .bind(c.measurement_id)
                    .bind(c.render_id)
                    .bind(&c.scene)
                    .bind(&c.target)
                    .bind(&c.coding)
                    .bind(&c.white_source)
                    .bind(c.white[0])
                    .bind(c.white[1])
                    .bind(c.white[2])
                    .bind(c.measured[0])
                    .bind(c.measured[1])
                    .bind(c.measured[2])
                    .bind(c.rendered[0])
                    .bind(c.rendered[1])
                    .bind(c.rendered[2])
                    .bind(c.rendered_y_se)
                    .bind(c.y_ratio)
                    .bind(c.xy_distance)
                    .bind(c.de76)
                    .bind(c.de00)
                    .bind(now())
                    .bind(c.observer.name())
                    .bind(c.measured_y_se)
                    .execute(&mut *tx)
                    .await?;
                }
                tx.commit().await?;
            });
            self.wrote();
            Ok(())
        })
    }

    /// For each (target, coding) of a scene, the newest comparison.
    pub fn latest_comparisons<'a>(&'a self, scene: &'a str) -> BoxFuture<'a, Result<Vec<ComparisonRow>, StoreError>> {
        Box::pin(async move {
            let records: Vec<ComparisonRecord> = with_pool!(self, |pool| sqlx::query_as(
                "SELECT c.* FROM comparisons c JOIN ( \
                     SELECT target, coding, MAX(id) AS id FROM comparisons WHERE scene = $1 GROUP BY target, coding \
                 ) latest ON latest.id = c.id ORDER BY c.target, c.coding",
            )
            .bind(scene)
            .fetch_all(pool)
            .await?);
            Ok(records.into_iter().map(ComparisonRow::from).collect())
        })
    }

    /// The version of a scene's comparisons, all that its summary reads
    /// (the measurements they compare are complete, so never rewritten):
    /// their number, the newest id, and the sum of the columns a new
    /// CIELAB white rewrites in place ([`Store::update_comparison_whites`]).
    pub fn scene_comparison_inputs<'a>(
        &'a self,
        scene: &'a str,
    ) -> BoxFuture<'a, Result<crate::InputsVersion, StoreError>> {
        Box::pin(async move {
            let (count, newest, de00, white_y): (i64, i64, f64, f64) = with_pool!(self, |pool| sqlx::query_as(
                "SELECT COUNT(*), COALESCE(MAX(id), 0), COALESCE(SUM(de00), 0.0), COALESCE(SUM(white_y), 0.0) \
                 FROM comparisons WHERE scene = $1"
            )
            .bind(scene)
            .fetch_one(pool)
            .await?);
            Ok(crate::InputsVersion([
                count,
                newest,
                de00.to_bits() as i64,
                white_y.to_bits() as i64,
            ]))
        })
    }

    /// Every comparison of a scene, oldest first.
    pub fn comparisons_of_scene<'a>(&'a self, scene: &'a str) -> BoxFuture<'a, Result<Vec<ComparisonRow>, StoreError>> {
        Box::pin(async move {
            let records: Vec<ComparisonRecord> = with_pool!(self, |pool| sqlx::query_as(
                "SELECT * FROM comparisons WHERE scene = $1 ORDER BY id"
            )
            .bind(scene)
            .fetch_all(pool)
            .await?);
            Ok(records.into_iter().map(ComparisonRow::from).collect())
        })
    }

    /// Every comparison of a scene whose measurement was taken in `booth`,
    /// oldest first: the rows a new white of that booth applies to.
    pub fn comparisons_of_scene_in_booth<'a>(
        &'a self,
        scene: &'a str,
        booth: &'a Booth,
    ) -> BoxFuture<'a, Result<Vec<ComparisonRow>, StoreError>> {
        Box::pin(async move {
            let records: Vec<ComparisonRecord> = with_pool!(self, |pool| sqlx::query_as(
                "SELECT c.* FROM comparisons c JOIN measurements m ON m.id = c.measurement_id \
                 WHERE c.scene = $1 AND m.booth = $2 ORDER BY c.id"
            )
            .bind(scene)
            .bind(booth.as_str())
            .fetch_all(pool)
            .await?);
            Ok(records.into_iter().map(ComparisonRow::from).collect())
        })
    }

    /// Rewrites the CIELAB white of comparisons and the ΔE computed with it
    /// (`(id, white_source, white XYZ, ΔE*ab, ΔE00)`), all in one transaction.
    pub fn update_comparison_whites<'a>(
        &'a self,
        updates: &'a [(i64, String, [f64; 3], f64, f64)],
    ) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| {
                let mut tx = pool.begin().await?;
                for (id, source, white, de76, de00) in updates {
                    sqlx::query(
                        "UPDATE comparisons SET white_source = $1, white_x = $2, white_y = $3, white_z = $4, de76 = $5, \
                         de00 = $6 WHERE id = $7",
                    )
                    .bind(source)
                    .bind(white[0])
                    .bind(white[1])
                    .bind(white[2])
                    .bind(de76)
                    .bind(de00)
                    .bind(id)
                    .execute(&mut *tx)
                    .await?;
                }
                tx.commit().await?;
            });
            self.wrote();
            Ok(())
        })
    }

    pub fn comparisons_for_measurement<'a>(
        &'a self,
        measurement_id: i64,
    ) -> BoxFuture<'a, Result<Vec<ComparisonRow>, StoreError>> {
        Box::pin(async move {
            let records: Vec<ComparisonRecord> = with_pool!(self, |pool| sqlx::query_as(
                "SELECT * FROM comparisons WHERE measurement_id = $1 ORDER BY id"
            )
            .bind(measurement_id)
            .fetch_all(pool)
            .await?);
            Ok(records.into_iter().map(ComparisonRow::from).collect())
        })
    }

    /// Stores a luminance meter's comparisons with every coding of one
    /// render, in one transaction (all or nothing).
    pub fn insert_luminance_comparisons<'a>(
        &'a self,
        rows: &'a [NewLuminanceComparison],
    ) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| {
                let mut tx = pool.begin().await?;
                for c in rows {
                    sqlx::query(
                        "INSERT INTO luminance_comparisons (measurement_id, render_id, scene, target, coding, observer, \
                         measured_y, measured_y_se, rendered_y, rendered_y_se, y_ratio, created_at) \
                         VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12)",
                    )
                    .bind(c.measurement_id)
                    .bind(c.render_id)
                    .bind(&c.scene)
                    .bind(&c.target)
                    .bind(&c.coding)
                    .bind(c.observer.name())
                    .bind(c.measured_y)
                    .bind(c.measured_y_se)
                    .bind(c.rendered_y)
                    .bind(c.rendered_y_se)
                    .bind(c.y_ratio)
                    .bind(now())
                    .execute(&mut *tx)
                    .await?;
                }
                tx.commit().await?;
            });
            self.wrote();
            Ok(())
        })
    }

    /// The luminance-only comparisons of one measurement, oldest first.
    pub fn luminance_comparisons_for_measurement<'a>(
        &'a self,
        measurement_id: i64,
    ) -> BoxFuture<'a, Result<Vec<LuminanceComparisonRow>, StoreError>> {
        Box::pin(async move {
            let records: Vec<LuminanceComparisonRecord> = with_pool!(self, |pool| sqlx::query_as(
                "SELECT * FROM luminance_comparisons WHERE measurement_id = $1 ORDER BY id"
            )
            .bind(measurement_id)
            .fetch_all(pool)
            .await?);
            Ok(records.into_iter().map(LuminanceComparisonRow::from).collect())
        })
    }

    /// Runs one statement with one integer argument (`$1`), for tests that
    /// reach past the store's API (a schema constraint, a forced state).
    #[cfg(test)]
    pub(crate) async fn execute_for_test(&self, sql: &str, arg: i64) -> Result<u64, StoreError> {
        Ok(with_pool!(self, |pool| sqlx::query(sql)
            .bind(arg)
            .execute(pool)
            .await?
            .rows_affected()))
    }
}
