//! Scene bundles: what is collected for every kind of reference (spectra,
//! IES, filters, meshes, nested RADIANCE includes), the hash's sensitivity,
//! the refusals, and that an unpacked bundle loads as the same scene. Scenes
//! are copies of the shipped `scenes/` in temp dirs.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use super::*;
use crate::scene_hash;

fn shipped_scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let dest = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_tree(&e.path(), &dest);
        } else {
            std::fs::copy(e.path(), dest).unwrap();
        }
    }
}

/// A temp dir holding a copy of the shipped scenes in `scenes/`.
fn scenes_copy() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("scenes");
    copy_tree(&shipped_scenes(), &root);
    (dir, root)
}

fn paths(b: &SceneBundle) -> BTreeSet<&str> {
    b.files().iter().map(|f| f.path.as_str()).collect()
}

#[test]
fn a_scene_in_a_sub_folder_bundles_its_spectra_filter_and_ies_relative_to_the_scenes_folder() {
    let (_dir, root) = scenes_copy();
    let c = SceneBundle::collect(&root, &root.join("examples/glossy_booth.toml")).unwrap();
    assert_eq!(c.bundle.scene_file(), "examples/glossy_booth.toml");
    assert_eq!(
        paths(&c.bundle),
        BTreeSet::from([
            "examples/glossy_booth.toml",
            "luminaires/mr16_ctb.ies",
            "spectra/colorchecker_classic.csv",
            "spectra/ctb_filter.csv",
        ])
    );
    for f in c.bundle.files() {
        assert_eq!(f.content, std::fs::read(root.join(&f.path)).unwrap(), "{}", f.path);
    }
    assert_eq!(c.scene_hash, scene_hash(&c.scene).unwrap());
}

#[test]
fn a_scene_with_a_mesh_bundles_the_obj_file() {
    let (_dir, root) = scenes_copy();
    let c = SceneBundle::collect(&root, &root.join("examples/own_booth.toml")).unwrap();
    let p = paths(&c.bundle);
    assert!(p.contains("examples/meshes/vase.obj"), "{p:?}");
    assert!(p.contains("spectra/white_paint.csv"), "{p:?}");
    assert!(p.contains("spectra/colorchecker_classic.csv"), "{p:?}");
}

/// A `[[radiance]]` file that `xform`s a file that `xform`s another, each
/// relative to the file holding the command.
fn write_nested_radiance_scene(root: &Path) -> PathBuf {
    std::fs::create_dir_all(root.join("rad/parts")).unwrap();
    std::fs::write(
        root.join("rad/main.rad"),
        "void light lamp 0 0 3 100 100 100\nlamp sphere bulb 0 0 4 0 0 2 0.1\n\
         void plastic m 0 0 5 .5 .5 .5 0 0\n!xform -n outer -t 0 0 0 parts/a.rad\n",
    )
    .unwrap();
    std::fs::write(root.join("rad/parts/a.rad"), "!xform -n inner -s 2 tri.rad\n").unwrap();
    std::fs::write(
        root.join("rad/parts/tri.rad"),
        "m polygon floor 0 0 12 -1 -1 0 1 -1 0 1 1 0 -1 1 0\n",
    )
    .unwrap();
    let toml = root.join("nested.toml");
    std::fs::write(
        &toml,
        "name = \"nested\"\n[radiometer]\nposition = [0.0, -1.0, 1.0]\nfield_deg = 1.0\n\
         [[target]]\nid = \"floor\"\npoint = [0.0, 0.0, 0.0]\n\
         [[radiance]]\nfile = \"rad/main.rad\"\n",
    )
    .unwrap();
    toml
}

#[test]
fn nested_radiance_includes_are_bundled_transitively() {
    let (_dir, root) = scenes_copy();
    let toml = write_nested_radiance_scene(&root);
    let c = SceneBundle::collect(&root, &toml).unwrap();
    assert_eq!(
        paths(&c.bundle),
        BTreeSet::from(["nested.toml", "rad/main.rad", "rad/parts/a.rad", "rad/parts/tri.rad"])
    );
    // And it unpacks to a scene with the same triangles.
    let cache = tempfile::tempdir().unwrap();
    let unpacked = load_scene(&c.bundle.unpack(cache.path()).unwrap()).unwrap();
    assert_eq!(
        format!("{:?}", unpacked.primitives),
        format!("{:?}", c.scene.primitives)
    );
}

#[test]
fn a_changed_spectrum_byte_changes_the_hash_and_an_unrelated_file_does_not() {
    let (_dir, root) = scenes_copy();
    let scene = root.join("examples/glossy_booth.toml");
    let before = SceneBundle::collect(&root, &scene).unwrap();

    std::fs::write(root.join("spectra/unrelated.csv"), "wavelength_nm,x\n380,1\n").unwrap();
    std::fs::write(root.join("examples/notes.txt"), "not a scene file").unwrap();
    let unrelated = SceneBundle::collect(&root, &scene).unwrap();
    assert_eq!(unrelated.bundle.hash(), before.bundle.hash());
    assert_eq!(unrelated.scene_hash, before.scene_hash);

    let filter = root.join("spectra/ctb_filter.csv");
    let mut bytes = std::fs::read(&filter).unwrap();
    let last_digit = bytes.iter().rposition(|b| b.is_ascii_digit() && *b != b'9').unwrap();
    bytes[last_digit] += 1;
    std::fs::write(&filter, bytes).unwrap();
    let changed = SceneBundle::collect(&root, &scene).unwrap();
    assert_ne!(changed.bundle.hash(), before.bundle.hash());
    assert_ne!(changed.scene_hash, before.scene_hash);
    assert_eq!(changed.bundle.hash().len(), 64);
    assert!(changed.bundle.hash().bytes().all(|b| b.is_ascii_hexdigit()));
}

#[test]
fn a_reference_outside_the_scenes_folder_is_refused_naming_the_file_and_key() {
    let (dir, root) = scenes_copy();
    std::fs::create_dir_all(dir.path().join("elsewhere")).unwrap();
    std::fs::copy(
        root.join("spectra/ctb_filter.csv"),
        dir.path().join("elsewhere/ctb_filter.csv"),
    )
    .unwrap();
    let scene = root.join("examples/glossy_booth.toml");
    let text = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(
        &scene,
        text.replace("\"../spectra/ctb_filter.csv", "\"../../elsewhere/ctb_filter.csv"),
    )
    .unwrap();
    // The scene loads (the loader allows any path) but is no bundle.
    load_scene(&scene).unwrap();
    let e = SceneBundle::collect(&root, &scene).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, BundleError::Outside { .. }), "{text}");
    assert!(text.contains("glossy_booth.toml"), "{text}");
    assert!(text.contains("light[0].filter"), "{text}");
    assert!(text.contains("elsewhere/ctb_filter.csv"), "{text}");
}

#[test]
fn a_symlink_escaping_the_scenes_folder_is_refused() {
    let (dir, root) = scenes_copy();
    let outside = dir.path().join("elsewhere.ies");
    std::fs::copy(root.join("luminaires/mr16_ctb.ies"), &outside).unwrap();
    std::fs::remove_file(root.join("luminaires/mr16_ctb.ies")).unwrap();
    std::os::unix::fs::symlink(&outside, root.join("luminaires/mr16_ctb.ies")).unwrap();
    let e = SceneBundle::collect(&root, &root.join("examples/glossy_booth.toml")).unwrap_err();
    assert!(matches!(e, BundleError::Outside { .. }), "{e}");
    assert!(e.to_string().contains("light[0].ies"), "{e}");
}

#[test]
fn an_unreadable_reference_is_an_error_naming_the_file_and_key() {
    let (_dir, root) = scenes_copy();
    std::fs::remove_file(root.join("spectra/ctb_filter.csv")).unwrap();
    let e = SceneBundle::collect(&root, &root.join("examples/glossy_booth.toml")).unwrap_err();
    let text = e.to_string();
    assert!(text.contains("glossy_booth.toml") && text.contains("filter"), "{text}");
}

#[test]
fn cylinder_unpacked_far_from_scenes_loads_as_the_same_scene() {
    let root = shipped_scenes();
    let c = SceneBundle::collect(&root, &root.join("cylinder.toml")).unwrap();
    let cache = tempfile::tempdir().unwrap();
    let toml = c.bundle.unpack(cache.path()).unwrap();
    assert_eq!(
        toml,
        cache.path().join("bundles").join(c.bundle.hash()).join("cylinder.toml")
    );
    let unpacked = load_scene(&toml).unwrap();
    // The render key reads bytes in load order, not paths: the same.
    assert_eq!(scene_hash(&unpacked).unwrap(), c.scene_hash);
    assert_eq!(unpacked.name, c.scene.name);
    assert_eq!(unpacked.targets(), c.scene.targets());
    assert_eq!(unpacked.files.len(), c.scene.files.len());
    for (what, a, b) in [
        (
            "materials",
            format!("{:?}", unpacked.materials),
            format!("{:?}", c.scene.materials),
        ),
        (
            "primitives",
            format!("{:?}", unpacked.primitives),
            format!("{:?}", c.scene.primitives),
        ),
        (
            "solids",
            format!("{:?}", unpacked.solids),
            format!("{:?}", c.scene.solids),
        ),
        (
            "lights",
            format!("{:?}", unpacked.lights),
            format!("{:?}", c.scene.lights),
        ),
        (
            "emitters",
            format!("{:?}", unpacked.emitters),
            format!("{:?}", c.scene.emitters),
        ),
        (
            "radiometer",
            format!("{:?}", unpacked.radiometer),
            format!("{:?}", c.scene.radiometer),
        ),
        (
            "targets",
            format!("{:?}", unpacked.target_list),
            format!("{:?}", c.scene.target_list),
        ),
        (
            "white",
            format!("{:?}", unpacked.cielab_white),
            format!("{:?}", c.scene.cielab_white),
        ),
    ] {
        assert_eq!(a, b, "{what} differ");
    }
    // Collected again from the unpacked folder: the same bundle.
    let again = SceneBundle::collect(&cache.path().join("bundles").join(c.bundle.hash()), &toml).unwrap();
    assert_eq!(again.bundle, c.bundle);
    // A second unpack reuses the folder.
    assert_eq!(c.bundle.unpack(cache.path()).unwrap(), toml);
}

fn bundle_with(path: &str) -> SceneBundle {
    SceneBundle {
        scene_file: path.to_string(),
        files: vec![BundleFile {
            path: path.to_string(),
            content: b"name = \"x\"\n".to_vec(),
        }],
    }
}

#[test]
fn unpack_refuses_a_dot_dot_path_and_writes_nothing_outside_the_cache() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let e = bundle_with("../escaped.toml").unpack(&cache).unwrap_err();
    assert!(matches!(e, BundleError::BadPath { .. }), "{e}");
    assert!(e.to_string().contains("../escaped.toml"), "{e}");
    assert!(!dir.path().join("escaped.toml").exists());
    assert!(!cache.join("escaped.toml").exists());
    let e = bundle_with("a/../../escaped.toml").unpack(&cache).unwrap_err();
    assert!(matches!(e, BundleError::BadPath { .. }), "{e}");
}

#[test]
fn unpack_refuses_an_absolute_path() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("absolute.toml");
    let e = bundle_with(target.to_str().unwrap())
        .unpack(&dir.path().join("cache"))
        .unwrap_err();
    assert!(matches!(e, BundleError::BadPath { .. }), "{e}");
    assert!(!target.exists());
}

#[test]
fn from_parts_refuses_bad_paths_duplicates_and_a_missing_scene_file() {
    let f = |p: &str| BundleFile {
        path: p.into(),
        content: vec![1],
    };
    for bad in ["", "/etc/passwd", "a//b", "a/./b", "a/../b", "..", "a\\b", "a/"] {
        let e = SceneBundle::from_parts("s.toml".into(), vec![f("s.toml"), f(bad)]).unwrap_err();
        assert!(matches!(e, BundleError::BadPath { .. }), "`{bad}`: {e}");
    }
    let e = SceneBundle::from_parts("s.toml".into(), vec![f("s.toml"), f("s.toml")]).unwrap_err();
    assert!(e.to_string().contains("twice"), "{e}");
    let e = SceneBundle::from_parts("s.toml".into(), vec![f("t.toml")]).unwrap_err();
    assert!(e.to_string().contains("not among"), "{e}");
}

#[test]
fn unpack_refuses_a_bundle_over_the_size_limit() {
    let dir = tempfile::tempdir().unwrap();
    let big = SceneBundle {
        scene_file: "s.toml".into(),
        files: vec![
            BundleFile {
                path: "s.toml".into(),
                content: vec![],
            },
            BundleFile {
                path: "mesh.obj".into(),
                content: vec![0; MAX_BUNDLE_BYTES as usize + 1],
            },
        ],
    };
    let e = big.unpack(dir.path()).unwrap_err();
    assert!(matches!(e, BundleError::TooLarge(_)), "{e}");
    assert!(!dir.path().join("bundles").join(big.hash()).exists());
}

#[test]
fn unpack_never_writes_through_a_symlink_planted_in_the_cache_folder() {
    let (_dir, root) = scenes_copy();
    let c = SceneBundle::collect(&root, &root.join("examples/glossy_booth.toml")).unwrap();
    let cache = tempfile::tempdir().unwrap();
    let outside = tempfile::tempdir().unwrap();
    let planted = cache.path().join("bundles").join(c.bundle.hash());
    std::fs::create_dir_all(&planted).unwrap();
    std::os::unix::fs::symlink(outside.path(), planted.join("spectra")).unwrap();
    let toml = c.bundle.unpack(cache.path()).unwrap();
    assert_eq!(
        std::fs::read_dir(outside.path()).unwrap().count(),
        0,
        "wrote through the link"
    );
    assert!(!std::fs::symlink_metadata(planted.join("spectra")).unwrap().is_symlink());
    load_scene(&toml).unwrap();
}

#[test]
fn a_tampered_unpacked_file_is_replaced_on_the_next_unpack() {
    let (_dir, root) = scenes_copy();
    let c = SceneBundle::collect(&root, &root.join("examples/glossy_booth.toml")).unwrap();
    let cache = tempfile::tempdir().unwrap();
    let toml = c.bundle.unpack(cache.path()).unwrap();
    let filter = toml.parent().unwrap().join("../spectra/ctb_filter.csv");
    std::fs::write(&filter, "wavelength_nm,full_half_ctb\n380,0\n").unwrap();
    c.bundle.unpack(cache.path()).unwrap();
    assert_eq!(
        std::fs::read(&filter).unwrap(),
        std::fs::read(root.join("spectra/ctb_filter.csv")).unwrap()
    );
}
