//! The README's two commands share one build of every dependency:
//! `cargo build --release` (the main job) and then `cargo test --release`
//! must not compile a dependency again. Cargo unifies a crate's features per
//! build, and a dev-dependency that turns on another feature of a shared
//! crate (criterion, proptest and tempfile do: `regex-syntax/unicode`,
//! `either/use_std`, `bitflags/std`) makes the test build recompile that
//! crate and everything above it (57 crates, sqlx and exr among them, before
//! the pins in `Cargo.toml`). This test asks `cargo tree` for the features
//! of every normal dependency with and without the dev-dependencies and
//! fails naming each crate whose features differ, and the pin to add.

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// `package version` → the feature sets `cargo tree` lists for it.
fn features(edges: &str) -> BTreeMap<String, BTreeSet<String>> {
    let out = Command::new(env!("CARGO"))
        .args([
            "tree",
            "--offline",
            "--locked",
            "-e",
            edges,
            "--prefix",
            "none",
            "-f",
            "{p}|{f}",
            "--target",
            "x86_64-unknown-linux-gnu",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run cargo tree");
    assert!(
        out.status.success(),
        "cargo tree failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut map: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in String::from_utf8(out.stdout).unwrap().lines() {
        let line = line.replace(" (*)", "").replace(" (proc-macro)", "");
        if let Some((package, features)) = line.split_once('|') {
            map.entry(package.trim().to_string())
                .or_default()
                .insert(features.trim().to_string());
        }
    }
    map
}

#[test]
fn the_test_build_recompiled_57_dependencies_with_dev_dependency_features() {
    let build = features("normal");
    let test = features("normal,dev");
    assert!(build.len() > 50, "cargo tree listed {} packages", build.len());
    let differing: Vec<String> = build
        .iter()
        .filter(|(package, f)| test.get(*package) != Some(f))
        .map(|(package, f)| format!("{package}: build {f:?}, test {:?}", test.get(package)))
        .collect();
    assert!(
        differing.is_empty(),
        "these dependencies get other features when the tests are built, so `cargo test --release` \
         recompiles them after `cargo build --release`; pin the test build's features in Cargo.toml's \
         [dependencies] (see the feature pins there):\n{}",
        differing.join("\n")
    );
}
