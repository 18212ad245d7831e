//! The REST API's handlers, one file per resource (as mini-redis keeps one
//! file per command). Paths that scripts depend on are fixed:
//! `/api/health`, `/api/openapi.json`, `/api/measurements`,
//! `/api/measurements/{id}`, `/api/events`.
//!
//! [`api_router`] is the whole table of paths; each handler documents itself
//! for the OpenAPI document with `#[utoipa::path]`, and that annotation's
//! path and method are also what the router serves (`utoipa_axum::routes!`).

mod booths;
mod comparisons;
mod credentials;
mod display_profiles;
mod experiments;
mod health;
mod hold;
mod illuminants;
mod images;
mod jobs;
mod measurements;
mod mock;
mod reflectances;
mod scenes;
mod sessions;
mod stimulus_sets;
mod studies;

use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

pub use booths::*;
pub use comparisons::*;
pub use credentials::*;
pub use display_profiles::*;
pub use experiments::*;
pub use health::*;
pub use hold::*;
pub use illuminants::*;
pub use images::*;
pub use jobs::*;
pub use measurements::*;
pub use mock::*;
pub use reflectances::*;
pub use scenes::*;
pub use sessions::*;
pub use stimulus_sets::*;
pub use studies::*;

use super::{sse, AppState};

/// Every path of the API (relative to `/api`) with its handlers. Each
/// `routes!` entry takes its path and methods from the handlers'
/// `#[utoipa::path]`, so the router and the OpenAPI document are one table
/// and cannot drift apart.
pub fn api_router() -> OpenApiRouter<AppState> {
    OpenApiRouter::default()
        .routes(routes!(health))
        .routes(routes!(document))
        .routes(routes!(read_cookie))
        .routes(routes!(instruments))
        .routes(routes!(scan_instruments))
        .routes(routes!(list_booths))
        .routes(routes!(list_jobs))
        .routes(routes!(list_sessions, create_session))
        .routes(routes!(list_measurements, start_measurement))
        .routes(routes!(get_measurement))
        .routes(routes!(measurement_colorimetry))
        .routes(routes!(cancel_measurement))
        .routes(routes!(measurement_csv))
        .routes(routes!(measurement_mat))
        .routes(routes!(measurement_svg))
        .routes(routes!(measurement_comparisons))
        .routes(routes!(measurement_luminance_comparisons))
        .routes(routes!(list_scenes))
        .routes(routes!(scene_overview))
        .routes(routes!(get_scene))
        .routes(routes!(scene_targets))
        .routes(routes!(scene_renders, start_render))
        .routes(routes!(scene_comparisons))
        .routes(routes!(scene_comparisons_csv))
        .routes(routes!(scene_comparisons_mat))
        .routes(routes!(scene_chart))
        .routes(routes!(list_studies, start_study))
        .routes(routes!(get_study))
        .routes(routes!(study_file))
        .routes(routes!(cancel_study))
        .routes(routes!(retry_study))
        .routes(routes!(get_render))
        .routes(routes!(cancel_render))
        .routes(routes!(retry_render))
        .routes(routes!(render_preview))
        .routes(routes!(render_images, start_image))
        .routes(routes!(get_image))
        .routes(routes!(cancel_image))
        .routes(routes!(image_display_png))
        .routes(routes!(image_pixel))
        .routes(routes!(image_pixel_svg))
        .routes(routes!(image_exr))
        .routes(routes!(image_mat))
        .routes(routes!(image_set_exr))
        .routes(routes!(image_delta_e))
        .routes(routes!(image_delta_e_png))
        .routes(routes!(list_reflectances, create_reflectance_route))
        .routes(routes!(get_reflectance))
        .routes(routes!(reflectance_csv))
        .routes(routes!(reflectance_svg))
        .routes(routes!(list_illuminants, create_illuminant_route))
        .routes(routes!(get_illuminant))
        .routes(routes!(illuminant_csv))
        .routes(routes!(sse::stream))
        .routes(routes!(mock_faults))
        .routes(routes!(mock_display))
        .routes(routes!(take_instrument_hold, get_instrument_hold))
        .routes(routes!(release_instrument_hold))
        .routes(routes!(renew_instrument_hold))
        .routes(routes!(display_calibration_plan))
        .routes(routes!(list_display_profiles, create_display_profile))
        .routes(routes!(get_display_profile))
        .routes(routes!(display_profile_chart))
        .routes(routes!(list_experiments, create_experiment))
        .routes(routes!(check_experiment))
        .routes(routes!(get_experiment))
        .routes(routes!(list_experiment_sessions, start_experiment_session))
        .routes(routes!(get_experiment_session))
        .routes(routes!(report_session_display))
        .routes(routes!(record_experiment_trial))
        .routes(routes!(list_experiment_verifications, create_experiment_verification))
        .routes(routes!(experiment_analysis))
        .routes(routes!(experiment_analysis_csv))
        .routes(routes!(experiment_analysis_mat))
        .routes(routes!(experiment_thresholds_csv))
        .routes(routes!(experiment_psychometric_figure))
        .routes(routes!(experiments_figure))
        .routes(routes!(list_stimulus_sets, create_stimulus_set))
        .routes(routes!(get_stimulus_set))
        .routes(routes!(stimulus_set_linear))
        .routes(routes!(stimulus_set_delta_e))
        .routes(routes!(stimulus_set_targets))
        .routes(routes!(
            list_stimulus_set_verifications,
            create_stimulus_set_verification
        ))
        .routes(routes!(stimulus_set_verification_chart))
        // The one body larger than `MAX_BODY_BYTES`: an OpenEXR file.
        .merge(
            OpenApiRouter::default()
                .routes(routes!(upload_stimulus_set))
                .layer(axum::extract::DefaultBodyLimit::max(MAX_UPLOAD_BYTES)),
        )
}
