//! Request bodies and queries that name the field at fault.
//!
//! MATLAB's `webwrite(url, struct)` sends `application/x-www-form-urlencoded`
//! unless told otherwise, and scripts also send JSON: [`Input`] accepts both
//! for simple POSTs. Unknown fields are rejected (the body types use
//! `deny_unknown_fields`), and errors say which field was wrong, via
//! `serde_path_to_error`. A JSON body is one value and nothing after it
//! (trailing bytes are refused, not ignored). [`Path`] names the path
//! parameter that does not parse, in the same JSON error shape, and refuses
//! numbers written with a sign or leading zeros (`/api/images/+1`): ids are
//! plain digits ([`plain_id`], also for ids in a query).
//!
//! Valid JSON of the wrong type for a field (`"geometry": 5` where a name
//! is taken) is named as such, with the field, not called malformed JSON
//! (serde_json reports some of those as syntax errors). A query key a
//! route does not take is refused, not ignored
//! ([`refuse_unknown_query_keys`], on every route, from the keys the
//! OpenAPI document lists for it).

use std::collections::HashMap;
use std::sync::OnceLock;

use axum::body::Bytes;
use axum::extract::path::ErrorKind;
use axum::extract::rejection::PathRejection;
use axum::extract::{FromRequest, FromRequestParts, MatchedPath, RawPathParams, Request};
use axum::http::header::CONTENT_TYPE;
use axum::http::request::Parts;
use axum::http::Method;
use axum::middleware::Next;
use axum::response::Response;
use serde::de::DeserializeOwned;

use super::error::{from_rejection, ApiError};

/// A JSON or form-encoded body deserialised into `T`.
pub struct Input<T>(pub T);

impl<S, T> FromRequest<S> for Input<T>
where
    T: DeserializeOwned,
    S: Send + Sync,
{
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, ApiError> {
        let content_type = req
            .headers()
            .get(CONTENT_TYPE)
            .and_then(|v| v.to_str().ok())
            .unwrap_or("")
            .split(';')
            .next()
            .unwrap_or("")
            .trim()
            .to_ascii_lowercase();
        let bytes = Bytes::from_request(req, state)
            .await
            .map_err(|r| from_rejection(r.status(), format!("cannot read the request body: {}", r.body_text())))?;
        match content_type.as_str() {
            "application/json" => {
                // `null` is "no body" (the document marks default-able bodies optional): all defaults.
                let bytes: &[u8] = if bytes.trim_ascii() == b"null" { b"{}" } else { &bytes };
                let mut de = serde_json::Deserializer::from_slice(bytes);
                let value = serde_path_to_error::deserialize(&mut de).map_err(|e| {
                    let path = e.path().to_string();
                    let inner = e.inner().to_string();
                    if inner.starts_with("trailing characters") && path != "." && !path.is_empty() {
                        // A fixed-size array given too many elements (a 4-element `drive`):
                        // serde_json calls it trailing characters; name the field (issue 32).
                        let at = inner.trim_start_matches("trailing characters").trim();
                        ApiError::BadRequest(format!("field `{path}`: more elements than it takes ({at})"))
                    } else if e.inner().is_syntax() || e.inner().is_eof() {
                        wrong_type_in_valid_json::<T>(bytes)
                            .unwrap_or_else(|| ApiError::BadRequest(format!("malformed JSON: {}", e.inner())))
                    } else {
                        field_error(&e)
                    }
                })?;
                // `{"samples":3}xx` is not a JSON document: refuse what follows the value.
                de.end()
                    .map_err(|e| ApiError::BadRequest(format!("malformed JSON: bytes after the JSON value ({e})")))?;
                Ok(Input(value))
            }
            "application/x-www-form-urlencoded" => {
                let de = serde_urlencoded::Deserializer::new(form_urlencoded::parse(&bytes));
                serde_path_to_error::deserialize(de)
                    .map(Input)
                    .map_err(|e| field_error(&e))
            }
            "" if bytes.is_empty() => {
                // An empty POST (MATLAB `webwrite(url)` with no data): all defaults.
                let mut de = serde_json::Deserializer::from_slice(b"{}");
                serde_path_to_error::deserialize(&mut de)
                    .map(Input)
                    .map_err(|e| field_error(&e))
            }
            other => Err(ApiError::UnsupportedMediaType(format!(
                "send the body as application/json or application/x-www-form-urlencoded, not `{other}`"
            ))),
        }
    }
}

/// When `bytes` is valid JSON that `T` refused as a syntax error (serde_json
/// answers "expected value" for an enum given a number, an array, `true`
/// or `null`, issue 46): the refusal of the same value read as a JSON tree,
/// which names the field and the type it takes.
fn wrong_type_in_valid_json<T: DeserializeOwned>(bytes: &[u8]) -> Option<ApiError> {
    let value: serde_json::Value = serde_json::from_slice(bytes).ok()?;
    serde_path_to_error::deserialize::<_, T>(value)
        .err()
        .map(|e| field_error(&e))
}

/// A query string deserialised into `T`, with the same field-naming errors.
pub struct Query<T>(pub T);

impl<S, T> FromRequestParts<S> for Query<T>
where
    T: DeserializeOwned,
    S: Send + Sync,
{
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, _state: &S) -> Result<Self, ApiError> {
        let query = parts.uri.query().unwrap_or("");
        let de = serde_urlencoded::Deserializer::new(form_urlencoded::parse(query.as_bytes()));
        serde_path_to_error::deserialize(de)
            .map(Query)
            .map_err(|e| field_error(&e))
    }
}

/// Path parameters deserialised into `T`; a value that does not parse is a
/// 400 naming the parameter, e.g. ``path parameter `id`: `abc` is not a valid i64``.
pub struct Path<T>(pub T);

impl<S, T> FromRequestParts<S> for Path<T>
where
    T: DeserializeOwned + Send,
    S: Send + Sync,
{
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, ApiError> {
        if let Ok(raw) = RawPathParams::from_request_parts(parts, state).await {
            // Only ids: a name (`/api/studies/{id}/files/{name}`) may well be `01`.
            let is_id = |key: &str| key == "id" || key.ends_with("_id");
            if let Some((key, value)) = raw.iter().find(|(k, v)| is_id(k) && is_unplain_number(v)) {
                return Err(ApiError::BadRequest(format!(
                    "path parameter `{key}`: `{value}` is not a plain number: write the digits alone, \
                     without a sign or leading zeros"
                )));
            }
        }
        let rejection = match axum::extract::Path::<T>::from_request_parts(parts, state).await {
            Ok(axum::extract::Path(value)) => return Ok(Path(value)),
            Err(r) => r,
        };
        let PathRejection::FailedToDeserializePathParams(e) = &rejection else {
            return Err(from_rejection(rejection.status(), rejection.body_text()));
        };
        let names: Vec<String> = RawPathParams::from_request_parts(parts, state)
            .await
            .map(|p| p.iter().map(|(k, _)| k.to_string()).collect())
            .unwrap_or_default();
        let named = |index: usize| names.get(index).map(String::as_str).unwrap_or("?").to_string();
        let message = match e.kind() {
            ErrorKind::ParseErrorAtKey {
                key,
                value,
                expected_type,
            } => format!("path parameter `{key}`: `{value}` is not a valid {expected_type}"),
            ErrorKind::ParseErrorAtIndex {
                index,
                value,
                expected_type,
            } => format!(
                "path parameter `{}`: `{value}` is not a valid {expected_type}",
                named(*index)
            ),
            ErrorKind::ParseError { value, expected_type } => {
                format!(
                    "path parameter `{}`: `{value}` is not a valid {expected_type}",
                    named(0)
                )
            }
            _ => format!("path parameters: {}", e.body_text()),
        };
        Err(from_rejection(e.status(), message))
    }
}

/// An id as written in a path or a query: plain digits, without a sign or
/// leading zeros (`-1`, `+3`, `007` are refused, as in a path: one
/// resource, one URL); `None` otherwise.
pub fn plain_id(text: &str) -> Option<i64> {
    let plain =
        !text.is_empty() && text.bytes().all(|b| b.is_ascii_digit()) && !(text.len() > 1 && text.starts_with('0'));
    plain.then(|| text.parse().ok()).flatten()
}

/// The query keys each operation of the API takes, from the OpenAPI
/// document: (method, path template) → keys.
fn query_keys() -> &'static HashMap<(String, String), Vec<String>> {
    static KEYS: OnceLock<HashMap<(String, String), Vec<String>>> = OnceLock::new();
    KEYS.get_or_init(|| {
        let mut keys = HashMap::new();
        let paths = super::openapi::served_document()["paths"]
            .as_object()
            .cloned()
            .unwrap_or_default();
        for (path, item) in paths {
            for (method, operation) in item.as_object().into_iter().flatten() {
                let names = operation["parameters"]
                    .as_array()
                    .into_iter()
                    .flatten()
                    .filter(|p| p["in"] == "query")
                    .filter_map(|p| p["name"].as_str().map(String::from))
                    .collect();
                keys.insert((method.to_ascii_uppercase(), path.clone()), names);
            }
        }
        keys
    })
}

/// Middleware on every API route: a query key the route does not take is
/// answered 400 naming it and the keys the route takes (issue 46: a
/// misspelt `limt=5`, or any key on a route without a query, was ignored
/// silently). The keys are those the OpenAPI document lists for the
/// operation, so what is refused and what is documented cannot differ.
pub async fn refuse_unknown_query_keys(req: Request, next: Next) -> Result<Response, ApiError> {
    if let (Some(query), Some(matched)) = (req.uri().query(), req.extensions().get::<MatchedPath>()) {
        let template = matched.as_str();
        let template = if template.starts_with("/api/") {
            template.to_string()
        } else {
            format!("/api{template}")
        };
        let method = if req.method() == Method::HEAD {
            "GET".to_string()
        } else {
            req.method().as_str().to_string()
        };
        if let Some(accepted) = query_keys().get(&(method.clone(), template.clone())) {
            if let Some((key, _)) =
                form_urlencoded::parse(query.as_bytes()).find(|(k, _)| !accepted.iter().any(|a| a == k))
            {
                let takes = if accepted.is_empty() {
                    "takes no query parameters; remove it".to_string()
                } else {
                    let listed: Vec<String> = accepted.iter().map(|k| format!("`{k}`")).collect();
                    format!("does not take it; it takes {}", listed.join(", "))
                };
                return Err(ApiError::BadRequest(format!(
                    "query key `{key}`: {method} {template} {takes}"
                )));
            }
        }
    }
    Ok(next.run(req).await)
}

/// A number with a sign or leading zeros (`+1`, `-0`, `007`), which Rust's
/// integer parsing accepts but no id is written as: one resource, one URL.
fn is_unplain_number(value: &str) -> bool {
    let digits = value.strip_prefix(['+', '-']).unwrap_or(value);
    !digits.is_empty()
        && digits.bytes().all(|b| b.is_ascii_digit())
        && (digits.len() != value.len() || (digits.len() > 1 && digits.starts_with('0')))
}

/// Refuses paging outside its range rather than clamping it silently:
/// `limit` 1–1000, `offset` ≥ 0.
pub fn check_paging(limit: Option<i64>, offset: Option<i64>) -> Result<(), ApiError> {
    if let Some(limit) = limit.filter(|l| !(1..=1000).contains(l)) {
        return Err(ApiError::BadRequest(format!(
            "parameter `limit`: {limit} is outside 1–1000"
        )));
    }
    if let Some(offset) = offset.filter(|o| *o < 0) {
        return Err(ApiError::BadRequest(format!(
            "parameter `offset`: {offset} is negative"
        )));
    }
    Ok(())
}

fn field_error<E: std::fmt::Display>(e: &serde_path_to_error::Error<E>) -> ApiError {
    let path = e.path().to_string();
    if path == "." || path.is_empty() {
        ApiError::BadRequest(format!("malformed request: {}", e.inner()))
    } else {
        ApiError::BadRequest(format!("field `{path}`: {}", e.inner()))
    }
}
