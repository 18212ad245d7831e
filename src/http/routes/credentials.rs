//! `/api/read-cookie`: the dashboard's read-only credential for what
//! cannot send the `Authorization` header (`<img>`, downloads, the event
//! stream) when the daemon is bound off loopback (see `http::auth`).

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};

use crate::http::auth::{read_cookie_name, read_token};
use crate::http::AppState;

/// Sets the read-only cookie `lightbooth_read_<port>` (HttpOnly,
/// SameSite=Strict, Path=/api) for this run of the daemon. Needs the write
/// token in the header, like every POST; the cookie itself authorises reads
/// only, and never holds the write token.
#[utoipa::path(post, path = "/read-cookie", tag = "service",
    responses((status = 204, description = "the read-only cookie is set (`Set-Cookie`)"),
              (status = 401, body = crate::http::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn read_cookie(State(state): State<AppState>) -> Response {
    let cookie = format!(
        "{}={}; Path=/api; HttpOnly; SameSite=Strict",
        read_cookie_name(state.config.allowed_hosts.port()),
        read_token(&state.config.token)
    );
    (StatusCode::NO_CONTENT, [(header::SET_COOKIE, cookie)]).into_response()
}
