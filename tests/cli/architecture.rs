//! The layer rule of `src/lib.rs`, checked: every `crate::<module>` path in
//! a file under `src/` (outside comments and strings) names a module on the
//! file's own level or below, as the table in `lib.rs`'s documentation
//! says; every module `lib.rs` declares is in the table and in its map.
//! A failure names the file, the line and the forbidden edge.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn src() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// The `| level | modules |` table of `lib.rs`'s doc comment.
fn levels(lib: &str) -> BTreeMap<String, u32> {
    let mut levels = BTreeMap::new();
    for line in lib.lines() {
        let Some(row) = line.strip_prefix("//! | ") else {
            continue;
        };
        let cells: Vec<&str> = row.trim_end_matches('|').split('|').map(str::trim).collect();
        let [level, modules] = cells[..] else { continue };
        let Ok(level) = level.parse::<u32>() else { continue };
        for module in modules.split(',') {
            levels.insert(module.trim().to_string(), level);
        }
    }
    levels
}

/// `text` without comments, string literals and char literals, line
/// structure kept (so line numbers still count).
fn code_only(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            while i < b.len() && !b[i..].starts_with(b"*/") {
                if b[i] == b'\n' {
                    out.push('\n');
                }
                i += 1;
            }
            i += 2;
        } else if b[i] == b'"' || (b[i] == b'r' && (b[i..].starts_with(b"r\"") || b[i..].starts_with(b"r#"))) {
            // a string, raw or not: skip to its end, keeping newlines
            let (mut hashes, raw) = if b[i] == b'r' {
                i += 1;
                let mut h = 0;
                while b[i] == b'#' {
                    h += 1;
                    i += 1;
                }
                (h, true)
            } else {
                (0, false)
            };
            if i >= b.len() || b[i] != b'"' {
                continue; // `r#ident`, not a string
            }
            i += 1;
            while i < b.len() {
                if !raw && b[i] == b'\\' {
                    i += 2;
                    continue;
                }
                if b[i] == b'\n' {
                    out.push('\n');
                }
                if b[i] == b'"' && b[i + 1..].iter().take(hashes).filter(|&&c| c == b'#').count() == hashes {
                    i += 1 + hashes;
                    hashes = 0;
                    break;
                }
                i += 1;
            }
            let _ = hashes;
        } else if b[i] == b'\'' && i + 2 < b.len() && (b[i + 2] == b'\'' || b[i + 1] == b'\\') {
            // a char literal ('x', '\n', '\''), not a lifetime
            i += if b[i + 1] == b'\\' { 4 } else { 3 };
            while i < b.len() && b[i - 1] != b'\'' {
                i += 1;
            }
        } else {
            out.push(b[i] as char);
            i += 1;
        }
    }
    out
}

/// Every `crate::name` in `code`, with its line number (1-based).
fn crate_paths(code: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (n, line) in code.lines().enumerate() {
        let mut rest = line;
        while let Some(at) = rest.find("crate::") {
            let before = rest[..at].chars().last();
            let tail = &rest[at + "crate::".len()..];
            let name: String = tail
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            // `lightbooth_crate::x` or `$crate::` are not ours
            if !before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_' || c == '$') && !name.is_empty() {
                found.push((n + 1, name));
            }
            rest = tail;
        }
    }
    found
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The forbidden edges under `src/`, as `file:line: a (level) uses b (level)`.
fn violations(src: &Path, levels: &BTreeMap<String, u32>) -> Vec<String> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    let mut bad = Vec::new();
    for file in files {
        let rel = file.strip_prefix(src).unwrap();
        let top = rel.components().next().unwrap().as_os_str().to_string_lossy();
        let top = top.trim_end_matches(".rs").to_string();
        if top == "lib" || top == "main" || top == "cli" {
            continue; // the crate root and the binary stand above every level
        }
        let Some(&from) = levels.get(&top) else {
            bad.push(format!(
                "src/{}: module `{top}` is in no level of lib.rs's table",
                rel.display()
            ));
            continue;
        };
        let text = std::fs::read_to_string(&file).unwrap();
        for (line, to) in crate_paths(&code_only(&text)) {
            if to == top {
                continue;
            }
            match levels.get(&to) {
                Some(&level) if level > from => bad.push(format!(
                    "src/{}:{line}: `{top}` (level {from}) uses `crate::{to}` (level {level}), a layer above it",
                    rel.display()
                )),
                _ => {}
            }
        }
    }
    bad
}

#[test]
fn every_module_is_in_the_layer_table_and_the_map() {
    let lib = std::fs::read_to_string(src().join("lib.rs")).unwrap();
    let levels = levels(&lib);
    assert!(levels.len() >= 10, "lib.rs has no layer table: {levels:?}");
    for line in lib.lines() {
        if let Some(module) = line.strip_prefix("pub mod ").and_then(|m| m.strip_suffix(';')) {
            assert!(
                levels.contains_key(module),
                "lib.rs declares `{module}` but its layer table gives it no level"
            );
            assert!(
                lib.contains(&format!("[`{module}`]")),
                "lib.rs declares `{module}` but its map (\"Where things live\") does not link it"
            );
        }
    }
}

#[test]
fn no_module_uses_one_above_it() {
    let lib = std::fs::read_to_string(src().join("lib.rs")).unwrap();
    let bad = violations(&src(), &levels(&lib));
    assert!(
        bad.is_empty(),
        "the layer rule of src/lib.rs is broken ({} edges):\n{}",
        bad.len(),
        bad.join("\n")
    );
}

/// The check itself: a planted forbidden import (the colour science using
/// the HTTP layer) is found and named, one in a comment or a string is not.
#[test]
fn a_planted_forbidden_import_is_named_with_its_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::create_dir_all(src.join("colorimetry")).unwrap();
    std::fs::write(
        src.join("colorimetry/mod.rs"),
        "//! uses crate::http in a comment only\nuse crate::spectrum::Spectrum;\nconst S: &str = \"crate::store\";\nuse crate::http::error::ApiError;\n",
    )
    .unwrap();
    let levels: BTreeMap<String, u32> = [("colorimetry", 0), ("spectrum", 0), ("store", 2), ("http", 4)]
        .into_iter()
        .map(|(m, l)| (m.to_string(), l))
        .collect();
    let bad = violations(src, &levels);
    assert_eq!(
        bad,
        vec![
            "src/colorimetry/mod.rs:4: `colorimetry` (level 0) uses `crate::http` (level 4), a layer above it"
                .to_string()
        ]
    );
}
