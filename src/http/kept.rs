//! Response bodies the lab made once and keeps (`lab::computed`: an
//! analysis's JSON, CSV and MAT file, a scene's summary, its charts),
//! served without copying them; and the lab's files to save ([`download`]).

use std::sync::Arc;

use axum::body::{Body, Bytes};
use axum::http::header;
use axum::response::{IntoResponse, Response};

/// A kept body, shared with the lab's cache.
struct Shared(Arc<Vec<u8>>);

impl AsRef<[u8]> for Shared {
    fn as_ref(&self) -> &[u8] {
        self.0.as_slice()
    }
}

/// The kept `body` as a response body.
pub fn body(body: Arc<Vec<u8>>) -> Body {
    Body::from(Bytes::from_owner(Shared(body)))
}

/// A kept body served as `content_type`.
pub fn served(content_type: &'static str, kept: Arc<Vec<u8>>) -> Response {
    ([(header::CONTENT_TYPE, content_type)], body(kept)).into_response()
}

/// A kept JSON body.
pub fn json(kept: Arc<Vec<u8>>) -> Response {
    served("application/json", kept)
}

/// A file the lab made ([`crate::lab::Download`]) as an attachment: its
/// media type and the name to save it under.
pub fn download(file: crate::lab::Download) -> Response {
    (
        [
            (header::CONTENT_TYPE, file.format.media_type().to_string()),
            (
                header::CONTENT_DISPOSITION,
                format!("attachment; filename=\"{}\"", file.file_name),
            ),
        ],
        body(file.bytes),
    )
        .into_response()
}
