//! `/api/sessions`: who measured, and their notes.

use axum::extract::State;
use axum::http::StatusCode;
use axum::Json;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::http::error::ApiError;
use crate::http::input::Input;
use crate::http::AppState;
use crate::store::SessionRow;

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewSession {
    /// Who measures; not blank.
    #[schema(min_length = 1, pattern = "\\S")]
    pub operator: String,
    #[serde(default)]
    pub notes: String,
}

#[utoipa::path(get, path = "/sessions", tag = "sessions", responses((status = 200, body = Vec<SessionRow>)))]
pub async fn list_sessions(State(state): State<AppState>) -> Result<Json<Vec<SessionRow>>, ApiError> {
    Ok(Json(state.lab.sessions().await?))
}

#[derive(Serialize, ToSchema)]
pub struct Created {
    pub id: i64,
}

#[utoipa::path(post, path = "/sessions", tag = "sessions", request_body = NewSession,
    responses((status = 201, body = Created), (status = 400, body = crate::http::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn create_session(
    State(state): State<AppState>,
    Input(body): Input<NewSession>,
) -> Result<(StatusCode, Json<Created>), ApiError> {
    let id = state.lab.create_session(&body.operator, &body.notes).await?;
    Ok((StatusCode::CREATED, Json(Created { id })))
}
