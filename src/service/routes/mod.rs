//! The REST API's handlers, one file per resource (as mini-redis keeps one
//! file per command). Paths that scripts depend on are fixed:
//! `/api/health`, `/api/openapi.json`, `/api/measurements`,
//! `/api/measurements/{id}`, `/api/events`.
//!
//! [`api_router`] is the whole table of paths; each handler documents itself
//! for the OpenAPI document with `#[utoipa::path]`.

mod comparisons;
mod health;
mod measurements;
mod mock;
mod scenes;
mod sessions;
mod studies;

use axum::routing::{get, post};
use axum::Router;

pub use comparisons::*;
pub use health::*;
pub use measurements::*;
pub use mock::*;
pub use scenes::*;
pub use sessions::*;
pub use studies::*;

use super::{events, AppState};

pub fn api_router() -> Router<AppState> {
    Router::new()
        .route("/health", get(health))
        .route("/openapi.json", get(super::openapi::document))
        .route("/instruments", get(instruments))
        .route("/sessions", get(list_sessions).post(create_session))
        .route("/measurements", get(list_measurements).post(start_measurement))
        .route("/measurements/{id}", get(get_measurement))
        .route("/measurements/{id}/cancel", axum::routing::post(cancel_measurement))
        .route("/measurements/{id}/spectrum.csv", get(measurement_csv))
        .route("/measurements/{id}/spectrum.mat", get(measurement_mat))
        .route("/measurements/{id}/spectrum.svg", get(measurement_svg))
        .route("/measurements/{id}/comparisons", get(measurement_comparisons))
        .route("/scenes", get(list_scenes))
        .route("/scenes/{scene}", get(get_scene))
        .route("/scenes/{scene}/targets", get(scene_targets))
        .route("/scenes/{scene}/renders", get(scene_renders).post(start_render))
        .route("/scenes/{scene}/comparisons", get(scene_comparisons))
        .route("/scenes/{scene}/comparisons.csv", get(scene_comparisons_csv))
        .route("/scenes/{scene}/comparisons.mat", get(scene_comparisons_mat))
        .route("/scenes/{scene}/charts/{chart}", get(scene_chart))
        .route("/studies", get(list_studies).post(start_study))
        .route("/studies/{id}", get(get_study))
        .route("/studies/{id}/files/{name}", get(study_file))
        .route("/studies/{id}/cancel", post(cancel_study))
        .route("/studies/{id}/retry", post(retry_study))
        .route("/renders/{id}", get(get_render))
        .route("/renders/{id}/cancel", post(cancel_render))
        .route("/renders/{id}/retry", post(retry_render))
        .route("/renders/{id}/preview.png", get(render_preview))
        .route("/events", get(events::stream))
        .route("/mock/faults", axum::routing::post(mock_faults))
}
