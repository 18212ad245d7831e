//! The OpenAPI document served at `/api/openapi.json`, generated from the
//! router itself ([`super::routes::api_router`] registers every handler
//! through its `#[utoipa::path]`), so it cannot drift from the code.
//!
//! [`CommonResponses`] adds the statuses every operation can answer without
//! its handler choosing them: 401 (a missing or wrong token), 421 (a `Host`
//! the daemon does not answer), 500, 400/404 for path parameters, 400 for
//! query parameters, 400/413/415 for bodies.
//!
//! [`state_request_rules`] then writes into the document the rules the
//! handlers enforce that the derived schemas cannot say: arrays of exactly
//! three drives in 0–1, "exactly one of `standard` / `standard_csv`", a
//! `target` only with its `scene`, open and closed bounds on numbers, the
//! forms of coding lists and fault specs, and ids in paths as plain digits
//! (`minimum: 0`). Schemathesis checks both directions
//! (`tests/api/api_schemathesis.rs`): every request the document allows is
//! accepted, and every one it forbids is refused.

use std::sync::OnceLock;

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
    components(schemas(crate::lab::events::Event, ErrorBody)),
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
                // Every operation: a query key it does not take (`input::refuse_unknown_query_keys`).
                Self::add(
                    operation,
                    "400",
                    if in_path || in_query || has_body {
                        "a parameter or the body is malformed, or a query key is one the operation does not \
                         take; the message names it"
                    } else {
                        "a query key the operation does not take (it takes none); the message names it"
                    },
                );
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
                Self::add(
                    operation,
                    "421",
                    "the `Host` names a host this daemon does not answer for (see `--allowed-host`)",
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

/// The document as served: [`api_document`] with [`state_request_rules`]. Built once.
pub fn served_document() -> &'static serde_json::Value {
    static DOCUMENT: OnceLock<serde_json::Value> = OnceLock::new();
    DOCUMENT.get_or_init(|| {
        let mut doc = serde_json::to_value(api_document()).expect("the OpenAPI document serialises");
        state_request_rules(&mut doc);
        image_refresh_key(&mut doc);
        doc
    })
}

/// Gives every GET of an image (SVG, PNG) that takes no other query the
/// query key `t`, ignored: a page that redraws a changed image (the live
/// spectrum, a scene's charts) adds `?t=<time>` so the browser fetches it
/// again. Unknown query keys are refused (`input::refuse_unknown_query_keys`),
/// so the document says this one is taken.
fn image_refresh_key(doc: &mut serde_json::Value) {
    let Some(paths) = doc["paths"].as_object_mut() else {
        return;
    };
    for item in paths.values_mut() {
        let Some(get) = item.get_mut("get") else {
            continue;
        };
        let image = get["responses"]["200"]["content"]
            .as_object()
            .is_some_and(|c| c.keys().any(|k| k.starts_with("image/")));
        let params = get["parameters"].as_array().cloned().unwrap_or_default();
        if !image || params.iter().any(|p| p["in"] == "query") {
            continue;
        }
        let mut params = params;
        params.push(serde_json::json!({
            "name": "t", "in": "query", "required": false,
            "description": "ignored: a page adds it (e.g. the time) to fetch a changed image again",
            "schema": {"type": "string"},
        }));
        get["parameters"] = serde_json::Value::Array(params);
    }
}

/// A coding: `rgb`, `srgb`, `spectral` or `nstepN` with 1 ≤ N ≤ 81.
const CODING: &str = "(rgb|srgb|spectral|nstep([1-9]|[1-7][0-9]|8[01]))";
/// A fault of the simulated PR-650: `KIND[@DELAY][:RATE]` (see `instrument::sim::Fault`).
const FAULT: &str =
    "((no-answer|truncate|garble|stale|error-code|cable-pull|double-crlf|link-dies)|slow(@[0-9]{1,4}ms)?)\
                     (:(once|[0-9]{1,3}x|0(\\.[0-9]{1,3})?|1(\\.0{1,3})?))?";

/// Writes the handlers' rules the derived schemas leave out into `doc` (see
/// the module doc). Each rule here is enforced by the handler named.
pub fn state_request_rules(doc: &mut serde_json::Value) {
    use serde_json::json;
    let schemas = &mut doc["components"]["schemas"];
    let three_drives = json!({
        "type": "array", "minItems": 3, "maxItems": 3,
        "items": {"type": "number", "minimum": 0.0, "maximum": 1.0},
    });
    // `routes::mock::mock_display`, `routes::display_profiles`: `[f64; 3]`, each 0–1.
    for (schema, field) in [("MockDisplay", "drive"), ("ShownPatch", "drive")] {
        merge(&mut schemas[schema]["properties"][field], &three_drives);
    }
    // `routes::reflectances`, `routes::illuminants`: exactly one of a shipped
    // standard and a calibration CSV; `standard_file` only with the CSV.
    for schema in ["NewReflectance", "NewIlluminant"] {
        schemas[schema]["oneOf"] = json!([
            {"required": ["standard"], "properties": {
                "standard": {"type": "string"}, "standard_csv": {"type": "null"}, "standard_file": {"type": "null"}}},
            {"required": ["standard_csv"], "properties": {
                "standard_csv": {"type": "string"}, "standard": {"type": "null"}}},
        ]);
    }
    // `routes::measurements::start_measurement`: a target needs its scene.
    schemas["StartMeasurement"]["anyOf"] = json!([
        {"properties": {"target": {"type": "null"}}},
        {"required": ["scene"], "properties": {"scene": {"type": "string"}}},
    ]);
    // `lab::render::images` (`check_request`): 0 < SE target ≤ 1, 0 < time budget ≤ 600 s.
    merge(
        &mut schemas["ImageRequest"]["properties"]["target_relative_se"],
        &json!({"exclusiveMinimum": 0.0, "maximum": 1.0}),
    );
    merge(
        &mut schemas["ImageRequest"]["properties"]["time_budget_s"],
        &json!({"exclusiveMinimum": 0.0, "maximum": 600.0}),
    );
    merge(
        &mut schemas["ImageRequest"]["properties"]["coding"],
        &json!({"pattern": format!("^{CODING}$")}),
    );
    // `lab::render::runner` (`settings`): a comma-separated list of known codings.
    merge(
        &mut schemas["RenderRequest"]["properties"]["codings"],
        &json!({"pattern": format!("^ *{CODING} *( *, *{CODING} *)*$")}),
    );
    // `routes::studies::start_study`: at least one scene name in the list.
    merge(
        &mut schemas["StudyRequest"]["properties"]["scenes"],
        &json!({"pattern": "[^, ]"}),
    );
    // `routes::mock::mock_faults`: empty (clears), or comma-separated faults.
    merge(
        &mut schemas["MockFaults"]["properties"]["faults"],
        &json!({"pattern": format!("^( *{FAULT} *(, *{FAULT} *)*)?$")}),
    );
    // `store::Booth`: 1–64 letters, digits, `-`, `_`, `.` (the filter of `GET /api/measurements`).
    if let Some(parameters) = doc["paths"]["/api/measurements"]["get"]["parameters"].as_array_mut() {
        for p in parameters.iter_mut().filter(|p| p["name"] == "booth") {
            merge(&mut p["schema"], &json!({"pattern": "^[A-Za-z0-9._-]{1,64}$"}));
        }
    }
    // `input::Path`: ids are plain digits, so never negative.
    if let Some(paths) = doc["paths"].as_object_mut() {
        for item in paths.values_mut() {
            let Some(item) = item.as_object_mut() else { continue };
            for operation in item.values_mut() {
                // `get_mut`, not `[..]`: indexing inserts `"parameters": null`
                // into operations without parameters, an invalid document.
                let Some(parameters) = operation.get_mut("parameters").and_then(|p| p.as_array_mut()) else {
                    continue;
                };
                for p in parameters {
                    if p["in"] == "path" && p["schema"]["type"] == "integer" {
                        p["schema"]["minimum"] = json!(0);
                    }
                }
            }
        }
    }
}

/// Adds the keys of `rules` to the schema `into` (which may be a `$ref`-free object).
fn merge(into: &mut serde_json::Value, rules: &serde_json::Value) {
    if let (Some(into), Some(rules)) = (into.as_object_mut(), rules.as_object()) {
        for (k, v) in rules {
            into.insert(k.clone(), v.clone());
        }
    }
}
