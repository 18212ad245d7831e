//! The layer rule of `src/lib.rs`, checked where Cargo cannot: the crates
//! of the workspace are layers, and Cargo refuses an edge from a crate to
//! one above it (the science crate, `crates/science`, cannot name the app);
//! inside the `lightbooth` crate, every `crate::<module>` path in a file
//! under `src/` (outside comments and strings) names a module on the
//! file's own level or below, as the table in `lib.rs`'s documentation
//! says; every module `lib.rs` declares is in the table and in its map.
//! A failure names the file, the line and the forbidden edge.
//!
//! And no two files of a crate import each other, directly or round a circle: every
//! `use` and path (`crate::`, `super::`, `self::`, a child module) of a
//! file's non-test code is resolved to the file that defines it, and the
//! graph must have no cycle. A module's root file (`mod.rs`) may use its
//! own submodules (it declares and re-exports them; they use what it
//! defines): that edge is not counted.

use std::collections::{BTreeMap, BTreeSet};
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
                    if b.get(i + 1) == Some(&b'\n') {
                        out.push('\n'); // a line continuation
                    }
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

// --- file-level import cycles -------------------------------------------

/// A file's module path: `render/scene/mod.rs` → `["render", "scene"]`.
fn module_of(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel.iter().map(|c| c.to_string_lossy().into_owned()).collect();
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs");
    if !matches!(stem, "mod" | "lib" | "main") {
        parts.push(stem.to_string());
    }
    parts
}

/// `code` up to its first inline test module (`#[cfg(test)] mod name {`):
/// the code a build without tests compiles (test modules stand at the end
/// of their file).
fn without_tests(code: &str) -> &str {
    let mut from = 0;
    while let Some(i) = code[from..].find("#[cfg(test)]") {
        let at = from + i;
        let item = code[at + "#[cfg(test)]".len()..].trim_start();
        if let Some(rest) = item.strip_prefix("mod ") {
            let name_end = rest
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(rest.len());
            if rest[name_end..].trim_start().starts_with('{') {
                return &code[..at];
            }
        }
        from = at + 1;
    }
    code
}

/// The tokens of a `use` tree: identifiers, `::`, braces, commas, `*`.
fn use_tokens(tree: &str) -> Vec<String> {
    let mut tokens = Vec::new();
    let mut chars = tree.chars().peekable();
    while let Some(c) = chars.next() {
        if c.is_alphanumeric() || c == '_' {
            let mut ident = c.to_string();
            while let Some(&n) = chars.peek() {
                if n.is_alphanumeric() || n == '_' {
                    ident.push(n);
                    chars.next();
                } else {
                    break;
                }
            }
            tokens.push(ident);
        } else if c == ':' && chars.peek() == Some(&':') {
            chars.next();
            tokens.push("::".into());
        } else if matches!(c, '{' | '}' | ',' | '*') {
            tokens.push(c.to_string());
        }
    }
    tokens
}

/// The paths a `use` tree names: `a::{b::C, d as e}` → `a::b::C`, `a::d`.
fn expand_use(tokens: &[String], at: &mut usize, prefix: &[String], out: &mut Vec<Vec<String>>) {
    let mut path = prefix.to_vec();
    while *at < tokens.len() {
        match tokens[*at].as_str() {
            "::" => *at += 1,
            "{" => {
                *at += 1;
                while *at < tokens.len() && tokens[*at] != "}" {
                    expand_use(tokens, at, &path, out);
                    if *at < tokens.len() && tokens[*at] == "," {
                        *at += 1;
                    }
                }
                *at += 1; // the `}`
                return;
            }
            "}" | "," => break,
            "as" => *at += 2, // `as name`: the path is what precedes
            "*" => *at += 1,
            ident => {
                path.push(ident.to_string());
                *at += 1;
            }
        }
    }
    out.push(path);
}

/// Every path `code` names, with its line: the `use` trees expanded, and
/// each `crate::…`, `super::…`, `self::…` path elsewhere.
fn named_paths(code: &str) -> Vec<(usize, Vec<String>)> {
    let mut found = Vec::new();
    let line_of = |at: usize| code[..at].matches('\n').count() + 1;
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut from = 0;
    while let Some(i) = code[from..].find("use ") {
        let at = from + i;
        from = at + 4;
        if code[..at].chars().last().is_some_and(|c| ident(c) || c == ':') {
            continue;
        }
        let Some(end) = code[at..].find(';') else { break };
        let tokens = use_tokens(&code[at + 4..at + end]);
        let mut paths = Vec::new();
        expand_use(&tokens, &mut 0, &[], &mut paths);
        found.extend(paths.into_iter().map(|p| (line_of(at), p)));
    }
    for root in ["crate::", "super::", "self::"] {
        let mut from = 0;
        while let Some(i) = code[from..].find(root) {
            let at = from + i;
            from = at + root.len();
            if code[..at]
                .chars()
                .last()
                .is_some_and(|c| ident(c) || c == ':' || c == '$')
            {
                continue;
            }
            let mut path = vec![root.trim_end_matches("::").to_string()];
            let mut rest = &code[at + root.len()..];
            loop {
                let name: String = rest.chars().take_while(|&c| ident(c)).collect();
                if name.is_empty() {
                    break;
                }
                rest = &rest[name.len()..];
                path.push(name);
                match rest.strip_prefix("::") {
                    Some(r) => rest = r,
                    None => break,
                }
            }
            found.push((line_of(at), path));
        }
    }
    found
}

/// The file a path named in the file of module `me` resolves to: the
/// longest prefix of it that is a module with a file; `None` for other
/// crates' paths.
fn resolve(me: &[String], path: &[String], files: &BTreeMap<Vec<String>, PathBuf>) -> Option<PathBuf> {
    let (mut module, mut rest) = match path.first()?.as_str() {
        "crate" => (Vec::new(), &path[1..]),
        "self" => (me.to_vec(), &path[1..]),
        "super" => {
            let mut m = me.to_vec();
            let mut r = path;
            while r.first().is_some_and(|s| s == "super") {
                m.pop();
                r = &r[1..];
            }
            (m, r)
        }
        first => {
            // A child module of this one, else another crate's path.
            let mut child = me.to_vec();
            child.push(first.to_string());
            if !files.contains_key(&child) {
                return None;
            }
            (me.to_vec(), path)
        }
    };
    let mut best = files.get(&module).cloned();
    while let Some((head, tail)) = rest.split_first() {
        module.push(head.clone());
        rest = tail;
        if let Some(f) = files.get(&module) {
            best = Some(f.clone());
        }
    }
    best
}

/// The import graph of the library's files under `src` (not the binary's
/// `main.rs` and `cli/`, nor test-only files): for each file, the files
/// it uses and the first line that does.
fn import_graph(src: &Path) -> BTreeMap<PathBuf, BTreeMap<PathBuf, usize>> {
    let mut all = Vec::new();
    rust_files(src, &mut all);
    let rels: Vec<PathBuf> = all
        .iter()
        .map(|f| f.strip_prefix(src).unwrap().to_path_buf())
        .filter(|r| !r.starts_with("cli") && r != Path::new("main.rs"))
        .collect();
    let files: BTreeMap<Vec<String>, PathBuf> = rels.iter().map(|r| (module_of(r), r.clone())).collect();
    let codes: BTreeMap<PathBuf, String> = rels
        .iter()
        .map(|r| (r.clone(), code_only(&std::fs::read_to_string(src.join(r)).unwrap())))
        .collect();
    // Files only tests compile: `#[cfg(test)] mod name;` in their parent.
    let mut test_only = BTreeSet::new();
    for (rel, code) in &codes {
        for (i, _) in code.match_indices("#[cfg(test)]") {
            let item = code[i + "#[cfg(test)]".len()..].trim_start();
            let item = item
                .strip_prefix("pub(crate) ")
                .or(item.strip_prefix("pub "))
                .unwrap_or(item);
            if let Some(name) = item.strip_prefix("mod ").and_then(|m| m.split(';').next()) {
                if !name.contains('{') {
                    let mut m = module_of(rel);
                    m.push(name.trim().to_string());
                    if let Some(f) = files.get(&m) {
                        test_only.insert(f.clone());
                    }
                }
            }
        }
    }
    let mut graph = BTreeMap::new();
    for (rel, code) in &codes {
        if test_only.contains(rel) {
            continue;
        }
        let me = module_of(rel);
        let root_dir = rel.file_name().is_some_and(|n| n == "mod.rs" || n == "lib.rs");
        let mut uses: BTreeMap<PathBuf, usize> = BTreeMap::new();
        for (line, path) in named_paths(without_tests(code)) {
            let Some(to) = resolve(&me, &path, &files) else {
                continue;
            };
            let own_submodule = root_dir && to.parent().is_some_and(|d| d.starts_with(rel.parent().unwrap()));
            if to != *rel && !own_submodule && !test_only.contains(&to) {
                uses.entry(to).or_insert(line);
            }
        }
        graph.insert(rel.clone(), uses);
    }
    graph
}

/// Import cycles of `graph`, as `a.rs:12 → b.rs:7 → a.rs` (the line of
/// each file that uses the next): the shortest through each file not named
/// in an earlier one.
fn cycles(graph: &BTreeMap<PathBuf, BTreeMap<PathBuf, usize>>) -> Vec<String> {
    let mut reported: BTreeSet<PathBuf> = BTreeSet::new();
    let mut found = Vec::new();
    for start in graph.keys() {
        if reported.contains(start) {
            continue;
        }
        // The shortest way back to `start`, breadth first.
        let mut previous: BTreeMap<&PathBuf, &PathBuf> = BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([start]);
        let mut closing = None;
        while let Some(file) = queue.pop_front() {
            for next in graph[file].keys() {
                if next == start {
                    closing = Some(file);
                    break;
                }
                if graph.contains_key(next) && !previous.contains_key(next) {
                    previous.insert(next, file);
                    queue.push_back(next);
                }
            }
            if closing.is_some() {
                break;
            }
        }
        let Some(mut file) = closing else { continue };
        let mut circle = vec![file];
        while file != start {
            file = previous[file];
            circle.push(file);
        }
        circle.reverse();
        let mut text = String::new();
        for (i, f) in circle.iter().enumerate() {
            let next = circle.get(i + 1).copied().unwrap_or(start);
            text.push_str(&format!("src/{}:{} → ", f.display(), graph[*f][next]));
            reported.insert((*f).clone());
        }
        text.push_str(&format!("src/{}", start.display()));
        found.push(text);
    }
    found
}

#[test]
fn no_two_files_import_each_other_directly_or_round_a_circle() {
    // Each crate on its own: Cargo already refuses a cycle between crates.
    let crates = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("crates");
    for (root, at_least) in [
        (src(), 25),
        (crates.join("science/src"), 25),
        (crates.join("render/src"), 25),
        (crates.join("instrument/src"), 25),
        (crates.join("store/src"), 15),
        (crates.join("report/src"), 15),
        (crates.join("lab/src"), 35),
    ] {
        let graph = import_graph(&root);
        assert!(
            graph.len() > at_least,
            "the graph of {} missed the files: {}",
            root.display(),
            graph.len()
        );
        let found = cycles(&graph);
        assert!(
            found.is_empty(),
            "import cycles between files of {} ({}); move what both need into a file below both:\n{}",
            root.display(),
            found.len(),
            found.join("\n")
        );
    }
}

/// The check itself: a planted circle (`a.rs` → `b.rs` → `c/mod.rs` →
/// `a.rs`) is found with each line; a root using its own submodule, a
/// path in a test module and another crate's path are not edges.
#[test]
fn a_planted_import_cycle_is_named_with_each_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::create_dir_all(src.join("c")).unwrap();
    let write = |f: &str, text: &str| std::fs::write(src.join(f), text).unwrap();
    write("lib.rs", "pub mod a;\npub mod b;\npub mod c;\n");
    write("a.rs", "use std::fmt;\n\nuse crate::b::{Thing as Other, more::*};\n");
    write("b.rs", "pub struct Thing;\nfn f() { super::c::g(); }\n");
    write(
        "c/mod.rs",
        "pub mod d;\npub use d::D;\npub fn g() {}\nfn h(a: crate::a::A) -> crate::a::A { a }\n#[cfg(test)]\nmod tests { use crate::b::Thing; }\n",
    );
    write("c/d.rs", "pub struct D;\nuse super::g;\n");
    let graph = import_graph(src);
    assert_eq!(
        graph[Path::new("c/mod.rs")].keys().collect::<Vec<_>>(),
        [Path::new("a.rs")],
        "{graph:?}"
    );
    assert_eq!(
        cycles(&graph),
        ["src/a.rs:3 → src/b.rs:2 → src/c/mod.rs:4 → src/a.rs"],
        "{graph:?}"
    );
}

// --- the OpenAPI document stays in the app ------------------------------

/// The lines of the crates' `Cargo.toml` files under `crates` (outside
/// comments) that name `axum`, or `utoipa` other than as an optional
/// dependency or `"dep:utoipa"` (the `openapi` feature), as `file:line: text`.
fn http_dependencies(crates: &Path) -> Vec<String> {
    let mut manifests: Vec<PathBuf> = std::fs::read_dir(crates)
        .unwrap()
        .map(|e| e.unwrap().path().join("Cargo.toml"))
        .filter(|m| m.is_file())
        .collect();
    manifests.sort();
    let mut bad = Vec::new();
    for manifest in manifests {
        let text = std::fs::read_to_string(&manifest).unwrap();
        for (n, line) in text.lines().enumerate() {
            let toml = line.split(" #").next().unwrap();
            let toml = if toml.trim_start().starts_with('#') { "" } else { toml };
            let named = toml.replace("\"dep:utoipa\"", "");
            if named.contains("axum") || (named.contains("utoipa") && !named.contains("optional = true")) {
                let rel = manifest.strip_prefix(crates).unwrap();
                bad.push(format!("crates/{}:{}: {}", rel.display(), n + 1, line.trim()));
            }
        }
    }
    bad
}

/// The lines of the Rust files under `src` whose code names `utoipa`,
/// `ToSchema` or `IntoParams` outside a `#[cfg_attr(feature = "openapi", …)]`
/// attribute or an item under `#[cfg(feature = "openapi")]`, as `file:line`
/// (the file relative to `src`).
fn ungated_openapi(src: &Path) -> Vec<String> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    let mut bad = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        // Inside a gate: whether it is a whole item (ends at its `;` or
        // closing brace) and how many brackets are open in it.
        let (mut gate, mut depth): (Option<bool>, i32) = (None, 0);
        for (n, (line, code)) in text.lines().zip(code_only(&text).lines()).enumerate() {
            let start = line.trim_start();
            if gate.is_none() && start.starts_with("#[cfg(feature = \"openapi\")]") {
                (gate, depth) = (Some(true), 0);
            } else if gate.is_none() && start.starts_with("#[cfg_attr(feature = \"openapi\",") {
                (gate, depth) = (Some(false), 0);
            }
            let Some(item) = gate else {
                if ["utoipa", "ToSchema", "IntoParams"].iter().any(|w| code.contains(w)) {
                    bad.push(format!("{}:{}", file.strip_prefix(src).unwrap().display(), n + 1));
                }
                continue;
            };
            for c in code.chars() {
                match c {
                    '(' | '[' | '{' => depth += 1,
                    ')' | ']' | '}' => {
                        depth -= 1;
                        if depth == 0 && (!item || c == '}') {
                            gate = None;
                        }
                    }
                    ';' if depth == 0 && item => gate = None,
                    _ => {}
                }
            }
        }
    }
    bad
}

#[test]
fn no_crate_below_the_app_needs_utoipa_or_axum() {
    let crates = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("crates");
    let bad = http_dependencies(&crates);
    assert!(
        bad.is_empty(),
        "a crate below the app depends on axum, or on utoipa without `optional = true` (the app's `openapi` feature turns it on):\n{}",
        bad.join("\n")
    );
    for name in ["science", "render", "instrument", "store", "report", "lab"] {
        let bad = ungated_openapi(&crates.join(name).join("src"));
        assert!(
            bad.is_empty(),
            "utoipa named outside `cfg_attr(feature = \"openapi\", …)` / `#[cfg(feature = \"openapi\")]`:\n{}",
            bad.iter()
                .map(|b| format!("crates/{name}/src/{b}"))
                .collect::<Vec<_>>()
                .join("\n")
        );
    }
}

/// The checks themselves: a planted unconditional utoipa and axum are
/// named with their lines; the gated forms and comments are not.
#[test]
fn a_planted_ungated_utoipa_is_named_with_its_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let crates = dir.path();
    std::fs::create_dir_all(crates.join("low/src")).unwrap();
    std::fs::write(
        crates.join("low/Cargo.toml"),
        "# no utoipa, no axum here\n[dependencies]\nutoipa = { workspace = true, optional = true }\naxum = \"0.8\"\n\
         utoipa-gen = \"5\"\n[features]\nopenapi = [\"dep:utoipa\"]\n",
    )
    .unwrap();
    assert_eq!(
        http_dependencies(crates),
        [
            "crates/low/Cargo.toml:4: axum = \"0.8\"",
            "crates/low/Cargo.toml:5: utoipa-gen = \"5\""
        ]
    );
    let src = crates.join("low/src");
    let lib = [
        "//! utoipa in a comment",
        "const T: &str = \"a line continuation: \\",
        "    ToSchema\";",
        "#[cfg(feature = \"openapi\")]",
        "use utoipa::IntoParams;",
        "#[derive(Debug)]",
        "#[cfg_attr(feature = \"openapi\", derive(utoipa::ToSchema))]",
        "pub struct A {",
        "    #[cfg_attr(feature = \"openapi\", schema(value_type = String))]",
        "    pub a: &'static str,",
        "}",
        "#[cfg(feature = \"openapi\")]",
        "impl IntoParams for B {",
        "    fn into_params() -> Vec<u8> { vec![] }",
        "}",
        "#[derive(utoipa::IntoParams)]",
        "pub struct B;",
        "const S: &str = \"ToSchema\";",
    ];
    std::fs::write(src.join("lib.rs"), lib.join("\n")).unwrap();
    assert_eq!(ungated_openapi(&src), ["lib.rs:16"]);
}

/// The lines of the Rust files under `dir` whose code names the store's
/// handle or its error (`Store`, `StoreError`), as `file:line` (the file
/// relative to `dir`). The HTTP layer's rows and ids come through the
/// lab's [`LabHandle`](lightbooth::lab::LabHandle); the rows' types
/// (`store::MeasurementDetail`…) may be named, the store may not.
fn store_handles(dir: &Path) -> Vec<String> {
    let mut files = Vec::new();
    rust_files(dir, &mut files);
    files.sort();
    let mut bad = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        for (n, code) in code_only(&text).lines().enumerate() {
            let words = code.split(|c: char| !(c.is_alphanumeric() || c == '_'));
            if words.into_iter().any(|w| w == "Store" || w == "StoreError") {
                bad.push(format!("{}:{}", file.strip_prefix(dir).unwrap().display(), n + 1));
            }
        }
    }
    bad
}

#[test]
fn the_http_layer_reaches_the_store_only_through_the_lab() {
    let http = src().join("http");
    let bad = store_handles(&http);
    assert!(
        bad.is_empty(),
        "the HTTP layer names the store; call a method of `state.lab` (crates/lab/src/handle.rs) instead, \
         adding one there if none fits:\n{}",
        bad.iter()
            .map(|b| format!("src/http/{b}"))
            .collect::<Vec<_>>()
            .join("\n")
    );
}

/// The check itself: a planted `Store` and `StoreError` are named with
/// their lines; row types, an atomic's `.store(…)`, comments and strings are not.
#[test]
fn a_planted_store_in_a_handler_is_named_with_its_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let routes = dir.path().join("routes");
    std::fs::create_dir_all(&routes).unwrap();
    let handler = [
        "//! Store in a comment",
        "use crate::store::{MeasurementDetail, RenderRow};",
        "use crate::store::Store;",
        "fn f(flag: &AtomicBool) { flag.store(true, Ordering::Release); }",
        "const S: &str = \"StoreError\";",
        "fn g(e: crate::store::StoreError) {}",
        "struct StoreErrors;",
    ];
    std::fs::write(routes.join("x.rs"), handler.join("\n")).unwrap();
    assert_eq!(store_handles(dir.path()), ["routes/x.rs:3", "routes/x.rs:6"]);
}
