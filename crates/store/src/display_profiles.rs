//! Stored display profiles (`migrations/0008`): what
//! [`lightbooth_science::display::fit_profile`] fitted, with the measurements it came from,
//! and whether it passed its checks ([`lightbooth_science::display::DisplayProfile::failures`],
//! judged from the stored fit whenever a row is read).

use crate::BoxFuture;
use serde::Serialize;

use super::{now, Store, StoreError};
use lightbooth_science::display::DisplayProfile;

/// A stored display profile, as the API sends it.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DisplayProfileRow {
    pub id: i64,
    pub name: String,
    /// POSIX seconds, UTC.
    pub created_at: f64,
    pub note: String,
    /// `passed`, or `failed`: a fit residual or a validation ΔE00 over its
    /// stated limit ([`DisplayProfile::failures`]); a failed profile is
    /// kept (its measurements are evidence) but cannot be chosen for an
    /// experiment.
    pub state: &'static str,
    /// Why it failed, one line per check; empty when it passed.
    pub failures: Vec<String>,
    pub profile: DisplayProfile,
}

#[derive(sqlx::FromRow)]
struct DisplayProfileRecord {
    id: i64,
    name: String,
    created_at: f64,
    profile_json: String,
    note: String,
}

impl TryFrom<DisplayProfileRecord> for DisplayProfileRow {
    type Error = StoreError;
    fn try_from(r: DisplayProfileRecord) -> Result<Self, StoreError> {
        let corrupt = |err: String| StoreError::Corrupt {
            what: format!("display_profiles.profile_json of profile {}", r.id),
            err,
        };
        let profile: DisplayProfile = serde_json::from_str(&r.profile_json).map_err(|e| corrupt(e.to_string()))?;
        profile.validate().map_err(|e| corrupt(e.to_string()))?;
        let failures = profile.failures();
        Ok(DisplayProfileRow {
            id: r.id,
            name: r.name,
            created_at: r.created_at,
            note: r.note,
            state: if failures.is_empty() { "passed" } else { "failed" },
            failures,
            profile,
        })
    }
}

impl Store {
    /// Stores a fitted profile; returns its id.
    pub fn insert_display_profile<'a>(
        &'a self,
        name: &'a str,
        note: &'a str,
        profile: &'a DisplayProfile,
    ) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "INSERT INTO display_profiles (name, created_at, observer, measurement_ids_json, profile_json, note) \
                 VALUES ($1, $2, $3, $4, $5, $6) RETURNING id",
            )
            .bind(name)
            .bind(now())
            .bind(profile.observer.name())
            .bind(serde_json::to_string(&profile.measurement_ids).expect("integers serialise"))
            .bind(serde_json::to_string(profile).expect("a profile of finite numbers serialises"))
            .bind(note)
            .fetch_one(pool)
            .await?))
        })
    }

    pub fn get_display_profile<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<DisplayProfileRow>, StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| sqlx::query_as::<_, DisplayProfileRecord>(
                "SELECT id, name, created_at, profile_json, note FROM display_profiles WHERE id = $1",
            )
            .bind(id)
            .fetch_optional(pool)
            .await?)
            .map(DisplayProfileRow::try_from)
            .transpose()
        })
    }

    /// Every stored profile, newest first.
    pub fn list_display_profiles<'a>(&'a self) -> BoxFuture<'a, Result<Vec<DisplayProfileRow>, StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| sqlx::query_as::<_, DisplayProfileRecord>(
                "SELECT id, name, created_at, profile_json, note FROM display_profiles ORDER BY id DESC",
            )
            .fetch_all(pool)
            .await?)
            .into_iter()
            .map(DisplayProfileRow::try_from)
            .collect()
        })
    }
}
