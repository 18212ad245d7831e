//! Image stimulus sets (`migrations/0023`): the codings of one rendered
//! image converted through a stored display profile, kept with where they
//! came from, the report, and the per-pixel linear RGB and ΔE00 maps the
//! pages read. Written once; the large columns are read only when asked
//! for ([`Store::stimulus_set_blob`]).

use crate::BoxFuture;
use serde::Serialize;

use super::{now, Booth, Store, StoreError};

/// A set to store.
#[derive(Clone, Debug)]
pub struct NewStimulusSet {
    pub booth: Booth,
    /// `render` or `upload`.
    pub source: &'static str,
    pub render_id: Option<i64>,
    pub scene: Option<String>,
    pub provenance: serde_json::Value,
    pub profile_id: i64,
    pub policy: String,
    pub output: String,
    pub width: u32,
    pub height: u32,
    pub codings: Vec<String>,
    pub reference: String,
    pub observer: String,
    pub report: serde_json::Value,
    /// f32 little-endian: per coding, per pixel, R G B.
    pub linear: Vec<u8>,
    /// f32 little-endian: per coding, per pixel.
    pub shown_delta_e: Vec<u8>,
}

/// A stored set without its per-pixel columns, as the API sends it.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct StimulusSetRow {
    pub id: i64,
    pub booth: String,
    /// POSIX seconds, UTC.
    pub created_at: f64,
    /// `render` (camera images the daemon kept) or `upload` (an OpenEXR file).
    pub source: String,
    pub render_id: Option<i64>,
    pub scene: Option<String>,
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub provenance: serde_json::Value,
    pub profile_id: i64,
    pub policy: String,
    pub output: String,
    pub width: u32,
    pub height: u32,
    pub codings: Vec<String>,
    pub reference: String,
    pub observer: String,
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub report: serde_json::Value,
}

#[derive(sqlx::FromRow)]
struct Record {
    id: i64,
    booth: String,
    created_at: f64,
    source: String,
    render_id: Option<i64>,
    scene: Option<String>,
    provenance_json: String,
    profile_id: i64,
    policy: String,
    output: String,
    width: i64,
    height: i64,
    codings_json: String,
    reference: String,
    observer: String,
    report_json: String,
}

const COLUMNS: &str = "id, booth, created_at, source, render_id, scene, provenance_json, profile_id, policy, output, \
                       width, height, codings_json, reference, observer, report_json";

impl TryFrom<Record> for StimulusSetRow {
    type Error = StoreError;
    fn try_from(r: Record) -> Result<Self, StoreError> {
        let id = r.id;
        let json = |what: &str, text: &str| -> Result<serde_json::Value, StoreError> {
            serde_json::from_str(text).map_err(|e| StoreError::Corrupt {
                what: format!("stimulus_sets.{what} of set {id}"),
                err: e.to_string(),
            })
        };
        let codings: Vec<String> =
            serde_json::from_value(json("codings_json", &r.codings_json)?).map_err(|e| StoreError::Corrupt {
                what: format!("stimulus_sets.codings_json of set {id}"),
                err: e.to_string(),
            })?;
        Ok(StimulusSetRow {
            id,
            booth: r.booth,
            created_at: r.created_at,
            source: r.source,
            render_id: r.render_id,
            scene: r.scene,
            provenance: json("provenance_json", &r.provenance_json)?,
            profile_id: r.profile_id,
            policy: r.policy,
            output: r.output,
            width: r.width as u32,
            height: r.height as u32,
            codings,
            reference: r.reference,
            observer: r.observer,
            report: json("report_json", &r.report_json)?,
        })
    }
}

/// A per-pixel column of a set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StimulusSetBlob {
    Linear,
    ShownDeltaE,
}

impl Store {
    /// Stores a set; its id.
    pub fn insert_stimulus_set<'a>(&'a self, set: &'a NewStimulusSet) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "INSERT INTO stimulus_sets (booth, created_at, source, render_id, scene, provenance_json, profile_id, \
                 policy, output, width, height, codings_json, reference, observer, report_json, linear, shown_delta_e) \
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17) RETURNING id"
            )
            .bind(set.booth.as_str())
            .bind(now())
            .bind(set.source)
            .bind(set.render_id)
            .bind(set.scene.as_deref())
            .bind(set.provenance.to_string())
            .bind(set.profile_id)
            .bind(&set.policy)
            .bind(&set.output)
            .bind(set.width as i64)
            .bind(set.height as i64)
            .bind(serde_json::to_string(&set.codings).expect("strings serialise"))
            .bind(&set.reference)
            .bind(&set.observer)
            .bind(set.report.to_string())
            .bind(&set.linear)
            .bind(&set.shown_delta_e)
            .fetch_one(pool)
            .await?))
        })
    }

    /// One set, without its per-pixel columns.
    pub fn get_stimulus_set<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<StimulusSetRow>, StoreError>> {
        Box::pin(async move {
            let sql = format!("SELECT {COLUMNS} FROM stimulus_sets WHERE id = $1");
            let r: Option<Record> = with_pool!(self, |pool| sqlx::query_as(&sql).bind(id).fetch_optional(pool).await?);
            r.map(StimulusSetRow::try_from).transpose()
        })
    }

    /// Every set, newest first, without their per-pixel columns.
    pub fn list_stimulus_sets<'a>(&'a self) -> BoxFuture<'a, Result<Vec<StimulusSetRow>, StoreError>> {
        Box::pin(async move {
            let sql = format!("SELECT {COLUMNS} FROM stimulus_sets ORDER BY id DESC");
            let rows: Vec<Record> = with_pool!(self, |pool| sqlx::query_as(&sql).fetch_all(pool).await?);
            rows.into_iter().map(StimulusSetRow::try_from).collect()
        })
    }

    /// A set's per-pixel column; `None` when there is no such set.
    pub fn stimulus_set_blob<'a>(
        &'a self,
        id: i64,
        which: StimulusSetBlob,
    ) -> BoxFuture<'a, Result<Option<Vec<u8>>, StoreError>> {
        Box::pin(async move {
            let column = match which {
                StimulusSetBlob::Linear => "linear",
                StimulusSetBlob::ShownDeltaE => "shown_delta_e",
            };
            let sql = format!("SELECT {column} FROM stimulus_sets WHERE id = $1");
            Ok(with_pool!(self, |pool| sqlx::query_scalar(&sql)
                .bind(id)
                .fetch_optional(pool)
                .await?))
        })
    }
}

/// A stored verification of a set's coding on the display.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct StimulusSetVerificationRow {
    pub id: i64,
    pub set_id: i64,
    /// POSIX seconds, UTC.
    pub created_at: f64,
    pub coding: String,
    /// The browser and drawing path that showed the image, as it said.
    pub client: String,
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub request: serde_json::Value,
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub result: serde_json::Value,
}

#[derive(sqlx::FromRow)]
struct VerificationRecord {
    id: i64,
    set_id: i64,
    created_at: f64,
    coding: String,
    client: String,
    request_json: String,
    result_json: String,
}

impl TryFrom<VerificationRecord> for StimulusSetVerificationRow {
    type Error = StoreError;
    fn try_from(r: VerificationRecord) -> Result<Self, StoreError> {
        let json = |what: &str, text: &str| -> Result<serde_json::Value, StoreError> {
            serde_json::from_str(text).map_err(|e| StoreError::Corrupt {
                what: format!("stimulus_set_verifications.{what} of verification {}", r.id),
                err: e.to_string(),
            })
        };
        Ok(StimulusSetVerificationRow {
            request: json("request_json", &r.request_json)?,
            result: json("result_json", &r.result_json)?,
            id: r.id,
            set_id: r.set_id,
            created_at: r.created_at,
            coding: r.coding,
            client: r.client,
        })
    }
}

impl Store {
    /// Stores a verification of set `set_id`'s `coding`; its id.
    pub fn insert_stimulus_set_verification<'a>(
        &'a self,
        set_id: i64,
        coding: &'a str,
        client: &'a str,
        request: &'a serde_json::Value,
        result: &'a serde_json::Value,
    ) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| {
                sqlx::query_scalar(
                "INSERT INTO stimulus_set_verifications (set_id, created_at, coding, client, request_json, result_json) \
                 VALUES ($1, $2, $3, $4, $5, $6) RETURNING id"
            )
            .bind(set_id)
            .bind(now())
            .bind(coding)
            .bind(client)
            .bind(request.to_string())
            .bind(result.to_string())
            .fetch_one(pool)
            .await?
            }))
        })
    }

    /// A set's verifications, oldest first.
    pub fn stimulus_set_verifications<'a>(
        &'a self,
        set_id: i64,
    ) -> BoxFuture<'a, Result<Vec<StimulusSetVerificationRow>, StoreError>> {
        Box::pin(async move {
            let rows: Vec<VerificationRecord> = with_pool!(self, |pool| sqlx::query_as(
                "SELECT id, set_id, created_at, coding, client, request_json, result_json \
                 FROM stimulus_set_verifications WHERE set_id = $1 ORDER BY id"
            )
            .bind(set_id)
            .fetch_all(pool)
            .await?);
            rows.into_iter().map(StimulusSetVerificationRow::try_from).collect()
        })
    }
}
