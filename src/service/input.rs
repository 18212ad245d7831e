//! Request bodies and queries that name the field at fault.
//!
//! MATLAB's `webwrite(url, struct)` sends `application/x-www-form-urlencoded`
//! unless told otherwise, and scripts also send JSON: [`Input`] accepts both
//! for simple POSTs. Unknown fields are rejected (the body types use
//! `deny_unknown_fields`), and errors say which field was wrong, via
//! `serde_path_to_error`.

use axum::body::Bytes;
use axum::extract::{FromRequest, FromRequestParts, Request};
use axum::http::header::CONTENT_TYPE;
use axum::http::request::Parts;
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
                let mut de = serde_json::Deserializer::from_slice(&bytes);
                serde_path_to_error::deserialize(&mut de).map(Input).map_err(|e| {
                    if e.inner().is_syntax() || e.inner().is_eof() {
                        ApiError::BadRequest(format!("malformed JSON: {}", e.inner()))
                    } else {
                        field_error(&e)
                    }
                })
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

fn field_error<E: std::fmt::Display>(e: &serde_path_to_error::Error<E>) -> ApiError {
    let path = e.path().to_string();
    if path == "." || path.is_empty() {
        ApiError::BadRequest(format!("malformed request: {}", e.inner()))
    } else {
        ApiError::BadRequest(format!("field `{path}`: {}", e.inner()))
    }
}
