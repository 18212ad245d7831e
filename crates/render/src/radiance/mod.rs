//! Importing RADIANCE scene files (`.rad`): the surfaces, materials and
//! inline commands vision labs' RADIANCE scenes use, turned into the
//! renderer's [`Material`]s, [`Primitive`]s and [`Emitter`]s.
//!
//! Read: comments, multi-line arguments, `void`, modifier chains; the
//! surfaces `polygon`, `sphere`, `bubble`, `cylinder`, `tube`, `cone`,
//! `cup`, `ring`; the materials `plastic`, `metal`, `mirror`, `light`,
//! `glow`, `spotlight`; RADIANCE 6's `spectrum` and `specfile` as colour modifiers of
//! those materials; the inline commands `!xform` and `!genbox`, evaluated
//! natively (alone or piped into `xform`). Everything else — patterns and
//! textures with `.cal` or data files (`brightfunc`, `brightdata`,
//! `colorfunc`, …), other materials (`glass`, `trans`, `BSDF`, …),
//! `instance`, `mesh`, `source` and every other command — is
//! refused with the file, line and primitive and what to do instead.
//! (Reference: G. Ward, "The RADIANCE 6.0 Synthetic Imaging System",
//! `ray.html`, and the `xform(1)` and `genbox(1)` manual pages.)
//!
//! The submodules, by concern: `lex` (words, comments, command lines),
//! `parse` (primitives and commands, no meaning), `xform` and `genbox`
//! (the two commands), `load` (files, commands expanded into one stream),
//! `convert` (the stream as materials, shapes and emitters), `tessellate`
//! (triangles for what has no analytic shape, and for emitters) and
//! `colour` (RGB as exact `rgb`-coding colours plus synthesised spectra).
//!
//! Coordinates are in the file's units, multiplied by `metres_per_unit` at
//! load. Every number must be a finite number, and stay one once placed
//! and converted (a `light` of `1e308` × 179 lm/W, or a vertex × `xform
//! -s 1e300`, is an error naming the file, line and primitive).
//!
//! Limits: see `load`'s — at most [`MAX_DEPTH`] files nested, [`MAX_PRIMITIVES`]
//! primitives, [`MAX_PLACEMENTS`] file copies placed by all `xform`s,
//! [`MAX_COPIES`] copies and [`MAX_ARRAYS`] arrays per `xform`; files are read
//! only if regular and at most
//! [`MAX_INPUT_BYTES`](crate::input_file::MAX_INPUT_BYTES).

mod colour;
mod convert;
mod genbox;
mod lex;
mod load;
mod parse;
mod tessellate;
mod xform;

use std::path::{Path, PathBuf};

pub use colour::{RADIANCE_EFFICACY, SYNTHESIS_METHOD};

use super::input_file::Quoting;
use super::scene::{Emitter, Material, Primitive};

/// An error in a RADIANCE file: the file, the line (0: the file as a
/// whole), the primitive or command, and what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}:{line}: {}{message}", primitive.as_ref().map(|p| format!("{p}: ")).unwrap_or_default())]
pub struct RadError {
    pub file: String,
    pub line: usize,
    /// `type identifier` of the primitive, or `!command …`.
    pub primitive: Option<String>,
    pub message: String,
}

impl RadError {
    pub fn new(file: &str, line: usize, primitive: Option<String>, message: impl Into<String>) -> RadError {
        RadError {
            file: file.to_string(),
            line,
            primitive,
            message: message.into(),
        }
    }
}

/// What a RADIANCE file contributes to a scene. Material and emitter
/// indices in `primitives` are into this struct's own lists.
#[derive(Debug, Default)]
pub struct RadianceScene {
    pub materials: Vec<Material>,
    pub primitives: Vec<Primitive>,
    pub emitters: Vec<Emitter>,
    /// Every file read (the scene file, `xform`'d files, `specfile`s).
    pub files: Vec<PathBuf>,
}

pub use load::{MAX_DEPTH, MAX_PLACEMENTS, MAX_PREFIX_BYTES, MAX_PRIMITIVES};
pub use xform::{MAX_ARRAYS, MAX_COPIES, MAX_NAME_BYTES};

/// Reads a RADIANCE scene file and everything it includes; `quoting` says
/// which files errors may quote (those in the scene's folder).
pub fn load_radiance(path: &Path, metres_per_unit: f64, quoting: &Quoting) -> Result<RadianceScene, RadError> {
    let mut files = load::Files {
        quoting: quoting.clone(),
    };
    let stream = load::expand(path, &mut files)?;
    convert::convert(stream, metres_per_unit, &mut files)
}
