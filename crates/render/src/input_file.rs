//! Reading a file a scene names — the scene file itself, a spectra CSV, an
//! IES file, an OBJ or PLY mesh, a RADIANCE file, what it `xform`s, a
//! `specfile` — bounded: only a regular file (not a FIFO, a device such as
//! `/dev/zero` or `/dev/urandom`, a socket or a folder), and at most
//! [`MAX_INPUT_BYTES`].
//!
//! The file type is checked before the file is opened (so a FIFO is never
//! opened, and an open cannot wait for a writer), the open itself is
//! non-blocking (`O_NONBLOCK`, in case the path changes between the check
//! and the open), and the opened file is checked again before a byte is
//! read. The read stops one byte past the limit, whatever the file's
//! metadata claims.
//!
//! [`Quoting`] says whether an error may quote a file's content: a file
//! outside the scene's folder (a scene may name `/etc/passwd` as a CSV) is
//! named with its line, never quoted.

use std::fs::{File, OpenOptions};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The largest file a scene may read, bytes (256 MiB: an OBJ of about four
/// million triangles).
pub const MAX_INPUT_BYTES: u64 = 256 << 20;

/// Why a scene input file was not read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("cannot read {path}: {reason}")]
pub struct InputFileError {
    pub path: String,
    pub reason: String,
}

/// Reads `path` whole, refusing anything but a regular file of at most
/// [`MAX_INPUT_BYTES`].
pub fn read_bytes(path: &Path) -> Result<Vec<u8>, InputFileError> {
    read_bounded(path, MAX_INPUT_BYTES)
}

/// [`read_bytes`] as UTF-8 text.
pub fn read_text(path: &Path) -> Result<String, InputFileError> {
    let bytes = read_bytes(path)?;
    String::from_utf8(bytes).map_err(|e| InputFileError {
        path: path.display().to_string(),
        reason: format!(
            "it is not UTF-8 text (byte {} is not valid UTF-8): save it as UTF-8",
            e.utf8_error().valid_up_to() + 1
        ),
    })
}

fn read_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, InputFileError> {
    let err = |reason: String| InputFileError {
        path: path.display().to_string(),
        reason,
    };
    let kind = |m: &std::fs::Metadata| -> Result<(), InputFileError> {
        if m.is_file() {
            return Ok(());
        }
        let what = file_kind(m);
        Err(err(format!(
            "it is {what}, not a regular file; a scene reads only regular files (copy the data into a file)"
        )))
    };
    let too_big = |size: u64| {
        err(format!(
            "it is {size} bytes, more than the {limit} bytes (MAX_INPUT_BYTES) a scene may read from one file"
        ))
    };
    let meta = std::fs::metadata(path).map_err(|e| err(e.to_string()))?;
    kind(&meta)?;
    if meta.len() > limit {
        return Err(too_big(meta.len()));
    }
    let file = open_nonblocking(path).map_err(|e| err(e.to_string()))?;
    let meta = file.metadata().map_err(|e| err(e.to_string()))?;
    kind(&meta)?;
    let mut bytes = Vec::with_capacity(meta.len().min(limit) as usize);
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| err(e.to_string()))?;
    if bytes.len() as u64 > limit {
        return Err(too_big(bytes.len() as u64));
    }
    Ok(bytes)
}

#[cfg(unix)]
fn open_nonblocking(path: &Path) -> std::io::Result<File> {
    use std::os::unix::fs::OpenOptionsExt;
    OpenOptions::new().read(true).custom_flags(libc::O_NONBLOCK).open(path)
}

#[cfg(not(unix))]
fn open_nonblocking(path: &Path) -> std::io::Result<File> {
    OpenOptions::new().read(true).open(path)
}

fn file_kind(m: &std::fs::Metadata) -> &'static str {
    if m.is_dir() {
        return "a folder";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = m.file_type();
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() {
            return "a character device (such as /dev/zero)";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Whether errors about a file may quote its content: only files inside
/// the folder of the scene file that names them (directly or through other
/// files).
#[derive(Clone, Debug)]
pub struct Quoting {
    /// The scene's folder, resolved (`None`: it could not be resolved, and
    /// nothing is quoted).
    root: Option<PathBuf>,
}

impl Quoting {
    /// For a scene whose top file is `scene_file`.
    pub fn for_scene(scene_file: &Path) -> Quoting {
        let dir = scene_file.parent().filter(|d| !d.as_os_str().is_empty());
        let root = std::fs::canonicalize(dir.unwrap_or(Path::new(".")));
        Quoting { root: root.ok() }
    }

    /// Quote everything (for tests of text held in memory).
    #[cfg(test)]
    pub fn everything() -> Quoting {
        Quoting {
            root: Some(PathBuf::from("/")),
        }
    }

    /// True when `path` lies inside the scene's folder (after resolving
    /// `..` and symbolic links).
    pub fn may_quote(&self, path: &Path) -> bool {
        let Some(root) = &self.root else { return false };
        if root == Path::new("/") {
            return true;
        }
        match std::fs::canonicalize(path) {
            Ok(real) => real.starts_with(root),
            Err(_) => false,
        }
    }
}

/// What an error about a file outside the scene's folder says instead of
/// quoting it.
pub fn unquoted(what: &str) -> String {
    format!(
        "{what} (the file is outside the scene's folder, so its content is not quoted here: \
         check that the scene names the file it means)"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_files_are_read_and_others_refused() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.csv");
        std::fs::write(&f, "nm,x\n380,1\n").unwrap();
        assert_eq!(read_text(&f).unwrap(), "nm,x\n380,1\n");
        let e = read_text(dir.path()).unwrap_err().to_string();
        assert!(e.contains("a folder, not a regular file"), "{e}");
        let e = read_text(Path::new("/dev/zero")).unwrap_err().to_string();
        assert!(e.contains("/dev/zero") && e.contains("character device"), "{e}");
        let e = read_bounded(&f, 4).unwrap_err().to_string();
        assert!(e.contains("more than the 4 bytes"), "{e}");
        std::fs::write(&f, [0xff, 0xfe, b'a']).unwrap();
        assert!(read_text(&f).unwrap_err().to_string().contains("not UTF-8"));
    }

    #[test]
    fn quoting_is_for_files_inside_the_scene_folder() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("spectra")).unwrap();
        let scene = dir.path().join("s.toml");
        let inside = dir.path().join("spectra/a.csv");
        std::fs::write(&scene, "").unwrap();
        std::fs::write(&inside, "").unwrap();
        let q = Quoting::for_scene(&scene);
        assert!(q.may_quote(&inside));
        assert!(!q.may_quote(Path::new("/etc/passwd")));
        assert!(!q.may_quote(&dir.path().join("spectra/../../x")));
    }
}
