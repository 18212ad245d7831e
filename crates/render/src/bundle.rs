//! Scene bundles: a scene's complete set of files — its TOML and every file
//! the scene loader reads for it (spectra CSVs, IES files, OBJ/PLY meshes,
//! `[[radiance]]` `.rad` files and what they `xform` or read as
//! `specfile`s, transitively) — as (relative path, bytes), so a machine
//! without the scenes folder (a render worker) can rebuild it from the
//! database and load the same scene.
//!
//! # What is collected
//!
//! Exactly the files [`load_scene`] read (`Scene::files`): the loader is the
//! one authority on which references it follows, so the bundle cannot miss
//! a kind of reference the loader learns later. Paths are relative to the
//! *scenes folder* (the root given to [`SceneBundle::collect`]), not to the
//! scene's own folder: scenes in sub-folders (`truth/`, `variants/`,
//! `examples/`) reference `../spectra/…`, and a bundle keeps the layout
//! those references need. A reference outside the scenes folder (lexically
//! or through a symbolic link) is refused, naming the scene file and the
//! TOML key that makes it (or the `.rad` file that includes it). The scene
//! a `[cielab_white]` names by `scene = "…"` is not followed: renders do not
//! read it (the daemon resolves whites against its measurements).
//!
//! # The bundle hash and the render key
//!
//! [`SceneBundle::hash`] is SHA-256 (hex) over a version tag, the scene
//! file's relative path, then every file sorted by relative path, each as
//! its path and its bytes with their lengths: any changed byte of a
//! referenced file, a renamed file or another entry scene changes it; a
//! file in the folder the scene does not reference does not.
//!
//! [`super::scene_hash`] (FNV-1a, 64 bit, over the same files' bytes in load
//! order, no paths) stays the key of renders and of the converged-spectrum
//! cache: every stored render and cache file is keyed by it, and replacing
//! it would make every stored render unreusable (a re-render of every scene)
//! for no gain in what it identifies — both change exactly when a byte the
//! loader reads changes. The two are tied instead: [`CollectedScene`] gives
//! both from the same bytes, the store keeps the render key next to each
//! bundle (`scene_bundles.scene_hash`), and a bundle unpacked anywhere loads
//! to a scene with the same render key (the hash reads bytes, not paths).
//!
//! # Unpacking
//!
//! [`SceneBundle::unpack`] writes into `<cache>/bundles/<hash>/`: paths must
//! be relative, plain (no `..`, `.`, root or empty part) and UTF-8; the
//! bundle at most [`MAX_BUNDLE_BYTES`] and [`MAX_BUNDLE_FILES`]; files are
//! written into a fresh temporary folder with `create_new` (never through
//! an existing link), read back and hashed, and only a folder whose hash
//! matches is renamed into place. An existing folder is reused only if it
//! holds exactly the bundle's files, none a symbolic link.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Component, Path, PathBuf};

use sha2::{Digest, Sha256};

use super::{load_scene, scene_hash_of, Scene, SceneError};

/// The most bytes a bundle may hold (all files together): 256 MiB, above
/// any booth scene (the largest shipped, CYLINDER, is under 1 MiB) and well
/// below what a database row set should carry.
pub const MAX_BUNDLE_BYTES: u64 = 256 << 20;

/// The most files a bundle may hold.
pub const MAX_BUNDLE_FILES: usize = 10_000;

const HASH_TAG: &[u8] = b"lightbooth-scene-bundle-v1";

/// Why a bundle could not be collected or unpacked; each names the file.
#[derive(Debug, thiserror::Error)]
pub enum BundleError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(
        "{file}: {key}: `{reference}` is outside the scenes folder {root}; a scene bundle holds only files under it"
    )]
    Outside {
        file: String,
        key: String,
        reference: String,
        root: String,
    },
    #[error("{file}: {key}: cannot read `{reference}`: {message}")]
    Unreadable {
        file: String,
        key: String,
        reference: String,
        message: String,
    },
    #[error("scene bundle: path `{path}`: {message}")]
    BadPath { path: String, message: String },
    #[error("scene bundle: {0}")]
    TooLarge(String),
    #[error("scene bundle {expected}: its files hash to {actual}; refusing a bundle that is not what it claims")]
    HashMismatch { expected: String, actual: String },
    #[error("scene bundle folder {folder}: {message}")]
    Io { folder: String, message: String },
}

/// One file of a bundle.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BundleFile {
    /// Relative to the scenes folder, `/`-separated.
    pub path: String,
    pub content: Vec<u8>,
}

/// A scene's complete set of files (see the module doc).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneBundle {
    /// The scene TOML's path among `files`.
    scene_file: String,
    /// Sorted by path, no two alike.
    files: Vec<BundleFile>,
}

/// A scene loaded from the scenes folder with its bundle and its render key,
/// all from the same bytes.
#[derive(Debug)]
pub struct CollectedScene {
    pub scene: Scene,
    pub bundle: SceneBundle,
    /// [`super::scene_hash`] of the bundled bytes: the renders' key.
    pub scene_hash: String,
}

impl SceneBundle {
    /// Loads the scene at `scene_path` and collects its files relative to
    /// `scenes_root` (see the module doc).
    pub fn collect(scenes_root: &Path, scene_path: &Path) -> Result<CollectedScene, BundleError> {
        let scene = load_scene(scene_path)?;
        SceneBundle::of_scene(scenes_root, scene)
    }

    /// Collects the files of an already loaded scene relative to
    /// `scenes_root`. The files are read again: the render key returned is
    /// of the bytes bundled.
    pub fn of_scene(scenes_root: &Path, scene: Scene) -> Result<CollectedScene, BundleError> {
        let scene_file_name = scene.path.display().to_string();
        let root_abs = absolute(scenes_root);
        let root_real = std::fs::canonicalize(scenes_root).map_err(|e| BundleError::Unreadable {
            file: scene_file_name.clone(),
            key: "(scenes folder)".into(),
            reference: scenes_root.display().to_string(),
            message: e.to_string(),
        })?;
        let toml_text = super::input_file::read_text(&scene.path).unwrap_or_default();
        let toml_tree: Option<toml::Value> = toml::from_str(&toml_text).ok();
        let scene_dir = absolute(scene.path.parent().unwrap_or(Path::new("")));
        let key_of = |file: &Path| -> String {
            if file == absolute(&scene.path) {
                return "(scene file)".into();
            }
            toml_tree
                .as_ref()
                .and_then(|t| key_referencing(t, String::new(), &scene_dir, file))
                .unwrap_or_else(|| "(a file a [[radiance]] file includes)".into())
        };
        let mut contents = Vec::with_capacity(scene.files.len());
        let mut files = BTreeMap::new();
        let mut total: u64 = 0;
        for f in &scene.files {
            let abs = absolute(f);
            let outside = || BundleError::Outside {
                file: scene_file_name.clone(),
                key: key_of(&abs),
                reference: f.display().to_string(),
                root: scenes_root.display().to_string(),
            };
            let rel = abs.strip_prefix(&root_abs).map_err(|_| outside())?;
            let real = std::fs::canonicalize(f).map_err(|e| BundleError::Unreadable {
                file: scene_file_name.clone(),
                key: key_of(&abs),
                reference: f.display().to_string(),
                message: e.to_string(),
            })?;
            if !real.starts_with(&root_real) {
                return Err(outside());
            }
            let path = relative_string(rel).map_err(|message| BundleError::BadPath {
                path: rel.display().to_string(),
                message,
            })?;
            // Bounded and regular files only, as the loader read them.
            let bytes = super::input_file::read_bytes(f).map_err(|e| BundleError::Unreadable {
                file: scene_file_name.clone(),
                key: key_of(&abs),
                reference: f.display().to_string(),
                message: e.reason,
            })?;
            total += bytes.len() as u64;
            contents.push(bytes.clone());
            files.insert(path, bytes);
        }
        let scene_rel = absolute(&scene.path);
        let scene_file = relative_string(scene_rel.strip_prefix(&root_abs).map_err(|_| BundleError::Outside {
            file: scene_file_name.clone(),
            key: "(scene file)".into(),
            reference: scene_file_name.clone(),
            root: scenes_root.display().to_string(),
        })?)
        .map_err(|message| BundleError::BadPath {
            path: scene_file_name.clone(),
            message,
        })?;
        check_size(files.len(), total)?;
        let scene_hash = scene_hash_of(contents.iter().map(Vec::as_slice));
        let bundle = SceneBundle {
            scene_file,
            files: files
                .into_iter()
                .map(|(path, content)| BundleFile { path, content })
                .collect(),
        };
        Ok(CollectedScene {
            scene,
            bundle,
            scene_hash,
        })
    }

    /// A bundle from stored parts, its paths and size checked (as
    /// [`SceneBundle::unpack`] would refuse them).
    pub fn from_parts(scene_file: String, files: Vec<BundleFile>) -> Result<SceneBundle, BundleError> {
        let mut sorted: BTreeMap<String, Vec<u8>> = BTreeMap::new();
        let mut total = 0u64;
        for f in files {
            check_relative(&f.path)?;
            total += f.content.len() as u64;
            if sorted.insert(f.path.clone(), f.content).is_some() {
                return Err(BundleError::BadPath {
                    path: f.path,
                    message: "appears twice".into(),
                });
            }
        }
        check_size(sorted.len(), total)?;
        if !sorted.contains_key(&scene_file) {
            return Err(BundleError::BadPath {
                path: scene_file,
                message: "the scene file is not among the bundle's files".into(),
            });
        }
        Ok(SceneBundle {
            scene_file,
            files: sorted
                .into_iter()
                .map(|(path, content)| BundleFile { path, content })
                .collect(),
        })
    }

    /// One bundle holding the files of all `bundles` (which share one
    /// scenes folder, as a daemon's scenes do), with the first one's scene
    /// file: unpacked, every scene's TOML sits where its references (a
    /// `[cielab_white]` naming a sibling scene, shared spectra) expect. A
    /// path two bundles hold with different bytes is refused, naming it.
    pub fn merge(bundles: &[SceneBundle]) -> Result<SceneBundle, BundleError> {
        let first = bundles.first().ok_or_else(|| BundleError::BadPath {
            path: String::new(),
            message: "no bundles to merge".into(),
        })?;
        let mut files: BTreeMap<&str, (&[u8], &str)> = BTreeMap::new();
        for b in bundles {
            for f in &b.files {
                match files.get(f.path.as_str()) {
                    Some((content, _)) if *content == f.content.as_slice() => {}
                    Some((_, other)) => {
                        return Err(BundleError::BadPath {
                            path: f.path.clone(),
                            message: format!(
                                "differs between the bundles of `{other}` and `{}` (the scenes folder changed between them)",
                                b.scene_file
                            ),
                        })
                    }
                    None => {
                        files.insert(&f.path, (&f.content, &b.scene_file));
                    }
                }
            }
        }
        SceneBundle::from_parts(
            first.scene_file.clone(),
            files
                .into_iter()
                .map(|(path, (content, _))| BundleFile {
                    path: path.to_string(),
                    content: content.to_vec(),
                })
                .collect(),
        )
    }

    /// The scene TOML's relative path.
    pub fn scene_file(&self) -> &str {
        &self.scene_file
    }

    /// The files, sorted by path.
    pub fn files(&self) -> &[BundleFile] {
        &self.files
    }

    /// The bytes of all files together.
    pub fn total_bytes(&self) -> u64 {
        self.files.iter().map(|f| f.content.len() as u64).sum()
    }

    /// SHA-256 (hex) of the bundle (see the module doc).
    pub fn hash(&self) -> String {
        bundle_hash(
            &self.scene_file,
            self.files.iter().map(|f| (f.path.as_str(), f.content.as_slice())),
        )
    }

    /// Writes the bundle into `<cache_dir>/bundles/<hash>/` (see the module
    /// doc) and returns the scene TOML's path there.
    pub fn unpack(&self, cache_dir: &Path) -> Result<PathBuf, BundleError> {
        let hash = self.hash();
        let bundles = cache_dir.join("bundles");
        let io = |folder: &Path, e: &dyn std::fmt::Display| BundleError::Io {
            folder: folder.display().to_string(),
            message: e.to_string(),
        };
        for f in &self.files {
            check_relative(&f.path)?;
        }
        check_size(self.files.len(), self.total_bytes())?;
        std::fs::create_dir_all(&bundles).map_err(|e| io(&bundles, &e))?;
        let target = bundles.join(&hash);
        let scene_toml = target.join(&self.scene_file);
        if std::fs::symlink_metadata(&target).is_ok() {
            if self.folder_holds_bundle(&target, &hash)? {
                return Ok(scene_toml);
            }
            // A torn or tampered folder: move it aside, then replace it.
            let aside = bundles.join(format!("{hash}.stale.{}", unique()));
            std::fs::rename(&target, &aside).map_err(|e| io(&target, &e))?;
            let _ = std::fs::remove_dir_all(&aside);
        }
        let tmp = bundles.join(format!("{hash}.tmp.{}", unique()));
        let written = (|| {
            std::fs::create_dir(&tmp).map_err(|e| io(&tmp, &e))?;
            for f in &self.files {
                let p = tmp.join(&f.path);
                if let Some(parent) = p.parent() {
                    std::fs::create_dir_all(parent).map_err(|e| io(parent, &e))?;
                }
                let mut out = std::fs::OpenOptions::new()
                    .write(true)
                    .create_new(true)
                    .open(&p)
                    .map_err(|e| io(&p, &e))?;
                out.write_all(&f.content).map_err(|e| io(&p, &e))?;
                out.sync_all().map_err(|e| io(&p, &e))?;
            }
            if !self.folder_holds_bundle(&tmp, &hash)? {
                return Err(BundleError::HashMismatch {
                    expected: hash.clone(),
                    actual: folder_hash(&tmp, &self.scene_file)?,
                });
            }
            match std::fs::rename(&tmp, &target) {
                Ok(()) => Ok(()),
                // Another unpacker finished first: use its folder if it is right.
                Err(_) if self.folder_holds_bundle(&target, &hash)? => {
                    let _ = std::fs::remove_dir_all(&tmp);
                    Ok(())
                }
                Err(e) => Err(io(&target, &e)),
            }
        })();
        if written.is_err() {
            let _ = std::fs::remove_dir_all(&tmp);
        }
        written.map(|()| scene_toml)
    }

    /// True when `folder` holds exactly this bundle's files (regular files,
    /// no links) and they hash to `hash`.
    fn folder_holds_bundle(&self, folder: &Path, hash: &str) -> Result<bool, BundleError> {
        match folder_hash(folder, &self.scene_file) {
            Ok(h) => Ok(h == hash),
            Err(BundleError::BadPath { .. }) | Err(BundleError::TooLarge(_)) => Ok(false),
            Err(e) => Err(e),
        }
    }
}

/// The hash of a bundle given as (path, bytes) in any order.
fn bundle_hash<'a>(scene_file: &str, files: impl Iterator<Item = (&'a str, &'a [u8])>) -> String {
    let mut sorted: Vec<(&str, &[u8])> = files.collect();
    sorted.sort_by(|a, b| a.0.cmp(b.0));
    let mut h = Sha256::new();
    let mut field = |bytes: &[u8]| {
        h.update((bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    };
    field(HASH_TAG);
    field(scene_file.as_bytes());
    for (path, content) in sorted {
        field(path.as_bytes());
        field(content);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// The bundle hash of what `folder` holds, refusing symbolic links and
/// anything but folders and regular files.
fn folder_hash(folder: &Path, scene_file: &str) -> Result<String, BundleError> {
    let mut found: Vec<(String, Vec<u8>)> = Vec::new();
    let mut total = 0u64;
    let mut stack = vec![folder.to_path_buf()];
    let io = |p: &Path, e: &dyn std::fmt::Display| BundleError::Io {
        folder: p.display().to_string(),
        message: e.to_string(),
    };
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).map_err(|e| io(&dir, &e))? {
            let entry = entry.map_err(|e| io(&dir, &e))?;
            let p = entry.path();
            let kind = std::fs::symlink_metadata(&p).map_err(|e| io(&p, &e))?.file_type();
            let rel =
                relative_string(p.strip_prefix(folder).unwrap_or(&p)).map_err(|message| BundleError::BadPath {
                    path: p.display().to_string(),
                    message,
                })?;
            if kind.is_dir() {
                stack.push(p);
            } else if kind.is_file() {
                let bytes = std::fs::read(&p).map_err(|e| io(&p, &e))?;
                total += bytes.len() as u64;
                found.push((rel, bytes));
                check_size(found.len(), total)?;
            } else {
                return Err(BundleError::BadPath {
                    path: rel,
                    message: "is a symbolic link or special file, not a regular file".into(),
                });
            }
        }
    }
    Ok(bundle_hash(
        scene_file,
        found.iter().map(|(p, b)| (p.as_str(), b.as_slice())),
    ))
}

fn check_size(files: usize, bytes: u64) -> Result<(), BundleError> {
    if files > MAX_BUNDLE_FILES {
        return Err(BundleError::TooLarge(format!(
            "{files} files, more than the limit of {MAX_BUNDLE_FILES}"
        )));
    }
    if bytes > MAX_BUNDLE_BYTES {
        return Err(BundleError::TooLarge(format!(
            "{bytes} bytes, more than the limit of {MAX_BUNDLE_BYTES} bytes"
        )));
    }
    Ok(())
}

/// Refuses a bundle path that is not relative and plain: absolute, empty,
/// `.` or `..` parts, a backslash (a Windows separator) or a NUL.
fn check_relative(path: &str) -> Result<(), BundleError> {
    let bad = |message: &str| BundleError::BadPath {
        path: path.to_string(),
        message: message.into(),
    };
    if path.is_empty() {
        return Err(bad("is empty"));
    }
    if path.starts_with('/') {
        return Err(bad("is absolute; bundle paths are relative to the scenes folder"));
    }
    if path.contains('\\') || path.contains('\0') {
        return Err(bad("holds a backslash or NUL"));
    }
    for part in path.split('/') {
        match part {
            "" => return Err(bad("has an empty part (`//` or a trailing `/`)")),
            "." | ".." => return Err(bad("has a `.` or `..` part; bundle paths stay inside the bundle")),
            _ => {}
        }
    }
    Ok(())
}

/// `/`-separated text of a relative path of plain parts.
fn relative_string(rel: &Path) -> Result<String, String> {
    let mut parts = Vec::new();
    for c in rel.components() {
        match c {
            Component::Normal(p) => parts.push(p.to_str().ok_or("is not UTF-8")?.to_string()),
            _ => return Err("is not a plain relative path".into()),
        }
    }
    let s = parts.join("/");
    check_relative(&s).map_err(|e| e.to_string())?;
    Ok(s)
}

/// `path` made absolute (against the working folder) with `.` and `..`
/// resolved lexically (links are checked separately, by canonicalising).
fn absolute(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

/// The TOML key whose string value (a path, or `path:column`) names `file`
/// relative to `dir`.
fn key_referencing(v: &toml::Value, key: String, dir: &Path, file: &Path) -> Option<String> {
    match v {
        toml::Value::String(s) => {
            let candidates = [s.as_str(), s.rsplit_once(':').map(|(p, _)| p).unwrap_or(s)];
            candidates
                .iter()
                .any(|c| !c.is_empty() && absolute(&dir.join(c)) == file)
                .then_some(key)
        }
        toml::Value::Table(t) => t.iter().find_map(|(k, v)| {
            let key = if key.is_empty() {
                k.clone()
            } else {
                format!("{key}.{k}")
            };
            key_referencing(v, key, dir, file)
        }),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, v)| key_referencing(v, format!("{key}[{i}]"), dir, file)),
        _ => None,
    }
}

/// A name part no other unpacker in this or another process uses now.
fn unique() -> String {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    format!("{}.{}", std::process::id(), COUNTER.fetch_add(1, Ordering::Relaxed))
}

#[cfg(test)]
mod tests;
