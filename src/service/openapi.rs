//! The OpenAPI document served at `/api/openapi.json`, generated from the
//! router itself ([`super::routes::api_router`] registers every handler
//! through its `#[utoipa::path]`), so it cannot drift from the code.
//!
//! [`CommonResponses`] adds the statuses every operation can answer without
//! its handler choosing them: 401 (a missing or wrong token), 500, 400/404
//! for path parameters, 400 for query parameters, 400/413/415 for bodies.

use std::sync::OnceLock;

use axum::Json;
use utoipa::openapi::path::{Operation, ParameterIn};
use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
use utoipa::openapi::{ContentBuilder, Ref, ResponseBuilder};
use utoipa::{Modify, OpenApi};

use super::error::ErrorBody;

#[derive(OpenApi)]
#[openapi(
    info(
        title = "lightbooth",
        description = "Spectroradiometer booth measurements, spectral renders and their comparison. Reads need no token on \
                       loopback; writes need `Authorization: Bearer <token>`. Times are POSIX seconds; spectra are \
                       numeric arrays on `wavelength_nm`, radiance in W/(sr·m²·nm); luminance Y in cd/m². Every \
                       error is `{\"error\": {\"code\", \"message\"}}`."
    ),
    components(schemas(super::events::Event, ErrorBody)),
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

/// Adds to every operation the error statuses it can answer whatever its
/// handler does (see the module doc), each with the JSON error body.
struct CommonResponses;

impl CommonResponses {
    fn add(operation: &mut Operation, status: &str, description: &str) {
        if operation.responses.responses.contains_key(status) {
            return;
        }
        let response = ResponseBuilder::new()
            .description(description)
            .content(
                "application/json",
                ContentBuilder::new()
                    .schema(Some(Ref::from_schema_name("ErrorBody")))
                    .build(),
            )
            .build();
        operation
            .responses
            .responses
            .insert(status.to_string(), response.into());
    }
}

impl Modify for CommonResponses {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        for item in openapi.paths.paths.values_mut() {
            for operation in [
                &mut item.get,
                &mut item.post,
                &mut item.put,
                &mut item.delete,
                &mut item.patch,
            ]
            .into_iter()
            .flatten()
            {
                let params = operation.parameters.as_deref().unwrap_or_default();
                let in_path = params.iter().any(|p| matches!(p.parameter_in, ParameterIn::Path));
                let in_query = params.iter().any(|p| matches!(p.parameter_in, ParameterIn::Query));
                let has_body = operation.request_body.is_some();
                if in_path || in_query || has_body {
                    Self::add(
                        operation,
                        "400",
                        "a parameter or the body is malformed; the message names it",
                    );
                }
                if in_path {
                    Self::add(operation, "404", "no such resource");
                }
                if has_body {
                    Self::add(operation, "413", "the body is larger than 64 KiB");
                    Self::add(operation, "415", "the body is neither JSON nor form-encoded");
                    Self::add(
                        operation,
                        "408",
                        "the body did not arrive within the body timeout (10 s); code `request_timeout`",
                    );
                }
                Self::add(
                    operation,
                    "401",
                    "a token is needed (writes; reads when not on loopback) or is wrong",
                );
                Self::add(operation, "500", "internal error (logged by the daemon)");
            }
        }
    }
}

/// The whole document: every route of [`super::routes::api_router`] under
/// `/api`, with the common responses. Built once.
pub fn api_document() -> &'static utoipa::openapi::OpenApi {
    static DOCUMENT: OnceLock<utoipa::openapi::OpenApi> = OnceLock::new();
    DOCUMENT.get_or_init(|| {
        let mut doc = utoipa_axum::router::OpenApiRouter::<super::AppState>::with_openapi(ApiDoc::openapi())
            .nest("/api", super::routes::api_router())
            .into_openapi();
        CommonResponses.modify(&mut doc);
        doc
    })
}

/// This document.
#[utoipa::path(get, path = "/openapi.json", tag = "service",
    responses((status = 200, description = "the OpenAPI 3.1 document of this API", content_type = "application/json")))]
pub async fn document() -> Json<&'static utoipa::openapi::OpenApi> {
    Json(api_document())
}
