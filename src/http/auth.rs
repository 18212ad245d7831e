//! Bearer-token authorisation for requests that move hardware or write data.
//!
//! The token comes from `--token-file PATH` or the `LIGHTBOOTH_TOKEN`
//! environment variable; without either, one is generated on first start
//! into `lightbooth.token`, and its path is printed. Reading needs no token
//! while the daemon listens on loopback only. Tokens are compared in
//! constant time.
//!
//! Token files are kept private: a token file that is a symbolic link is
//! refused (the daemon would otherwise read, chmod or replace whatever it
//! points to); one that group or others may read is tightened to mode 0600
//! and the operator is told the token may have been copied; a generated
//! token is written to a new file created with mode 0600 and renamed into
//! place, never through an existing file. What is printed is what was found
//! and done.
//!
//! The scheme of `Authorization: Bearer <token>` is case-insensitive (RFC 7235 §2.1).
//!
//! The dashboard, bound off loopback, must authorise its reads too. Its
//! `fetch` calls send the header, but `<img>` charts, download links and
//! `EventSource` (the event stream) cannot set headers. So the dashboard
//! asks, with the write token in the header, `POST /api/read-cookie` for a
//! **read-only** credential: the daemon answers with the cookie
//! [`read_cookie_name`] (`lightbooth_read_<port>`; `HttpOnly`,
//! `SameSite=Strict`, `Path=/api`) holding [`read_token`], a token derived
//! from the write token and a secret drawn afresh for each run of the
//! daemon. That cookie is accepted for **reads only** (GET, HEAD), and the
//! write token is never accepted from a cookie. Why: cookies are not bound
//! to a port, so every other web service on the same host under `/api` (a
//! notebook server, say) receives them; what it receives can read this
//! daemon's data until the daemon restarts, and can neither write nor be
//! turned into the write token (a SHA-256 preimage). Naming the cookie
//! after the port keeps two daemons on one host from overwriting each
//! other's. A page of another site cannot make the browser send the cookie
//! (`SameSite=Strict`), and could not read the answer anyway (no CORS
//! headers are sent); writes need the header, which only script that knows
//! the token can set, so the cookie opens no cross-site request forgery. A
//! token in the query string is not accepted: it would be copied into
//! server and proxy logs, the browser history and `Referer` headers. Off
//! loopback the token crosses the network in clear over plain HTTP, header
//! or cookie alike: put the daemon behind TLS (a reverse proxy or an SSH
//! tunnel) when the network is not trusted.

use std::io::Write;
use std::path::{Path, PathBuf};

use std::sync::OnceLock;

use axum::extract::{Request, State};
use axum::http::{header::AUTHORIZATION, header::COOKIE, HeaderMap, Method};
use axum::middleware::Next;
use axum::response::Response;
use sha2::{Digest, Sha256};
use subtle::ConstantTimeEq;

use super::error::ApiError;
use super::AppState;

/// The read-only cookie of the daemon listening on `port` (see the module doc).
pub fn read_cookie_name(port: Option<u16>) -> String {
    match port {
        Some(port) => format!("lightbooth_read_{port}"),
        None => "lightbooth_read".into(),
    }
}

/// The read-only token of this run of the daemon for `write_token`: SHA-256
/// of a secret drawn at the first call of the process and the write token,
/// as hex. It authorises reads from a cookie, never a write.
pub fn read_token(write_token: &str) -> String {
    static RUN_SECRET: OnceLock<[u8; 32]> = OnceLock::new();
    let secret = RUN_SECRET.get_or_init(|| {
        let mut bytes = [0u8; 32];
        if let Err(e) =
            std::fs::File::open("/dev/urandom").and_then(|mut f| std::io::Read::read_exact(&mut f, &mut bytes))
        {
            // Still unguessable from outside the process, if weaker.
            tracing::warn!(error = %e, "cannot read /dev/urandom; the read token's secret comes from the clock");
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_nanos())
                .unwrap_or(0);
            bytes = Sha256::digest(format!("{nanos}/{}", std::process::id())).into();
        }
        bytes
    });
    let mut hash = Sha256::new();
    hash.update(b"lightbooth read token\0");
    hash.update(secret);
    hash.update(write_token.as_bytes());
    hash.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// Where the token came from, to tell the operator.
#[derive(Clone, Debug)]
pub enum TokenSource {
    Environment,
    /// An existing file. `tightened_from` is its mode when it was readable by
    /// group or others and has been set to 0600.
    File {
        path: PathBuf,
        tightened_from: Option<u32>,
    },
    /// A new token written to a new file with mode 0600.
    Generated(PathBuf),
}

impl TokenSource {
    /// What the daemon prints about its token at start-up.
    pub fn describe(&self) -> String {
        match self {
            TokenSource::Environment => "write token from LIGHTBOOTH_TOKEN".into(),
            TokenSource::Generated(p) => format!(
                "generated a write token in {} (mode 0600: readable only by you)",
                p.display()
            ),
            TokenSource::File {
                path,
                tightened_from: None,
            } => format!("write token from {} (mode 0600: readable only by you)", path.display()),
            TokenSource::File {
                path,
                tightened_from: Some(mode),
            } => format!(
                "write token from {p}: the file was mode {mode:04o}, readable by other users, and is now 0600. \
                 Others may have copied the token: delete {p} and restart to generate a new one (or write a new \
                 token into it)",
                p = path.display()
            ),
        }
    }
}

/// Loads the token: `LIGHTBOOTH_TOKEN`, else `token_file` if given (must
/// exist), else `default_file` (generated if missing or too short).
pub fn load_token(token_file: Option<&Path>, default_file: &Path) -> anyhow::Result<(String, TokenSource)> {
    if let Ok(t) = std::env::var("LIGHTBOOTH_TOKEN") {
        let t = t.trim().to_string();
        anyhow::ensure!(
            t.len() >= 16,
            "LIGHTBOOTH_TOKEN is too short: use at least 16 characters"
        );
        return Ok((t, TokenSource::Environment));
    }
    if let Some(path) = token_file {
        let (t, tightened_from) = read_private(path)?
            .ok_or_else(|| anyhow::anyhow!("cannot read the token file {}: not found", path.display()))?;
        anyhow::ensure!(
            t.len() >= 16,
            "the token in {} is too short: use at least 16 characters",
            path.display()
        );
        return Ok((
            t,
            TokenSource::File {
                path: path.to_path_buf(),
                tightened_from,
            },
        ));
    }
    if let Some((t, tightened_from)) = read_private(default_file)? {
        if t.len() >= 16 {
            return Ok((
                t,
                TokenSource::File {
                    path: default_file.to_path_buf(),
                    tightened_from,
                },
            ));
        }
        tracing::warn!(path = %default_file.display(), "the token file holds no usable token; generating a new one");
    }
    let token = generate_token()?;
    write_private(default_file, &token)?;
    Ok((token, TokenSource::Generated(default_file.to_path_buf())))
}

/// Reads a token file that must be a regular file, not a symbolic link,
/// and makes it private (0600) if group or others could read or write it.
/// Returns the trimmed text and the mode it had if it was tightened; `None`
/// if the file does not exist.
fn read_private(path: &Path) -> anyhow::Result<Option<(String, Option<u32>)>> {
    let link = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => anyhow::bail!("cannot read the token file {}: {e}", path.display()),
    };
    anyhow::ensure!(
        !link.file_type().is_symlink(),
        "the token file {} is a symbolic link: lightbooth does not follow links for its token (it would read and \
         chmod whatever the link points to). Use the real file's path, or replace the link with the file",
        path.display()
    );
    anyhow::ensure!(
        link.is_file(),
        "the token file {} is not a regular file",
        path.display()
    );
    let mut file =
        std::fs::File::open(path).map_err(|e| anyhow::anyhow!("cannot read the token file {}: {e}", path.display()))?;
    let mut tightened_from = None;
    #[cfg(unix)]
    {
        use std::os::unix::fs::{MetadataExt, PermissionsExt};
        let opened = file.metadata()?;
        // The path was not swapped for something else between the check and the open.
        anyhow::ensure!(
            opened.dev() == link.dev() && opened.ino() == link.ino(),
            "the token file {} changed while it was being opened",
            path.display()
        );
        let mode = opened.mode() & 0o7777;
        if mode & 0o077 != 0 {
            // fchmod on the open file: nothing else is touched.
            file.set_permissions(std::fs::Permissions::from_mode(0o600))
                .map_err(|e| {
                    anyhow::anyhow!(
                        "the token file {} is mode {mode:04o}, readable by other users, and cannot be made private \
                     ({e}): chmod 600 it, or use a file you own",
                        path.display()
                    )
                })?;
            tracing::warn!(path = %path.display(), was = format!("{mode:04o}"), "token file made private (0600)");
            tightened_from = Some(mode);
        }
    }
    let mut text = String::new();
    std::io::Read::read_to_string(&mut file, &mut text)
        .map_err(|e| anyhow::anyhow!("cannot read the token file {}: {e}", path.display()))?;
    Ok(Some((text.trim().to_string(), tightened_from)))
}

/// 32 random bytes from the operating system, as hex.
fn generate_token() -> anyhow::Result<String> {
    let mut bytes = [0u8; 32];
    let mut f = std::fs::File::open("/dev/urandom")?;
    std::io::Read::read_exact(&mut f, &mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Writes `text` to `path` as a new file only its owner can read: created
/// (never opened through an existing file or link) next to `path` with mode
/// 0600, then renamed over it, which replaces a link rather than following it.
fn write_private(path: &Path, text: &str) -> anyhow::Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("token");
    let temp = dir.join(format!(".{name}.{}.new", std::process::id()));
    let mut options = std::fs::OpenOptions::new();
    options.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.mode(0o600);
    }
    let written = options.open(&temp).and_then(|mut f| {
        f.write_all(text.as_bytes())?;
        f.sync_all()
    });
    let result = written.and_then(|()| std::fs::rename(&temp, path));
    if let Err(e) = result {
        let _ = std::fs::remove_file(&temp);
        anyhow::bail!("cannot write the token to {}: {e}", path.display());
    }
    Ok(())
}

/// True when `presented` equals `expected`, in time independent of where they differ.
pub fn token_matches(presented: &str, expected: &str) -> bool {
    presented.len() == expected.len() && bool::from(presented.as_bytes().ct_eq(expected.as_bytes()))
}

/// The token of an `Authorization` value with the `Bearer` scheme, in any case.
pub fn bearer_token(value: &str) -> Option<&str> {
    let (scheme, token) = value.trim().split_once([' ', '\t'])?;
    let token = token.trim();
    (scheme.eq_ignore_ascii_case("bearer") && !token.is_empty()).then_some(token)
}

/// The value of cookie `name`, if the request has it.
fn cookie<'a>(headers: &'a HeaderMap, name: &str) -> Option<&'a str> {
    headers
        .get_all(COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .find_map(|pair| pair.trim().strip_prefix(name)?.strip_prefix('='))
}

/// Middleware: writes need the write token in the `Authorization` header;
/// reads need it unless bound to loopback, in the header, or the read
/// token in the dashboard's read-only cookie.
pub async fn require_token(State(state): State<AppState>, req: Request, next: Next) -> Result<Response, ApiError> {
    let is_read = matches!(*req.method(), Method::GET | Method::HEAD | Method::OPTIONS);
    if is_read && state.config.loopback_only {
        return Ok(next.run(req).await);
    }
    let headers = req.headers();
    let authorised = match headers.get(AUTHORIZATION) {
        Some(v) => v
            .to_str()
            .ok()
            .and_then(bearer_token)
            .map(|t| token_matches(t, &state.config.token)),
        None if is_read => cookie(headers, &read_cookie_name(state.config.allowed_hosts.port()))
            .map(|t| token_matches(t, &read_token(&state.config.token))),
        None => None,
    };
    match authorised {
        None => Err(ApiError::Unauthorized(
            "this request needs the daemon's token: send `Authorization: Bearer <token>` (the token file's path \
             is printed when the daemon starts)"
                .into(),
        )),
        Some(true) => Ok(next.run(req).await),
        Some(false) => Err(ApiError::Unauthorized("wrong token".into())),
    }
}
