//! Batches of a camera image's paths rendered by workers
//! (`migrations/0022`): the daemon records a row per batch and queues a
//! worker job of kind [`WorkerJobKind::Image`](crate::WorkerJobKind) about
//! it; the worker leaves the batch's moments (`CameraImages::to_bytes`) on
//! the row and ends its job; the daemon reads them, merges them into the
//! image it keeps in memory, and deletes the row. The bytes are opaque
//! here: the store neither reads nor checks them.

use crate::BoxFuture;

use super::{Store, StoreError};

impl Store {
    /// Records a batch of an image asked by this handle's daemon; its id.
    pub fn new_image_batch<'a>(&'a self) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            let me = self.registered_id("recording an image batch")?;
            let sql = format!(
                "INSERT INTO image_batches (requested_by, created_at) VALUES ($1, {}) RETURNING id",
                self.clock_sql()
            );
            Ok(with_pool!(self, |pool| sqlx::query_scalar(&sql)
                .bind(me)
                .fetch_one(pool)
                .await?))
        })
    }

    /// Leaves a rendered batch's moments on its row. False when the row is
    /// gone (the daemon that asked gave the image up).
    pub fn put_image_batch_moments<'a>(
        &'a self,
        id: i64,
        moments: &'a [u8],
    ) -> BoxFuture<'a, Result<bool, StoreError>> {
        Box::pin(async move {
            let n = with_pool!(self, |pool| sqlx::query(
                "UPDATE image_batches SET moments = $1 WHERE id = $2"
            )
            .bind(moments)
            .bind(id)
            .execute(pool)
            .await?
            .rows_affected());
            Ok(n == 1)
        })
    }

    /// A batch's moments: `None` when there is no such row, `Some(None)`
    /// before a worker left them.
    pub fn image_batch_moments<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<Option<Vec<u8>>>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "SELECT moments FROM image_batches WHERE id = $1"
            )
            .bind(id)
            .fetch_optional(pool)
            .await?))
        })
    }

    /// Deletes batch rows (merged, or of an image given up).
    pub fn delete_image_batches<'a>(&'a self, ids: &'a [i64]) -> BoxFuture<'a, Result<u64, StoreError>> {
        Box::pin(async move {
            let mut n = 0;
            for id in ids {
                n += with_pool!(self, |pool| sqlx::query("DELETE FROM image_batches WHERE id = $1")
                    .bind(id)
                    .execute(pool)
                    .await?
                    .rows_affected());
            }
            Ok(n)
        })
    }

    /// Gives up the image batches of daemons that are gone (stopped, or
    /// their lease ran out): their queued jobs are cancelled and their rows
    /// deleted, since the images they were for were kept in those daemons'
    /// memory. Returns how many rows went.
    pub fn abandon_image_batches_of_gone_daemons<'a>(&'a self) -> BoxFuture<'a, Result<u64, StoreError>> {
        Box::pin(async move {
            let clock = self.clock_sql();
            let gone = format!(
                "SELECT d.id FROM daemons d WHERE d.stopped_at IS NOT NULL OR d.heartbeat_at + d.lease_seconds < {clock}"
            );
            let cancel = format!(
                "UPDATE worker_jobs SET state = 'cancelled', error = 'the daemon that asked for this image is gone', \
                 finished_at = {clock} WHERE kind = 'image' AND state = 'queued' AND requested_by IN ({gone})"
            );
            with_pool!(self, |pool| sqlx::query(&cancel).execute(pool).await?.rows_affected());
            let delete = format!("DELETE FROM image_batches WHERE requested_by IN ({gone})");
            Ok(with_pool!(self, |pool| sqlx::query(&delete)
                .execute(pool)
                .await?
                .rows_affected()))
        })
    }
}
