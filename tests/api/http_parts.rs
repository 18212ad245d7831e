//! The HTTP layer's own parts, without a server: the bearer token (its
//! file's mode, symbolic links, the scheme's case, exact comparison), the
//! `Host` allow-list against DNS rebinding, and the image probe's box
//! check. (They were the `lightbooth` library's unit tests; as integration
//! tests they spare the test build a second compilation of the library.)

use std::path::Path;

use lightbooth::http::auth::{bearer_token, load_token, token_matches, TokenSource};
use lightbooth::http::error::ApiError;
use lightbooth::http::hosts::{parse_allowed_host, AllowedHosts};
use lightbooth::lab::render::image_views::check_box;

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
    assert!(matches!(
        source,
        TokenSource::File {
            tightened_from: None,
            ..
        }
    ));
}

#[test]
fn the_bearer_scheme_is_case_insensitive() {
    for v in ["Bearer abc", "bearer abc", "BEARER abc", "Bearer\tabc", " Bearer  abc "] {
        assert_eq!(bearer_token(v), Some("abc"), "{v:?}");
    }
    for v in ["Basic abc", "Bearer", "Bearer ", "Bearerabc", ""] {
        assert_eq!(bearer_token(v), None, "{v:?}");
    }
}

/// Regression: an existing 0644 token file was rewritten and left 0644
/// while the daemon printed "readable only by you".
#[cfg(unix)]
#[test]
fn a_world_readable_token_file_is_made_private_and_said_so() {
    use std::os::unix::fs::PermissionsExt;
    if std::env::var("LIGHTBOOTH_TOKEN").is_ok() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    // A usable token in a 0644 file: kept, the file made 0600, and the message says what happened.
    let path = dir.path().join("token");
    std::fs::write(&path, "0123456789abcdef0123").unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
    let (t, source) = load_token(None, &path).unwrap();
    assert_eq!(t, "0123456789abcdef0123");
    assert_eq!(mode(&path), 0o600);
    assert!(
        matches!(
            source,
            TokenSource::File {
                tightened_from: Some(0o644),
                ..
            }
        ),
        "{source:?}"
    );
    let said = source.describe();
    assert!(
        said.contains("0644") && said.contains("now 0600") && !said.contains("only by you"),
        "{said}"
    );
    // The same for an explicit --token-file.
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640)).unwrap();
    let (_, source) = load_token(Some(&path), &dir.path().join("unused")).unwrap();
    assert!(
        matches!(
            source,
            TokenSource::File {
                tightened_from: Some(0o640),
                ..
            }
        ),
        "{source:?}"
    );
    assert_eq!(mode(&path), 0o600);
    // A 0644 file without a usable token is replaced by a new 0600 file.
    let short = dir.path().join("short");
    std::fs::write(&short, "abc").unwrap();
    std::fs::set_permissions(&short, std::fs::Permissions::from_mode(0o644)).unwrap();
    let (t, source) = load_token(None, &short).unwrap();
    assert_eq!(t.len(), 64);
    assert!(matches!(source, TokenSource::Generated(_)));
    assert!(source.describe().contains("0600"));
    assert_eq!(mode(&short), 0o600);
    assert_eq!(std::fs::read_to_string(&short).unwrap(), t);
}

/// Regression: token files behind symbolic links were followed (read, and
/// rewritten through the link).
#[cfg(unix)]
#[test]
fn a_symlinked_token_file_is_refused_and_its_target_untouched() {
    use std::os::unix::fs::PermissionsExt;
    if std::env::var("LIGHTBOOTH_TOKEN").is_ok() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("elsewhere");
    std::fs::write(&target, "x").unwrap();
    std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o644)).unwrap();
    let link = dir.path().join("token");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    for explicit in [false, true] {
        let e = if explicit {
            load_token(Some(&link), &dir.path().join("unused")).unwrap_err()
        } else {
            load_token(None, &link).unwrap_err()
        };
        assert!(e.to_string().contains("symbolic link"), "{e}");
    }
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "x");
    assert_eq!(std::fs::metadata(&target).unwrap().permissions().mode() & 0o777, 0o644);
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
}

#[test]
fn loopback_names_and_addresses_pass_and_other_names_do_not() {
    let loopback = AllowedHosts::new("127.0.0.1:8650".parse().unwrap(), &["Booth1.Lab.example.".into()]).unwrap();
    for ok in [
        "localhost",
        "localhost:8650",
        "LOCALHOST.",
        "app.localhost:1",
        "127.0.0.1:8650",
        "127.1.2.3",
        "[::1]:8650",
        "[::1]",
        "booth1.lab.example:8650",
    ] {
        assert!(loopback.allows(ok), "{ok}");
    }
    for refused in [
        "attacker.example",
        "attacker.example:8650",
        "localhost.attacker.example",
        "10.0.0.5:8650",
        "[fe80::1]:8650",
        "",
        "127.0.0.1.attacker.example",
    ] {
        assert!(!loopback.allows(refused), "{refused}");
    }
    let everywhere = AllowedHosts::new("0.0.0.0:8650".parse().unwrap(), &[]).unwrap();
    assert!(everywhere.allows("10.0.0.5:8650") && !everywhere.allows("booth1:8650"));
    let one = AllowedHosts::new("10.0.0.5:8650".parse().unwrap(), &[]).unwrap();
    assert!(one.allows("10.0.0.5:8650") && !one.allows("10.0.0.6:8650"));
}

#[test]
fn allow_list_entries_are_names_or_addresses() {
    assert_eq!(parse_allowed_host(" Booth1.LAB. ").unwrap(), "booth1.lab");
    assert_eq!(parse_allowed_host("[::1]").unwrap(), "::1");
    for bad in ["", "booth:8650", "a b", "http://booth", "a..b"] {
        let e = parse_allowed_host(bad).unwrap_err();
        assert!(e.contains(bad) && e.contains("host name"), "{e}");
    }
}

/// Regression: `?x=1&y=0&w=4294967295` wrapped in u32 and was answered
/// 200 with nulls.
#[test]
fn pixel_box_width_that_wraps_u32_is_refused_naming_w() {
    for (x, y, w, h, field) in [
        (1, 0, u32::MAX, 1, "`w`"),
        (0, 1, 1, u32::MAX, "`h`"),
        (2, 0, u32::MAX - 1, 1, "`w`"),
        (0, 0, 0, 1, "`w`"),
        (u32::MAX, 0, 1, 1, "`x`"),
        (0, 40, 1, 1, "`y`"),
    ] {
        let e = ApiError::from(check_box(x, y, w, h, 64, 40).unwrap_err());
        assert!(matches!(e, ApiError::BadRequest(_)), "{e}");
        assert!(e.to_string().contains(field), "{x},{y},{w},{h}: {e}");
    }
    assert!(check_box(0, 0, 64, 40, 64, 40).is_ok());
    assert!(check_box(63, 39, 1, 1, 64, 40).is_ok());
}
