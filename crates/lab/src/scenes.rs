//! The scene catalogue: the scenes a daemon serves (or a render worker
//! renders for the daemon it works for), each loaded once, when the
//! catalogue is built.
//!
//! Building it reads every scene file, checks it (its `[cielab_white]`
//! included: a scene without one is refused at start, not at its first
//! comparison) and takes its render key ([`render::scene_hash`]); a scene
//! that fails to load is an error naming the file and key — a broken booth
//! must be fixed, not skipped. After that no workflow reads a scene file
//! again: renders, comparisons, whites and camera images all take the
//! catalogue's [`CatalogScene`], so a comparison costs no file reads and
//! every render of a scene is of the same content. A scene file edited or
//! added while the daemon runs is seen after a restart.
//!
//! ```no_run
//! # fn main() -> anyhow::Result<()> {
//! use lightbooth_science::colorimetry::Observer;
//! use lightbooth_lab::scenes::SceneCatalog;
//!
//! let catalogue = SceneCatalog::from_folder("scenes".as_ref(), Observer::JuddVos)?;
//! for scene in catalogue.iter() {
//!     println!("{}: {} targets", scene.id, scene.targets().len());
//! }
//! # Ok(()) }
//! ```

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::compare::white::{scene_white, SceneWhite};
use crate::requests::SceneInfo;
use lightbooth_render::{self as render, Scene};
use lightbooth_science::colorimetry::Observer;

/// The study's order of its scenes: the simple ones, then CYLINDER; other
/// scenes follow in file-name order.
const STUDY_ORDER: [&str; 5] = ["white", "red", "green", "blue", "cylinder"];

/// One scene of the catalogue, as it was loaded.
pub struct CatalogScene {
    /// The file name without `.toml`: the scene's id in the API and the store.
    pub id: String,
    /// The scene file.
    pub path: PathBuf,
    /// The loaded scene (shared by every render of it).
    pub scene: Arc<Scene>,
    /// Its render key: the hash of the scene's content and every file it reads.
    pub hash: String,
    /// The CIELAB reference white it declares, with the catalogue's observer.
    pub white: SceneWhite,
}

impl CatalogScene {
    /// The scene's title (its `name`).
    pub fn title(&self) -> &str {
        &self.scene.name
    }

    /// Its measurement targets, in the file's order.
    pub fn targets(&self) -> Vec<&str> {
        self.scene.targets()
    }

    /// The scene as the API lists it.
    pub fn info(&self) -> SceneInfo {
        SceneInfo {
            id: self.id.clone(),
            title: self.title().to_string(),
            targets: self.targets().into_iter().map(str::to_string).collect(),
        }
    }
}

/// The scenes, in the study's order.
pub struct SceneCatalog {
    scenes: Vec<CatalogScene>,
}

impl SceneCatalog {
    /// Every `*.toml` scene of the folder `dir`.
    pub fn from_folder(dir: &Path, observer: Observer) -> anyhow::Result<SceneCatalog> {
        let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
            .map_err(|e| anyhow::anyhow!("cannot read the scenes folder {}: {e}", dir.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        paths.sort();
        SceneCatalog::from_files(&paths, observer)
    }

    /// The scene files `paths` (each scene's id is its file name without
    /// `.toml`): a render worker's, whose scenes are unpacked bundles.
    pub fn from_files(paths: &[PathBuf], observer: Observer) -> anyhow::Result<SceneCatalog> {
        let mut scenes = Vec::new();
        for path in paths {
            let scene = render::load_scene(path)?;
            let white = scene_white(path, &scene, observer).map_err(anyhow::Error::msg)?;
            let hash = render::scene_hash(&scene)?;
            let id = path
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or_default()
                .to_string();
            anyhow::ensure!(
                !scenes.iter().any(|s: &CatalogScene| s.id == id),
                "{}: a second scene with the id `{id}`; scene ids (file names without .toml) must differ",
                path.display()
            );
            scenes.push(CatalogScene {
                id,
                path: path.clone(),
                scene: Arc::new(scene),
                hash,
                white,
            });
        }
        scenes.sort_by_key(|s| STUDY_ORDER.iter().position(|o| *o == s.id).unwrap_or(STUDY_ORDER.len()));
        Ok(SceneCatalog { scenes })
    }

    /// The scene `id`.
    pub fn get(&self, id: &str) -> Option<&CatalogScene> {
        self.scenes.iter().find(|s| s.id == id)
    }

    /// Every scene, in the study's order.
    pub fn iter(&self) -> impl Iterator<Item = &CatalogScene> {
        self.scenes.iter()
    }

    /// The scenes' ids, in the study's order.
    pub fn ids(&self) -> Vec<&str> {
        self.scenes.iter().map(|s| s.id.as_str()).collect()
    }

    /// The scenes as the API lists them.
    pub fn infos(&self) -> Vec<SceneInfo> {
        self.scenes.iter().map(CatalogScene::info).collect()
    }

    /// The scenes whose comparisons a new measurement of `scene`/`target`
    /// may change: `scene` itself and every scene whose CIELAB white is that
    /// target.
    pub fn whitened_by(&self, scene: &str, target: &str) -> Vec<&str> {
        self.scenes
            .iter()
            .filter(|s| s.id == scene || s.white.is_target(scene, target))
            .map(|s| s.id.as_str())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scenes_dir() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
    }

    #[test]
    fn the_shipped_scenes_load_in_the_studys_order() {
        let catalogue = SceneCatalog::from_folder(&scenes_dir(), Observer::JuddVos).unwrap();
        let ids = catalogue.ids();
        assert_eq!(&ids[..5], &["white", "red", "green", "blue", "cylinder"], "{ids:?}");
        let cylinder = catalogue.get("cylinder").unwrap();
        assert!(cylinder.targets().contains(&"h21"), "{:?}", cylinder.targets());
        assert_eq!(cylinder.info().targets.len(), cylinder.targets().len());
        assert!(catalogue.get("no-such-scene").is_none());
    }

    #[test]
    fn a_measurement_of_the_spectralon_rewhites_every_scene_that_names_it() {
        let catalogue = SceneCatalog::from_folder(&scenes_dir(), Observer::JuddVos).unwrap();
        // WHITE, RED, GREEN and BLUE take WHITE's Spectralon as their white;
        // CYLINDER its own top target.
        let mut by_patch = catalogue.whitened_by("white", "patch");
        by_patch.sort();
        assert_eq!(by_patch, ["blue", "green", "red", "white"]);
        assert_eq!(catalogue.whitened_by("cylinder", "h21"), ["cylinder"]);
        // Another target of CYLINDER whitens nothing but its own scene.
        let other = catalogue.get("cylinder").unwrap().targets()[0];
        assert_ne!(other, "h21");
        assert_eq!(catalogue.whitened_by("cylinder", other), ["cylinder"]);
    }

    #[test]
    fn a_scene_without_a_cielab_white_is_refused_naming_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let text = std::fs::read_to_string(scenes_dir().join("white.toml")).unwrap();
        let start = text.find("[cielab_white]").expect("white.toml declares its white");
        let rest = &text[start + "[cielab_white]".len()..];
        let end = rest
            .find("\n[")
            .map(|i| start + "[cielab_white]".len() + i)
            .unwrap_or(text.len());
        let without = format!("{}{}", &text[..start], &text[end..]);
        // Beside the files the scene reads, as in `scenes/`.
        for shared in ["spectra", "luminaires"] {
            std::os::unix::fs::symlink(scenes_dir().join(shared), dir.path().join(shared)).unwrap();
        }
        let path = dir.path().join("bare.toml");
        std::fs::write(&path, without).unwrap();
        let err = SceneCatalog::from_files(&[path], Observer::JuddVos)
            .err()
            .expect("a scene without a white is refused")
            .to_string();
        assert!(err.contains("bare.toml") && err.contains("cielab_white"), "{err}");
    }
}
