//! The converged-spectrum cache (what the simulated PR-650 sees): one file
//! per scene content and target, keyed unambiguously, written atomically,
//! and a torn or corrupt file is recomputed instead of breaking every later
//! measurement.

use std::path::{Path, PathBuf};

use lightbooth::render::{cache_file, converged_target_spectrum, load_scene, truth_hash, truth_settings};

/// A lone grey plane under a spotlight with two targets whose ids differ
/// only in `.` against `_`, at different points (so different spectra).
fn two_target_scene(dir: &Path) -> PathBuf {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    std::fs::copy(scenes.join("luminaires/mr16_ctb.ies"), dir.join("spot.ies")).unwrap();
    std::fs::write(dir.join("refl.csv"), "nm,grey\n380,0.5\n780,0.5\n").unwrap();
    let text = r#"name = "two targets"
[radiometer]
position = [0.0, 1.0, 1.0]
[[target]]
id = "a.b"
point = [0.0, 0.0, 0.0]
[[target]]
id = "a_b"
point = [0.6, 0.0, 0.0]
[materials]
grey = { reflectance = "refl.csv:grey" }
[[light]]
id = "spot"
position = [0.0, 1.0, 0.0]
aim = [0.0, -1.0, 0.0]
ies = "spot.ies"
blackbody_k = 3200
[[quad]]
corner = [-1.0, 0.0, -1.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 2.0]
material = "grey"
"#;
    let p = dir.join("two.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn target_ids_a_dot_b_and_a_underscore_b_get_their_own_cache_files() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let scene = two_target_scene(dir.path());
    let loaded = load_scene(&scene).unwrap();
    let hash = truth_hash(&loaded, &truth_settings("a.b")).unwrap();
    assert_ne!(cache_file(&cache, &hash, "a.b"), cache_file(&cache, &hash, "a_b"));
    let dot = converged_target_spectrum(&scene, "a.b", Some(&cache)).unwrap();
    let underscore = converged_target_spectrum(&scene, "a_b", Some(&cache)).unwrap();
    // The spot is aimed at a.b: it is far brighter than a_b, off axis.
    assert!(dot.values()[300] > 1.5 * underscore.values()[300]);
    // Read back from the cache, each is its own.
    assert_eq!(converged_target_spectrum(&scene, "a.b", Some(&cache)).unwrap(), dot);
    assert_eq!(
        converged_target_spectrum(&scene, "a_b", Some(&cache)).unwrap(),
        underscore
    );
}

#[test]
fn a_torn_cache_file_is_recomputed_not_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let scene = two_target_scene(dir.path());
    let first = converged_target_spectrum(&scene, "a.b", Some(&cache)).unwrap();
    // The truth's cache key: the scene's content and the truth's settings.
    let hash = truth_hash(&load_scene(&scene).unwrap(), &truth_settings("a.b")).unwrap();
    let file = cache_file(&cache, &hash, "a.b");
    let whole = std::fs::read(&file).unwrap();
    // As a crash in the middle of the write would leave it (in place).
    std::fs::write(&file, &whole[..whole.len() / 2]).unwrap();
    let again = converged_target_spectrum(&scene, "a.b", Some(&cache)).unwrap();
    assert_eq!(again, first, "recomputed (deterministic: the same seed and paths)");
    assert_eq!(std::fs::read(&file).unwrap(), whole, "and the file replaced whole");
    // Garbage, too.
    std::fs::write(&file, "nm,radiance\n380,not a number\n").unwrap();
    assert_eq!(converged_target_spectrum(&scene, "a.b", Some(&cache)).unwrap(), first);
    // Nothing but the cache files is left in the folder (no temporary files).
    let names: Vec<String> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.iter().all(|n| n.ends_with(".csv") && !n.contains(".tmp")),
        "{names:?}"
    );
}
