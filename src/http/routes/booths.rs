//! `/api/booths`: every booth sharing this database, with its measurement
//! counts, so the dashboard and MATLAB scripts can pick one booth's data
//! (`/api/measurements?booth=NAME`).

use axum::extract::State;
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use crate::http::error::ApiError;
use crate::http::AppState;
use crate::store::BoothRow;

#[derive(Serialize, ToSchema)]
pub struct Booths {
    /// The booth this daemon measures in (`serve --booth`).
    pub this_daemon: String,
    /// Every booth with a measurement or an instrument in the database, by name.
    pub booths: Vec<BoothRow>,
}

/// Every booth in the database and which one this daemon serves.
#[utoipa::path(get, path = "/booths", tag = "instruments", responses((status = 200, body = Booths)))]
pub async fn list_booths(State(state): State<AppState>) -> Result<Json<Booths>, ApiError> {
    Ok(Json(Booths {
        this_daemon: state.lab.booth().to_string(),
        booths: state.lab.booths().await?,
    }))
}
