//! One error type for the whole REST API, mapped to HTTP statuses in one
//! place. Every error leaves as JSON `{"error": {"code": …, "message": …}}`,
//! which MATLAB's `webread` surfaces in its exception text.
//!
//! Errors the handlers never see get the same shape here: the router's
//! fallback ([`no_route`]), wrong methods ([`method_not_allowed`]), request
//! lines and headers over this service's limits ([`refuse_oversized_head`]),
//! and, as a last net, any error response some layer produced with a
//! non-JSON body ([`json_error_bodies`]).
//!
//! Limitation: hyper answers by itself, with an empty body, before any of
//! this code runs, when a request has more than 100 header fields, a head
//! over about 400 KiB, or a request target over 65,534 bytes. Requests under
//! those hard limits but over [`MAX_URI_BYTES`] / [`MAX_HEAD_BYTES`] get the
//! JSON 414 / 431 from [`refuse_oversized_head`].

use axum::extract::Request;
use axum::http::{header, HeaderValue, StatusCode, Uri};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

#[derive(Debug, thiserror::Error)]
pub enum ApiError {
    /// The request body or query is malformed; the message names the field.
    #[error("{0}")]
    BadRequest(String),
    #[error("{0}")]
    Unauthorized(String),
    #[error("{0}")]
    NotFound(String),
    /// The instrument's queue is full, or the resource is in the wrong state.
    #[error("{0}")]
    MethodNotAllowed(String),
    #[error("{0}")]
    Conflict(String),
    /// The request names a host this daemon does not answer for (see `http::hosts`).
    #[error("{0}")]
    MisdirectedRequest(String),
    #[error("{0}")]
    PayloadTooLarge(String),
    #[error("{0}")]
    UriTooLong(String),
    #[error("{0}")]
    HeadersTooLarge(String),
    #[error("{0}")]
    UnsupportedMediaType(String),
    /// The instrument is disconnected or in error.
    #[error("{0}")]
    Unavailable(String),
    #[error("internal error: {0}")]
    Internal(String),
}

/// The JSON body of every error response.
#[derive(Serialize, ToSchema)]
pub struct ErrorBody {
    pub error: ErrorDetail,
}

#[derive(Serialize, ToSchema)]
pub struct ErrorDetail {
    /// Stable, machine-readable: bad_request, unauthorized, not_found,
    /// method_not_allowed, request_timeout (408, from the body timeout in
    /// `limits`), conflict, misdirected_request (421, a `Host` the daemon
    /// does not answer: `hosts`), payload_too_large, uri_too_long,
    /// headers_too_large, unsupported_media_type, too_many_requests (429,
    /// too many event streams from one client: `limits`), unavailable, internal.
    pub code: &'static str,
    pub message: String,
}

impl ApiError {
    pub fn status(&self) -> StatusCode {
        match self {
            ApiError::BadRequest(_) => StatusCode::BAD_REQUEST,
            ApiError::Unauthorized(_) => StatusCode::UNAUTHORIZED,
            ApiError::NotFound(_) => StatusCode::NOT_FOUND,
            ApiError::MethodNotAllowed(_) => StatusCode::METHOD_NOT_ALLOWED,
            ApiError::Conflict(_) => StatusCode::CONFLICT,
            ApiError::MisdirectedRequest(_) => StatusCode::MISDIRECTED_REQUEST,
            ApiError::PayloadTooLarge(_) => StatusCode::PAYLOAD_TOO_LARGE,
            ApiError::UriTooLong(_) => StatusCode::URI_TOO_LONG,
            ApiError::HeadersTooLarge(_) => StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
            ApiError::UnsupportedMediaType(_) => StatusCode::UNSUPPORTED_MEDIA_TYPE,
            ApiError::Unavailable(_) => StatusCode::SERVICE_UNAVAILABLE,
            ApiError::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    pub fn code(&self) -> &'static str {
        match self {
            ApiError::BadRequest(_) => "bad_request",
            ApiError::Unauthorized(_) => "unauthorized",
            ApiError::NotFound(_) => "not_found",
            ApiError::MethodNotAllowed(_) => "method_not_allowed",
            ApiError::Conflict(_) => "conflict",
            ApiError::MisdirectedRequest(_) => "misdirected_request",
            ApiError::PayloadTooLarge(_) => "payload_too_large",
            ApiError::UriTooLong(_) => "uri_too_long",
            ApiError::HeadersTooLarge(_) => "headers_too_large",
            ApiError::UnsupportedMediaType(_) => "unsupported_media_type",
            ApiError::Unavailable(_) => "unavailable",
            ApiError::Internal(_) => "internal",
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        if let ApiError::Internal(msg) = &self {
            tracing::error!(error = %msg, "internal error answering a request");
        }
        let mut response = (
            self.status(),
            Json(ErrorBody {
                error: ErrorDetail {
                    code: self.code(),
                    message: self.to_string(),
                },
            }),
        )
            .into_response();
        if matches!(self, ApiError::Unauthorized(_)) {
            response
                .headers_mut()
                .insert("www-authenticate", axum::http::HeaderValue::from_static("Bearer"));
        }
        response
    }
}

/// The one place a workflow's refusal becomes a status.
impl From<crate::lab::error::LabError> for ApiError {
    fn from(e: crate::lab::error::LabError) -> Self {
        use crate::lab::error::LabError;
        match e {
            LabError::Invalid(m) => ApiError::BadRequest(m),
            LabError::NotFound(m) => ApiError::NotFound(m),
            LabError::Conflict(m) => ApiError::Conflict(m),
            LabError::Unavailable(m) => ApiError::Unavailable(m),
            LabError::Internal(m) => ApiError::Internal(m),
        }
    }
}

/// Turns a status some other layer chose (axum's rejections, a method
/// router's 405) into the error with that status.
pub fn from_rejection(status: StatusCode, message: String) -> ApiError {
    match status {
        StatusCode::UNAUTHORIZED => ApiError::Unauthorized(message),
        StatusCode::NOT_FOUND => ApiError::NotFound(message),
        StatusCode::METHOD_NOT_ALLOWED => ApiError::MethodNotAllowed(message),
        StatusCode::CONFLICT => ApiError::Conflict(message),
        StatusCode::MISDIRECTED_REQUEST => ApiError::MisdirectedRequest(message),
        StatusCode::PAYLOAD_TOO_LARGE => ApiError::PayloadTooLarge(message),
        StatusCode::URI_TOO_LONG => ApiError::UriTooLong(message),
        StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE => ApiError::HeadersTooLarge(message),
        StatusCode::UNSUPPORTED_MEDIA_TYPE => ApiError::UnsupportedMediaType(message),
        StatusCode::SERVICE_UNAVAILABLE => ApiError::Unavailable(message),
        s if s.is_server_error() => ApiError::Internal(message),
        _ => ApiError::BadRequest(message),
    }
}

/// The router's fallback: no route has this path.
pub async fn no_route(uri: Uri) -> ApiError {
    ApiError::NotFound(format!(
        "no resource at `{}`; the API is listed at /api/openapi.json",
        uri.path()
    ))
}

/// Every method router's fallback: the path exists, the method does not.
/// (axum adds the `Allow` header itself.)
pub async fn method_not_allowed(method: axum::http::Method, uri: Uri) -> ApiError {
    ApiError::MethodNotAllowed(format!("`{method}` is not allowed on `{}`", uri.path()))
}

/// Longest request target (path and query) the service reads: no API path
/// or query comes near it.
pub const MAX_URI_BYTES: usize = 8 * 1024;
/// Most bytes of header fields (names and values) the service reads.
pub const MAX_HEAD_BYTES: usize = 32 * 1024;

/// Refuses a request whose target or headers exceed the service's limits
/// with 414 or 431 in the JSON shape (hyper's own, larger limits answer
/// with an empty body: see the module doc), and one whose `Content-Length`
/// exceeds [`super::MAX_BODY_BYTES`] with 413 before its body is read.
pub async fn refuse_oversized_head(request: Request, next: Next) -> Response {
    let uri_len = request.uri().to_string().len();
    if uri_len > MAX_URI_BYTES {
        return ApiError::UriTooLong(format!(
            "the request target is {uri_len} bytes; the limit is {MAX_URI_BYTES}"
        ))
        .into_response();
    }
    let head: usize = request
        .headers()
        .iter()
        .map(|(name, value)| name.as_str().len() + value.len())
        .sum();
    if head > MAX_HEAD_BYTES {
        return ApiError::HeadersTooLarge(format!(
            "the header fields are {head} bytes; the limit is {MAX_HEAD_BYTES}"
        ))
        .into_response();
    }
    // A body announced too large is refused at once, not read (nor waited for).
    let announced = request
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    // The OpenEXR upload of a stimulus set is the one larger body.
    let limit = if request.uri().path() == "/api/stimulus-sets/exr" {
        super::routes::MAX_UPLOAD_BYTES
    } else {
        super::MAX_BODY_BYTES
    };
    if let Some(length) = announced.filter(|&l| l > limit as u64) {
        let mut response = ApiError::PayloadTooLarge(format!(
            "the body is {length} bytes (Content-Length); the limit is {limit} bytes"
        ))
        .into_response();
        // The body is not read, so the connection cannot carry another request.
        response
            .headers_mut()
            .insert(header::CONNECTION, HeaderValue::from_static("close"));
        return response;
    }
    next.run(request).await
}

/// The last net: an error response with a body that is not JSON (or no
/// body) leaves in the JSON error shape, with the same status and headers
/// (`Allow`, `WWW-Authenticate`) and its text as the message.
pub async fn json_error_bodies(response: Response) -> Response {
    let status = response.status();
    let is_json = response
        .headers()
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"application/json"));
    if !(status.is_client_error() || status.is_server_error()) || is_json {
        return response;
    }
    let (mut parts, body) = response.into_parts();
    let text = axum::body::to_bytes(body, 64 * 1024)
        .await
        .map(|b| String::from_utf8_lossy(&b).trim().to_string())
        .unwrap_or_default();
    let message = if text.is_empty() {
        status.canonical_reason().unwrap_or("error").to_ascii_lowercase()
    } else {
        text
    };
    let fresh = from_rejection(status, message).into_response();
    let (fresh_parts, fresh_body) = fresh.into_parts();
    parts.headers.remove(header::CONTENT_LENGTH);
    parts.headers.insert(
        header::CONTENT_TYPE,
        fresh_parts
            .headers
            .get(header::CONTENT_TYPE)
            .cloned()
            .unwrap_or(HeaderValue::from_static("application/json")),
    );
    Response::from_parts(parts, fresh_body)
}
