//! The OpenAPI document served at `/api/openapi.json`, generated from the
//! handlers' annotations so it cannot drift from the code.

use axum::Json;
use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
use utoipa::{Modify, OpenApi};

use super::routes;

#[derive(OpenApi)]
#[openapi(
    info(
        title = "lightbooth",
        description = "PR-650 booth measurements, spectral renders and their comparison. Reads need no token on \
                       loopback; writes need `Authorization: Bearer <token>`. Times are POSIX seconds; spectra are \
                       numeric arrays on `wavelength_nm`, radiance in W/(sr·m²·nm); luminance Y in cd/m²."
    ),
    paths(
        routes::health,
        routes::instruments,
        routes::list_sessions,
        routes::create_session,
        routes::list_measurements,
        routes::start_measurement,
        routes::get_measurement,
        routes::cancel_measurement,
        routes::measurement_csv,
        routes::measurement_mat,
        routes::measurement_svg,
        routes::measurement_comparisons,
        routes::list_scenes,
        routes::get_scene,
        routes::scene_targets,
        routes::scene_renders,
        routes::start_render,
        routes::get_render,
        routes::render_preview,
        routes::cancel_render,
        routes::retry_render,
        routes::scene_comparisons,
        routes::scene_comparisons_csv,
        routes::scene_comparisons_mat,
        routes::scene_chart,
        routes::mock_faults,
        routes::list_studies,
        routes::start_study,
        routes::get_study,
        routes::study_file,
        routes::cancel_study,
        routes::retry_study,
        super::events::stream,
    ),
    components(schemas(super::events::Event, super::error::ErrorBody)),
    modifiers(&BearerAuth)
)]
pub struct ApiDoc;

struct BearerAuth;

impl Modify for BearerAuth {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        let components = openapi.components.get_or_insert_with(Default::default);
        components.add_security_scheme(
            "bearer",
            SecurityScheme::Http(HttpBuilder::new().scheme(HttpAuthScheme::Bearer).build()),
        );
    }
}

pub async fn document() -> Json<utoipa::openapi::OpenApi> {
    Json(ApiDoc::openapi())
}
