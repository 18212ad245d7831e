//! Which `Host` a request may name: the defence against DNS rebinding.
//!
//! A page of `attacker.example` can make its own name resolve to 127.0.0.1
//! and then read, as same-origin requests, whatever a daemon on loopback
//! answers without a token. Its requests carry `Host: attacker.example`, so
//! the daemon answers only requests that name
//!
//! - `localhost` or a name under `.localhost` (which browsers resolve to
//!   loopback themselves, RFC 6761 §6.3),
//! - a loopback address (`127.0.0.0/8`, `[::1]`) or the address the daemon
//!   listens on — any IP address when it listens on all of them (`0.0.0.0`,
//!   `[::]`): an address is not a name an attacker can rebind,
//! - or a name of the operator's allow-list (`serve --allowed-host NAME`,
//!   `allowed_hosts` in `lightbooth.toml`), e.g. the booth PC's own name
//!   when the daemon is reached by it.
//!
//! Anything else is answered 421 (Misdirected Request) naming the host and
//! how to allow it. The port is not checked: a rebound name is refused
//! whatever port it names.
//!
//! Which host a request names follows RFC 9112 §3.2: an HTTP/1.1 request
//! without `Host`, and any request with more than one `Host` or an invalid
//! one, is answered 400 (the RFC's "MUST respond with a 400"). A request in
//! absolute form (`GET http://host/path`) names the host of its target:
//! §3.2.2 requires a server to accept the absolute form and to ignore
//! `Host` then, so that authority, not `Host`, is what is checked. An
//! HTTP/1.0 request without `Host` passes (HTTP/1.0 has no `Host`
//! requirement), and so does a request the router is called with directly
//! (tests with `oneshot`, not read from a connection).

use std::net::{IpAddr, SocketAddr};

use axum::extract::{Request, State};
use axum::http::header::HOST;
use axum::http::Version;
use axum::middleware::Next;
use axum::response::Response;

use super::error::ApiError;
use super::AppState;

/// The names and addresses requests may name in `Host` besides `localhost`
/// and loopback addresses.
#[derive(Clone, Debug, Default)]
pub struct AllowedHosts {
    /// The address the daemon listens on; `None` when it is not known.
    pub bound: Option<SocketAddr>,
    /// Host names of the allow-list, lower case, without a trailing dot.
    pub names: Vec<String>,
}

impl AllowedHosts {
    /// `bound` and the allow-list `names`, each checked by [`parse_allowed_host`].
    pub fn new(bound: SocketAddr, names: &[String]) -> Result<AllowedHosts, String> {
        Ok(AllowedHosts {
            bound: Some(bound),
            names: names.iter().map(|n| parse_allowed_host(n)).collect::<Result<_, _>>()?,
        })
    }

    /// The port the daemon listens on, when known.
    pub fn port(&self) -> Option<u16> {
        self.bound.map(|b| b.port())
    }

    /// True when a request naming `host` (a `Host` value: name or address,
    /// with or without a port) is answered.
    pub fn allows(&self, host: &str) -> bool {
        let name = host_name(host);
        if let Ok(ip) = name.trim_start_matches('[').trim_end_matches(']').parse::<IpAddr>() {
            return ip.is_loopback()
                || self.bound.is_some_and(|b| b.ip().is_unspecified() || b.ip() == ip)
                || self.names.contains(&ip.to_string());
        }
        let name = name.trim_end_matches('.').to_ascii_lowercase();
        name == "localhost" || name.ends_with(".localhost") || self.names.contains(&name)
    }

    /// What the daemon answers: for its start-up message and its 421s.
    pub fn describe(&self) -> String {
        let mut accepted = vec!["localhost".to_string(), "loopback addresses".to_string()];
        match self.bound {
            Some(b) if b.ip().is_unspecified() => accepted.push("any IP address".into()),
            Some(b) if !b.ip().is_loopback() => accepted.push(b.ip().to_string()),
            _ => {}
        }
        accepted.extend(self.names.iter().cloned());
        accepted.join(", ")
    }
}

/// The host of a `Host` value: `name`, `name:port`, `[v6]` or `[v6]:port`.
fn host_name(host: &str) -> &str {
    let host = host.trim();
    if host.starts_with('[') {
        return host.split_inclusive(']').next().unwrap_or(host);
    }
    match host.rsplit_once(':') {
        // One colon: `name:port`. More: a bare IPv6 address (not valid in Host, but not a name either).
        Some((name, _)) if !name.contains(':') => name,
        _ => host,
    }
}

/// One allow-list entry: a DNS name (letters, digits, `-`, `.`) or an IP
/// address, lower-cased; the error says what is wrong with it.
pub fn parse_allowed_host(entry: &str) -> Result<String, String> {
    let name = entry.trim().trim_end_matches('.').to_ascii_lowercase();
    let is_name = !name.is_empty()
        && name.len() <= 253
        && name
            .split('.')
            .all(|label| !label.is_empty() && label.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-'));
    let is_address = name
        .trim_start_matches('[')
        .trim_end_matches(']')
        .parse::<IpAddr>()
        .is_ok();
    if is_name || is_address {
        Ok(name.trim_start_matches('[').trim_end_matches(']').to_string())
    } else {
        Err(format!(
            "allowed host `{entry}`: not a host name (letters, digits, `-` and `.`, without a port) or an IP address"
        ))
    }
}

/// The host `req` names (see the module doc): its target's authority in
/// absolute form, else its one `Host`; `None` when it names none. A 400
/// citing RFC 9112 when it breaks §3.2's rules.
fn named_host(req: &Request) -> Result<Option<String>, ApiError> {
    let hosts: Vec<_> = req.headers().get_all(HOST).iter().collect();
    if hosts.len() > 1 {
        return Err(ApiError::BadRequest(format!(
            "the request has {} `Host` header fields; send exactly one (RFC 9112 §3.2: a server must answer 400 \
             to a request with more than one)",
            hosts.len()
        )));
    }
    let from_a_connection = req.extensions().get::<super::limits::ClientAddr>().is_some();
    if hosts.is_empty() && from_a_connection && req.version() == Version::HTTP_11 {
        return Err(ApiError::BadRequest(
            "the HTTP/1.1 request has no `Host` header field; send `Host: <the address you reach the daemon by>` \
             (RFC 9112 §3.2: a server must answer 400 to an HTTP/1.1 request lacking Host)"
                .into(),
        ));
    }
    if let Some(authority) = req.uri().authority() {
        // Absolute form (RFC 9112 §3.2.2): the target's authority is the host; `Host` is ignored.
        return Ok(Some(
            authority.as_str().rsplit('@').next().unwrap_or_default().to_string(),
        ));
    }
    match hosts.first() {
        None => Ok(None),
        Some(value) => {
            let valid = value
                .to_str()
                .ok()
                .filter(|v| !v.contains('@') && v.parse::<axum::http::uri::Authority>().is_ok());
            match valid {
                Some(v) => Ok(Some(v.to_string())),
                None => Err(ApiError::BadRequest(format!(
                    "the `Host` header field `{}` is not a host and optional port (RFC 9112 §3.2: a server must \
                     answer 400 to an invalid Host)",
                    String::from_utf8_lossy(value.as_bytes())
                ))),
            }
        }
    }
}

/// Middleware: refuses, with 421, a request naming a host this daemon does
/// not answer, and with 400 one that breaks RFC 9112 §3.2 (see the module doc).
pub async fn require_known_host(State(state): State<AppState>, req: Request, next: Next) -> Result<Response, ApiError> {
    let allowed = &state.config.allowed_hosts;
    if let Some(host) = named_host(&req)? {
        if !allowed.allows(&host) {
            tracing::warn!(%host, "request for a host this daemon does not answer (DNS rebinding?)");
            return Err(ApiError::MisdirectedRequest(format!(
                "this daemon does not answer for the host `{host}` (it answers {}): a page that made its own \
                 name point at this machine would otherwise read its data. Reach the daemon by one of those, \
                 or start it with `--allowed-host {}` (or `allowed_hosts` in lightbooth.toml)",
                allowed.describe(),
                host_name(&host)
            )));
        }
    }
    Ok(next.run(req).await)
}
