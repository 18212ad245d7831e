//! `/api/jobs`: everything this booth's daemon has waiting or under way
//! (measurements, renders, studies, camera images, experiment sessions),
//! with progress and time left, whoever started it (see `lab::queue`).

use axum::extract::State;
use axum::Json;

use crate::http::error::ApiError;
use crate::http::AppState;
use crate::lab::queue::Queue;

/// Every job of this booth waiting or under way, the instrument's first in
/// the order it takes them; each with its progress and, where its pace is
/// known, the seconds it still needs (an extrapolation that says how it
/// was made).
#[utoipa::path(get, path = "/jobs", tag = "service", responses((status = 200, body = Queue)))]
pub async fn list_jobs(State(state): State<AppState>) -> Result<Json<Queue>, ApiError> {
    Ok(Json(state.lab.queue().await?))
}
