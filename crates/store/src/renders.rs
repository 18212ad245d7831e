//! Renders: their settings and render key, their progress as jobs, their
//! results and preview images.

use super::*;
use crate::BoxFuture;

impl Store {
    pub fn create_render<'a>(&'a self, r: &'a NewRender) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move { self.create_render_retrying(r, None).await })
    }

    /// A new queued render; with `retry_of`, the retry of that render, at
    /// most one (migration 0017's unique index): a second retry of the same
    /// render is a [`StoreError::Conflict`] naming the first retry.
    pub fn create_render_retrying<'a>(
        &'a self,
        r: &'a NewRender,
        retry_of: Option<i64>,
    ) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            let inserted: Result<i64, sqlx::Error> = with_pool!(self, |pool| {
                sqlx::query_scalar(
                "INSERT INTO renders (scene, scene_hash, settings_json, codings, seed, state, created_at, daemon_id, retry_of) \
                 VALUES ($1, $2, $3, $4, $5, 'queued', $6, $7, $8) RETURNING id",
            )
            .bind(&r.scene)
            .bind(&r.scene_hash)
            .bind(r.settings_json.to_string())
            .bind(r.codings.join(","))
            .bind(r.seed as i64)
            .bind(now())
            .bind(self.daemon_id)
            .bind(retry_of)
            .fetch_one(pool)
            .await
            });
            self.unless_retried_already(Job::Render, inserted, retry_of).await
        })
    }

    /// The job that retries `id` (`retry_of`), if it was retried.
    pub fn retried_as<'a>(&'a self, job: Job, id: i64) -> BoxFuture<'a, Result<Option<i64>, StoreError>> {
        Box::pin(async move {
            let sql = format!("SELECT id FROM {} WHERE retry_of = $1", job.table());
            Ok(with_pool!(self, |pool| sqlx::query_scalar::<_, i64>(&sql)
                .bind(id)
                .fetch_optional(pool)
                .await?))
        })
    }

    /// The conflict of a second retry of `id`: it names the first retry.
    /// The new job's id, or, when the unique `retry_of` refused a second
    /// retry of `retry_of`, the 409 naming the first.
    pub(super) async fn unless_retried_already(
        &self,
        job: Job,
        inserted: Result<i64, sqlx::Error>,
        retry_of: Option<i64>,
    ) -> Result<i64, StoreError> {
        match (inserted, retry_of) {
            (Err(sqlx::Error::Database(db)), Some(old)) if db.is_unique_violation() => {
                Err(self.already_retried(job, old).await)
            }
            (result, _) => Ok(result?),
        }
    }

    async fn already_retried(&self, job: Job, id: i64) -> StoreError {
        let noun = job.noun();
        match self.retried_as(job, id).await {
            Ok(Some(first)) => StoreError::Conflict(already_retried_message(job, id, first)),
            Ok(None) => StoreError::Conflict(format!("{noun} {id} is being retried already")),
            Err(e) => e,
        }
    }

    pub fn finish_render<'a>(
        &'a self,
        id: i64,
        result: Result<(&'a serde_json::Value, f64), &'a str>,
    ) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            match result {
                Ok((json, wall)) => with_pool!(self, |pool| sqlx::query(
                    "UPDATE renders SET state = 'complete', result_json = $1, wall_seconds = $2, finished_at = $3 \
                     WHERE id = $4 AND state = 'running'",
                )
                .bind(json.to_string())
                .bind(wall)
                .bind(now())
                .bind(id)
                .execute(pool)
                .await?
                .rows_affected()),
                Err(e) => with_pool!(self, |pool| sqlx::query(
                    "UPDATE renders SET state = 'failed', error = $1, finished_at = $2 \
                     WHERE id = $3 AND state IN ('queued', 'running')",
                )
                .bind(e)
                .bind(now())
                .bind(id)
                .execute(pool)
                .await?
                .rows_affected()),
            };
            self.wrote();
            Ok(())
        })
    }

    /// The newest complete render of this scene content with these exact
    /// settings: its id and JSON result.
    pub fn find_render_result<'a>(
        &'a self,
        scene_hash: &'a str,
        settings: &'a serde_json::Value,
    ) -> BoxFuture<'a, Result<Option<(i64, serde_json::Value)>, StoreError>> {
        Box::pin(async move {
            let row: Option<(i64, String)> = with_pool!(self, |pool| {
                sqlx::query_as(
                "SELECT id, result_json FROM renders WHERE scene_hash = $1 AND settings_json = $2 AND state = 'complete' \
                 ORDER BY id DESC LIMIT 1",
            )
            .bind(scene_hash)
            .bind(settings.to_string())
            .fetch_optional(pool)
            .await?
            });
            let Some((id, text)) = row else { return Ok(None) };
            let json = serde_json::from_str(&text).map_err(|e| StoreError::Corrupt {
                what: "renders.result_json".into(),
                err: e.to_string(),
            })?;
            Ok(Some((id, json)))
        })
    }

    /// A running render of this scene content with these exact settings,
    /// by any process: its id.
    pub fn running_render_of<'a>(
        &'a self,
        scene_hash: &'a str,
        settings: &'a serde_json::Value,
    ) -> BoxFuture<'a, Result<Option<i64>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "SELECT id FROM renders WHERE scene_hash = $1 AND settings_json = $2 AND state = 'running' \
                 ORDER BY id DESC LIMIT 1"
            )
            .bind(scene_hash)
            .bind(settings.to_string())
            .fetch_optional(pool)
            .await?))
        })
    }

    /// Stores a render's preview image (PNG bytes).
    pub fn set_render_preview<'a>(&'a self, id: i64, png: &'a [u8]) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| sqlx::query(
                "UPDATE renders SET preview_png = $1 WHERE id = $2"
            )
            .bind(png)
            .bind(id)
            .execute(pool)
            .await?
            .rows_affected());
            self.wrote();
            Ok(())
        })
    }

    /// A render's preview PNG, if it has one.
    pub fn render_preview<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<Vec<u8>>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar::<_, Option<Vec<u8>>>(
                "SELECT preview_png FROM renders WHERE id = $1"
            )
            .bind(id)
            .fetch_optional(pool)
            .await?)
            .flatten())
        })
    }

    /// The newest complete render of `scene` with a preview image, if any.
    pub fn latest_preview_render<'a>(&'a self, scene: &'a str) -> BoxFuture<'a, Result<Option<i64>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar::<_, i64>(
                "SELECT id FROM renders WHERE scene = $1 AND state = 'complete' AND preview_png IS NOT NULL \
                 ORDER BY id DESC LIMIT 1"
            )
            .bind(scene)
            .fetch_optional(pool)
            .await?))
        })
    }

    pub fn get_render<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<RenderRow>, StoreError>> {
        Box::pin(async move {
            let sql = format!("SELECT {RENDER_COLUMNS} FROM renders WHERE id = $1");
            let record: Option<RenderRecord> =
                with_pool!(self, |pool| sqlx::query_as(&sql).bind(id).fetch_optional(pool).await?);
            record.map(RenderRow::try_from).transpose()
        })
    }

    pub fn list_renders<'a>(&'a self, scene: Option<&'a str>) -> BoxFuture<'a, Result<Vec<RenderRow>, StoreError>> {
        Box::pin(async move {
            let records: Vec<RenderRecord> = match scene {
                Some(s) => {
                    let sql = format!("SELECT {RENDER_COLUMNS} FROM renders WHERE scene = $1 ORDER BY id DESC");
                    with_pool!(self, |pool| sqlx::query_as(&sql).bind(s).fetch_all(pool).await?)
                }
                None => {
                    let sql = format!("SELECT {RENDER_COLUMNS} FROM renders ORDER BY id DESC LIMIT 200");
                    with_pool!(self, |pool| sqlx::query_as(&sql).fetch_all(pool).await?)
                }
            };
            records.into_iter().map(RenderRow::try_from).collect()
        })
    }

    /// The queued and running renders, oldest first (the queue's; not
    /// capped like the list, which is newest first).
    pub fn unfinished_renders<'a>(&'a self) -> BoxFuture<'a, Result<Vec<RenderRow>, StoreError>> {
        Box::pin(async move {
            let sql = format!("SELECT {RENDER_COLUMNS} FROM renders WHERE state IN ('queued', 'running') ORDER BY id");
            let records: Vec<RenderRecord> = with_pool!(self, |pool| sqlx::query_as(&sql).fetch_all(pool).await?);
            records.into_iter().map(RenderRow::try_from).collect()
        })
    }
}
