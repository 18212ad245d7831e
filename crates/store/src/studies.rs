//! Studies: the request, their progress as jobs, the result and the report's files.

use super::*;
use crate::BoxFuture;

impl Store {
    /// Records a study as `queued`.
    pub fn create_study<'a>(&'a self, request: &'a serde_json::Value) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move { self.create_study_retrying(request, None).await })
    }

    /// A new queued study; with `retry_of`, the one retry of that study (as
    /// [`Store::create_render_retrying`]).
    pub fn create_study_retrying<'a>(
        &'a self,
        request: &'a serde_json::Value,
        retry_of: Option<i64>,
    ) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            let inserted: Result<i64, sqlx::Error> = with_pool!(self, |pool| {
                sqlx::query_scalar(
                    "INSERT INTO studies (request_json, state, created_at, daemon_id, retry_of) \
                     VALUES ($1, 'queued', $2, $3, $4) RETURNING id",
                )
                .bind(request.to_string())
                .bind(now())
                .bind(self.daemon_id)
                .bind(retry_of)
                .fetch_one(pool)
                .await
            });
            self.unless_retried_already(Job::Study, inserted, retry_of).await
        })
    }

    /// Stores a finished study with its report files, in one transaction.
    pub fn complete_study<'a>(
        &'a self,
        id: i64,
        result: &'a serde_json::Value,
        wall_seconds: f64,
        files: &'a [(String, Vec<u8>)],
    ) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| {
                let mut tx = pool.begin().await?;
                for (name, content) in files {
                    sqlx::query("INSERT INTO study_files (study_id, name, content) VALUES ($1, $2, $3)")
                        .bind(id)
                        .bind(name)
                        .bind(content)
                        .execute(&mut *tx)
                        .await?;
                }
                let r = sqlx::query(
                    "UPDATE studies SET state = 'complete', result_json = $1, wall_seconds = $2, finished_at = $3 \
                     WHERE id = $4 AND state = 'running'",
                )
                .bind(result.to_string())
                .bind(wall_seconds)
                .bind(now())
                .bind(id)
                .execute(&mut *tx)
                .await?;
                if r.rows_affected() != 1 {
                    // Cancelled or interrupted meanwhile: keep nothing (the transaction rolls back).
                    return Err(StoreError::Conflict(format!("study {id} is not running")));
                }
                tx.commit().await?;
            });
            Ok(())
        })
    }

    pub fn fail_study<'a>(&'a self, id: i64, error: &'a str) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| sqlx::query(
                "UPDATE studies SET state = 'failed', error = $1, finished_at = $2 WHERE id = $3 AND state = 'running'",
            )
            .bind(error)
            .bind(now())
            .bind(id)
            .execute(pool)
            .await?
            .rows_affected());
            Ok(())
        })
    }

    /// The stored studies, newest first, without their results.
    pub fn list_studies<'a>(&'a self) -> BoxFuture<'a, Result<Vec<StudyRow>, StoreError>> {
        Box::pin(async move {
            let records: Vec<StudyRecord> = with_pool!(self, |pool| {
                sqlx::query_as(
                "SELECT id, request_json, state, error, created_at, finished_at, wall_seconds FROM studies ORDER BY id DESC",
            )
            .fetch_all(pool)
            .await?
            });
            records.into_iter().map(StudyRow::try_from).collect()
        })
    }

    /// The queued and running studies, oldest first, without their results.
    pub fn unfinished_studies<'a>(&'a self) -> BoxFuture<'a, Result<Vec<StudyRow>, StoreError>> {
        Box::pin(async move {
            let records: Vec<StudyRecord> = with_pool!(self, |pool| {
                sqlx::query_as(
                    "SELECT id, request_json, state, error, created_at, finished_at, wall_seconds FROM studies \
                 WHERE state IN ('queued', 'running') ORDER BY id",
                )
                .fetch_all(pool)
                .await?
            });
            records.into_iter().map(StudyRow::try_from).collect()
        })
    }

    /// One study with its result and the names of its report files.
    pub fn get_study<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<StudyRow>, StoreError>> {
        Box::pin(async move {
            let (record, files): (Option<StudyRecord>, Vec<String>) = with_pool!(self, |pool| (
                sqlx::query_as("SELECT * FROM studies WHERE id = $1")
                    .bind(id)
                    .fetch_optional(pool)
                    .await?,
                sqlx::query_scalar("SELECT name FROM study_files WHERE study_id = $1 ORDER BY name")
                    .bind(id)
                    .fetch_all(pool)
                    .await?
            ));
            let Some(record) = record else {
                return Ok(None);
            };
            let mut study = StudyRow::try_from(record)?;
            study.files = files;
            Ok(Some(study))
        })
    }

    pub fn study_file<'a>(&'a self, id: i64, name: &'a str) -> BoxFuture<'a, Result<Option<Vec<u8>>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "SELECT content FROM study_files WHERE study_id = $1 AND name = $2"
            )
            .bind(id)
            .bind(name)
            .fetch_optional(pool)
            .await?))
        })
    }
}
