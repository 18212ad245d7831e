//! Bearer-token authorisation for requests that move hardware or write data.
//!
//! The token comes from `--token-file PATH` or the `LIGHTBOOTH_TOKEN`
//! environment variable; without either, one is generated on first start
//! into a file readable only by its owner (mode 0600), and its path is
//! printed. Reading needs no token while the daemon listens on loopback
//! only. Tokens are compared in constant time.

use std::io::Write;
use std::path::{Path, PathBuf};

use axum::extract::{Request, State};
use axum::http::{header::AUTHORIZATION, Method};
use axum::middleware::Next;
use axum::response::Response;
use subtle::ConstantTimeEq;

use super::error::ApiError;
use super::AppState;

/// Where the token came from, to tell the operator.
#[derive(Clone, Debug)]
pub enum TokenSource {
    Environment,
    File(PathBuf),
    Generated(PathBuf),
}

/// Loads the token: `LIGHTBOOTH_TOKEN`, else `token_file` if given (must
/// exist), else `default_file` (generated if missing).
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
        let t = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("cannot read the token file {}: {e}", path.display()))?;
        let t = t.trim().to_string();
        anyhow::ensure!(
            t.len() >= 16,
            "the token in {} is too short: use at least 16 characters",
            path.display()
        );
        return Ok((t, TokenSource::File(path.to_path_buf())));
    }
    if let Ok(t) = std::fs::read_to_string(default_file) {
        let t = t.trim().to_string();
        if t.len() >= 16 {
            return Ok((t, TokenSource::File(default_file.to_path_buf())));
        }
    }
    let token = generate_token()?;
    write_private(default_file, &token)?;
    Ok((token, TokenSource::Generated(default_file.to_path_buf())))
}

/// 32 random bytes from the operating system, as hex.
fn generate_token() -> anyhow::Result<String> {
    let mut bytes = [0u8; 32];
    let mut f = std::fs::File::open("/dev/urandom")?;
    std::io::Read::read_exact(&mut f, &mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Writes `text` to a new file only its owner can read.
fn write_private(path: &Path, text: &str) -> anyhow::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let mut options = std::fs::OpenOptions::new();
    options.write(true).create(true).truncate(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.mode(0o600);
    }
    let mut f = options
        .open(path)
        .map_err(|e| anyhow::anyhow!("cannot write the token to {}: {e}", path.display()))?;
    f.write_all(text.as_bytes())?;
    Ok(())
}

/// True when `presented` equals `expected`, in time independent of where they differ.
pub fn token_matches(presented: &str, expected: &str) -> bool {
    presented.len() == expected.len() && bool::from(presented.as_bytes().ct_eq(expected.as_bytes()))
}

/// Middleware: writes need the token; reads need it unless bound to loopback.
pub async fn require_token(State(state): State<AppState>, req: Request, next: Next) -> Result<Response, ApiError> {
    let is_read = matches!(*req.method(), Method::GET | Method::HEAD | Method::OPTIONS);
    if is_read && state.config.loopback_only {
        return Ok(next.run(req).await);
    }
    let presented = req
        .headers()
        .get(AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer ").or_else(|| v.strip_prefix("bearer ")))
        .map(str::trim);
    match presented {
        None => Err(ApiError::Unauthorized(
            "this request needs the daemon's token: send `Authorization: Bearer <token>` (the token file's path \
             is printed when the daemon starts)"
                .into(),
        )),
        Some(t) if token_matches(t, &state.config.token) => Ok(next.run(req).await),
        Some(_) => Err(ApiError::Unauthorized("wrong token".into())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_compare_exactly() {
        assert!(token_matches("abcdefabcdefabcdef", "abcdefabcdefabcdef"));
        assert!(!token_matches("abcdefabcdefabcdeX", "abcdefabcdefabcdef"));
        assert!(!token_matches("abc", "abcdefabcdefabcdef"));
    }

    #[cfg(unix)]
    #[test]
    fn a_generated_token_file_is_private() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/token");
        // Only when the environment does not set a token.
        if std::env::var("LIGHTBOOTH_TOKEN").is_ok() {
            return;
        }
        let (t, source) = load_token(None, &path).unwrap();
        assert!(matches!(source, TokenSource::Generated(_)));
        assert_eq!(t.len(), 64);
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        // Second start reuses it.
        let (again, source) = load_token(None, &path).unwrap();
        assert_eq!(again, t);
        assert!(matches!(source, TokenSource::File(_)));
    }
}
