//! Reading a RADIANCE file and everything its inline commands bring in,
//! as one flat stream of placed primitives in file order — what `oconv`
//! would read from the expanded scene.
//!
//! `!xform` and `!genbox` are evaluated here, natively ([`super::xform`],
//! [`super::genbox`]); so is a pipeline of them (`!genbox … | xform -t …`,
//! where each later `xform` transforms the output of the one before).
//! Every other command is refused: lightbooth never runs a program. Files
//! named by `xform` are read relative to the directory of the file that
//! names them, each once: a file's expansion does not depend on where it
//! is placed, so `xform -a N` places N copies of one expansion (work
//! linear in N, not N expansions). File access goes through [`Source`], so
//! the parsing can be tested without files; [`Files`] reads only regular
//! files of at most [`MAX_INPUT_BYTES`](crate::input_file::MAX_INPUT_BYTES).
//!
//! Limits (errors naming the file, the line and the limit, not clamps):
//! - [`MAX_DEPTH`] (16) files nested by `xform` (a file that includes
//!   itself stops here);
//! - [`MAX_PRIMITIVES`] (2 000 000) primitives in the expanded scene (arrays
//!   multiply them), and as many renderer primitives once converted;
//! - [`MAX_PLACEMENTS`] (2 000 000) copies of files placed by all the
//!   scene's `xform`s together (an array of an empty file, or arrays nested
//!   through files, cost work without adding primitives);
//! - [`super::xform::MAX_COPIES`] (100 000) copies made by one `xform`.
//!
//! Errors about a file outside the scene's folder name the file and the
//! line but do not quote it ([`crate::input_file::Quoting`]).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use glam::DVec3;

use super::genbox::parse_genbox;
use super::lex::command_words;
use super::parse::{parse, Item, RawPrimitive};
use super::xform::{parse_xform, Transform};
use super::RadError;
use crate::input_file::{read_text, unquoted, Quoting};

/// How deep `xform` may nest files (a file that includes itself stops here).
pub const MAX_DEPTH: usize = 16;

/// Most primitives a scene may expand to (arrays multiply them), and most
/// renderer primitives (triangles, spheres, …) it may convert to.
pub const MAX_PRIMITIVES: usize = 2_000_000;

/// Most copies of files the `xform`s of one scene may place, all together.
pub const MAX_PLACEMENTS: u64 = 2_000_000;

/// The longest identifier prefix nested `xform -n` and arrays may build, bytes.
pub const MAX_PREFIX_BYTES: usize = 256;

/// Where file text comes from.
pub trait Source {
    fn read(&mut self, path: &Path) -> Result<String, String>;

    /// Whether errors about `path` may quote its content.
    fn may_quote(&self, _path: &Path) -> bool {
        true
    }
}

/// The file system: regular files only, bounded in size; files outside
/// the scene's folder are not quoted in errors.
pub struct Files {
    pub quoting: Quoting,
}

impl Source for Files {
    fn read(&mut self, path: &Path) -> Result<String, String> {
        read_text(path).map_err(|e| e.to_string())
    }

    fn may_quote(&self, path: &Path) -> bool {
        self.quoting.may_quote(path)
    }
}

/// A primitive where the expanded scene puts it.
#[derive(Clone, Debug)]
pub struct Placed {
    /// Shared by every copy an `xform` array makes.
    pub prim: Rc<RawPrimitive>,
    /// The file it was read from, as messages name it.
    pub file: Rc<str>,
    /// That file's directory (for `specfile` paths).
    pub dir: Rc<Path>,
    /// Whether errors about it may quote the file (see [`Source::may_quote`]).
    pub quote: bool,
    /// Local → scene coordinates.
    pub transform: Transform,
    /// `xform -n` and array prefixes of a surface's identifier.
    pub prefix: String,
    /// `xform -m`: the modifier a surface takes instead of its own.
    pub material: Option<Rc<str>>,
}

impl Placed {
    /// The identifier as `xform` would have written it (surfaces only).
    pub fn id(&self) -> String {
        format!("{}{}", self.prefix, self.prim.id)
    }

    /// The modifier in effect.
    pub fn modifier(&self) -> &str {
        self.material.as_deref().unwrap_or(&self.prim.modifier)
    }

    pub fn err(&self, message: impl Into<String>) -> RadError {
        if !self.quote {
            return RadError::new(
                &self.file,
                self.prim.line,
                None,
                unquoted("a primitive lightbooth cannot import"),
            );
        }
        RadError::new(
            &self.file,
            self.prim.line,
            Some(format!("{} {}", self.prim.kind, self.id())),
            message,
        )
    }
}

/// The expanded scene: its primitives and every file read.
#[derive(Debug, Default)]
pub struct Stream {
    pub items: Vec<Placed>,
    pub files: Vec<PathBuf>,
}

/// True for the primitive types that are surfaces (everything else modifies).
pub fn is_surface(kind: &str) -> bool {
    matches!(
        kind,
        "polygon"
            | "sphere"
            | "bubble"
            | "cylinder"
            | "tube"
            | "cone"
            | "cup"
            | "ring"
            | "source"
            | "instance"
            | "mesh"
    )
}

/// Reads `path` and everything it includes.
pub fn expand(path: &Path, source: &mut dyn Source) -> Result<Stream, RadError> {
    let display = path.display().to_string();
    let text = source.read(path).map_err(|m| RadError::new(&display, 0, None, m))?;
    let mut x = Expander {
        source,
        placements: 0,
        expanded: HashMap::new(),
    };
    let mut out = Stream::default();
    out.files.push(path.to_path_buf());
    x.expand_text(&text, path, &Context::default(), 0, &mut out)?;
    Ok(out)
}

/// What an enclosing `xform` does to a file's primitives.
#[derive(Clone, Debug, Default)]
struct Context {
    transform: Transform,
    prefix: String,
    material: Option<Rc<str>>,
}

impl Context {
    /// `inner` (a command inside this context) placed by this context.
    fn around(&self, inner: &Context) -> Context {
        Context {
            transform: inner.transform.then(&self.transform),
            prefix: format!("{}{}", self.prefix, inner.prefix),
            // The outer -m wins, as piping through a second xform -m would.
            material: self.material.clone().or_else(|| inner.material.clone()),
        }
    }
}

/// One expansion of a scene: the files expanded so far and the work done.
struct Expander<'a> {
    source: &'a mut dyn Source,
    /// Copies of files placed so far (bounded by [`MAX_PLACEMENTS`]).
    placements: u64,
    /// Each file's expansion where it stands (identity placement), by path:
    /// a file named again (by another copy, command or file) is not read,
    /// parsed or expanded again.
    expanded: HashMap<PathBuf, Rc<Stream>>,
}

impl Expander<'_> {
    /// The expansion of the file `p` in place, read once; `err` frames a
    /// failure to read it.
    fn file(&mut self, p: &Path, depth: usize, err: &dyn Fn(String) -> RadError) -> Result<Rc<Stream>, RadError> {
        if let Some(s) = self.expanded.get(p) {
            return Ok(s.clone());
        }
        let text = self.source.read(p).map_err(|m| err(format!("xform: {m}")))?;
        let mut sub = Stream::default();
        sub.files.push(p.to_path_buf());
        self.expand_text(&text, p, &Context::default(), depth, &mut sub)?;
        let sub = Rc::new(sub);
        self.expanded.insert(p.to_path_buf(), sub.clone());
        Ok(sub)
    }

    fn expand_text(
        &mut self,
        text: &str,
        path: &Path,
        ctx: &Context,
        depth: usize,
        out: &mut Stream,
    ) -> Result<(), RadError> {
        let file = path.display().to_string();
        let file_rc: Rc<str> = Rc::from(file.as_str());
        let dir: Rc<Path> = Rc::from(path.parent().unwrap_or(Path::new("")));
        let quote = self.source.may_quote(path);
        let items = parse(text, &file).map_err(|e| {
            if quote {
                e
            } else {
                RadError::new(
                    &file,
                    e.line,
                    None,
                    unquoted("not a RADIANCE scene lightbooth can read"),
                )
            }
        })?;
        for item in items {
            match item {
                Item::Primitive(prim) => {
                    let placed = Placed {
                        prim: Rc::new(prim),
                        file: file_rc.clone(),
                        dir: dir.clone(),
                        quote,
                        transform: Transform::IDENTITY,
                        prefix: String::new(),
                        material: None,
                    };
                    push(out, placed_in(&placed, ctx), &file)?
                }
                Item::Command { text, line } => {
                    let err = |m: String| {
                        if quote {
                            RadError::new(&file, line, Some(format!("!{}", text.trim())), m)
                        } else {
                            RadError::new(
                                &file,
                                line,
                                None,
                                unquoted("an inline command lightbooth cannot evaluate"),
                            )
                        }
                    };
                    let made = self.command(&text, line, &file_rc, &dir, quote, depth, &err)?;
                    for p in &made.items {
                        push(out, placed_in(p, ctx), &file)?;
                    }
                    for f in &made.files {
                        if !out.files.contains(f) {
                            out.files.push(f.clone());
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// One shared budget of placed file copies for the whole scene.
    fn place_copies(&mut self, n: u64, err: &dyn Fn(String) -> RadError) -> Result<(), RadError> {
        self.placements += n;
        if self.placements > MAX_PLACEMENTS {
            return Err(err(format!(
                "the scene's xforms place more than {MAX_PLACEMENTS} copies of files in all (MAX_PLACEMENTS): \
                 use fewer or smaller arrays (-a), or fewer levels of arrays nested through files"
            )));
        }
        Ok(())
    }

    /// The primitives an inline command makes, in the command's file's coordinates.
    #[allow(clippy::too_many_arguments)]
    fn command(
        &mut self,
        text: &str,
        line: usize,
        file: &Rc<str>,
        dir: &Rc<Path>,
        quote: bool,
        depth: usize,
        err: &dyn Fn(String) -> RadError,
    ) -> Result<Stream, RadError> {
        let words = command_words(text).map_err(err)?;
        let stages: Vec<&[String]> = words.split(|w| w == "|").collect();
        if let Some(w) = words
            .iter()
            .find(|w| w.contains(['<', '>', '`', '$', ';', '&']) || (w.contains('|') && *w != "|"))
        {
            return Err(err(format!(
                "`{w}`: redirections, substitutions and command lists are not evaluated \
                 (lightbooth runs no programs; it evaluates xform and genbox, alone or piped)"
            )));
        }
        let too_many = || {
            err(format!(
                "expands to more than {MAX_PRIMITIVES} primitives (MAX_PRIMITIVES): use fewer or smaller arrays (-a)"
            ))
        };
        // The first stage makes primitives; later stages are xforms of them.
        let mut made = Stream::default();
        let first = stages[0];
        match first.first().map(String::as_str) {
            Some("genbox") => {
                let g = parse_genbox(&first[1..]).map_err(|m| err(format!("genbox: {m}")))?;
                for (suffix, v) in g.faces() {
                    let reals = v.iter().flat_map(|p| p.to_array()).collect();
                    let prim = RawPrimitive {
                        modifier: g.material.clone(),
                        kind: "polygon".into(),
                        id: format!("{}.{suffix}", g.name),
                        strings: vec![],
                        integers: vec![],
                        reals,
                        line,
                    };
                    made.items.push(Placed {
                        prim: Rc::new(prim),
                        file: file.clone(),
                        dir: dir.clone(),
                        quote,
                        transform: Transform::IDENTITY,
                        prefix: String::new(),
                        material: None,
                    });
                }
            }
            Some("xform") => {
                let x = parse_xform(&first[1..]).map_err(|m| err(format!("xform: {m}")))?;
                if depth + 1 >= MAX_DEPTH {
                    return Err(err(format!(
                        "xform nests deeper than {MAX_DEPTH} files (MAX_DEPTH; does a file include itself?)"
                    )));
                }
                for f in &x.files {
                    let p = dir.join(f);
                    self.place_copies(x.copies.len() as u64, err)?;
                    let sub = self.file(&p, depth + 1, err)?;
                    if made.items.len() + x.copies.len() * sub.items.len() > MAX_PRIMITIVES {
                        return Err(too_many());
                    }
                    let material: Option<Rc<str>> = x.material.as_deref().map(Rc::from);
                    let longest = sub.items.iter().map(|q| q.prefix.len()).max().unwrap_or(0);
                    for (t, prefix) in &x.copies {
                        long_prefix(longest + prefix.len(), err)?;
                        let c = Context {
                            transform: *t,
                            prefix: prefix.clone(),
                            material: material.clone(),
                        };
                        made.items.extend(sub.items.iter().map(|q| placed_in(q, &c)));
                    }
                    for f in &sub.files {
                        if !made.files.contains(f) {
                            made.files.push(f.clone());
                        }
                    }
                }
            }
            Some(other) => {
                return Err(err(format!(
                    "the command `{other}` is not evaluated: lightbooth runs no programs and \
                     evaluates only `xform` and `genbox`; run it once and include its output \
                     (e.g. `{other} … > part.rad`, then `!xform part.rad`)"
                )))
            }
            None => return Err(err("an empty command".into())),
        }
        for stage in &stages[1..] {
            if stage.first().map(String::as_str) != Some("xform") {
                return Err(err(format!(
                    "a pipe into `{}`: only `xform` may follow a pipe",
                    stage.first().map(String::as_str).unwrap_or("")
                )));
            }
            let mut args = stage[1..].to_vec();
            // The files of a piped xform are its standard input.
            args.push("(stdin)".into());
            let x = parse_xform(&args).map_err(|m| err(format!("xform: {m}")))?;
            if x.files.len() > 1 {
                return Err(err("xform after a pipe reads the pipe; it names no files".into()));
            }
            self.place_copies(x.copies.len() as u64, err)?;
            if x.copies.len() * made.items.len() > MAX_PRIMITIVES {
                return Err(too_many());
            }
            let mut next = Vec::with_capacity(x.copies.len() * made.items.len());
            let material: Option<Rc<str>> = x.material.as_deref().map(Rc::from);
            let longest = made.items.iter().map(|q| q.prefix.len()).max().unwrap_or(0);
            for (t, prefix) in &x.copies {
                long_prefix(longest + prefix.len(), err)?;
                let c = Context {
                    transform: *t,
                    prefix: prefix.clone(),
                    material: material.clone(),
                };
                next.extend(made.items.iter().map(|p| placed_in(p, &c)));
            }
            made.items = next;
        }
        Ok(made)
    }
}

fn long_prefix(bytes: usize, err: &dyn Fn(String) -> RadError) -> Result<(), RadError> {
    if bytes > MAX_PREFIX_BYTES {
        return Err(err(format!(
            "the nested `-n` names and array indices make identifiers longer than {MAX_PREFIX_BYTES} bytes \
             (MAX_PREFIX_BYTES): use shorter names"
        )));
    }
    Ok(())
}

fn push(out: &mut Stream, p: Placed, file: &str) -> Result<(), RadError> {
    if out.items.len() >= MAX_PRIMITIVES {
        return Err(RadError::new(
            file,
            p.prim.line,
            None,
            format!(
                "the scene expands to more than {MAX_PRIMITIVES} primitives (MAX_PRIMITIVES): use fewer or \
                 smaller arrays (-a)"
            ),
        ));
    }
    out.items.push(p);
    Ok(())
}

/// `p` (already placed by inner commands) placed further by `ctx`.
fn placed_in(p: &Placed, ctx: &Context) -> Placed {
    let surface = is_surface(&p.prim.kind);
    let inner = Context {
        transform: p.transform,
        prefix: p.prefix.clone(),
        material: p.material.clone(),
    };
    let c = ctx.around(&inner);
    Placed {
        transform: c.transform,
        prefix: if surface { c.prefix } else { String::new() },
        material: if surface { c.material } else { None },
        ..p.clone()
    }
}

/// A polygon's vertices in scene coordinates (order kept; reversed under a
/// mirror so the front side stays the front side).
pub fn placed_vertices(p: &Placed, reals: &[f64]) -> Vec<DVec3> {
    let mut v: Vec<DVec3> = reals
        .chunks(3)
        .map(|c| p.transform.point(DVec3::new(c[0], c[1], c[2])))
        .collect();
    if p.transform.mirrored {
        v.reverse();
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Files held in memory.
    struct Memory(HashMap<PathBuf, String>);

    impl Source for Memory {
        fn read(&mut self, path: &Path) -> Result<String, String> {
            self.0
                .get(path)
                .cloned()
                .ok_or_else(|| format!("cannot read {}: no such file", path.display()))
        }
    }

    fn memory(files: &[(&str, &str)]) -> Memory {
        Memory(files.iter().map(|(p, t)| (PathBuf::from(p), t.to_string())).collect())
    }

    fn polygons(s: &Stream) -> Vec<(String, Vec<DVec3>)> {
        s.items
            .iter()
            .filter(|p| p.prim.kind == "polygon")
            .map(|p| (p.id(), placed_vertices(p, &p.prim.reals)))
            .collect()
    }

    /// A nested xform of a file relative to the including file, and a
    /// genbox piped through xform: vertices computed by hand.
    #[test]
    fn nested_xform_and_piped_genbox_place_vertices_as_computed_by_hand() {
        let mut src = memory(&[
            ("scene/main.rad", "void plastic m 0 0 5 .5 .5 .5 0 0\n!xform -n outer -t 10 0 0 parts/a.rad\n!genbox m box 1 2 3 | xform -rz 90 -t 0 0 1\n"),
            ("scene/parts/a.rad", "!xform -n inner -s 2 tri.rad\n"),
            ("scene/parts/tri.rad", "m polygon t 0 0 9 1 0 0 0 1 0 0 0 1\n"),
        ]);
        let s = expand(Path::new("scene/main.rad"), &mut src).unwrap();
        assert_eq!(s.files.len(), 3, "{:?}", s.files);
        let p = polygons(&s);
        assert_eq!(p.len(), 7);
        // Scaled by 2, then moved by (10, 0, 0).
        assert_eq!(p[0].0, "outer.inner.t");
        assert_eq!(
            p[0].1,
            [
                DVec3::new(12.0, 0.0, 0.0),
                DVec3::new(10.0, 2.0, 0.0),
                DVec3::new(10.0, 0.0, 2.0)
            ]
        );
        // genbox face 1540: (1,0,0) (1,0,3) (0,0,3) (0,0,0), rotated by 90° about z
        // ((x, y) → (−y, x)), then lifted by 1.
        assert_eq!(p[1].0, "box.1540");
        let want = [
            DVec3::new(0.0, 1.0, 1.0),
            DVec3::new(0.0, 1.0, 4.0),
            DVec3::new(0.0, 0.0, 4.0),
            DVec3::new(0.0, 0.0, 1.0),
        ];
        for (g, w) in p[1].1.iter().zip(want) {
            assert!((*g - w).length() < 1e-12, "{g} vs {w}");
        }
    }

    #[test]
    fn a_mirror_reverses_polygons_and_materials_keep_their_names() {
        let mut src = memory(&[
            ("m.rad", "!xform -n k -mx t.rad"),
            (
                "t.rad",
                "void plastic m 0 0 5 .5 .5 .5 0 0\nm polygon t 0 0 9 1 0 0 0 1 0 0 0 1\n",
            ),
        ]);
        let s = expand(Path::new("m.rad"), &mut src).unwrap();
        assert_eq!(s.items[0].id(), "m");
        assert_eq!(s.items[1].id(), "k.t");
        assert_eq!(
            placed_vertices(&s.items[1], &s.items[1].prim.reals),
            [
                DVec3::new(0.0, 0.0, 1.0),
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(-1.0, 0.0, 0.0)
            ]
        );
    }

    #[test]
    fn commands_that_run_programs_are_refused_with_file_line_and_what_to_do() {
        for (text, want) in [
            (
                "\n!gensky 3 21 12",
                "main.rad:2: !gensky 3 21 12: the command `gensky` is not evaluated",
            ),
            (
                "!xform -t 1 0 0 missing.rad",
                "main.rad:1: !xform -t 1 0 0 missing.rad: xform: cannot read",
            ),
            ("!genbox m b 1 1 1 > x.rad", "redirections"),
            ("!genbox m b 1 1 1 | rcalc -e x", "only `xform` may follow a pipe"),
            ("!xform self.rad", "nests deeper"),
        ] {
            let mut src = memory(&[("main.rad", text), ("self.rad", "!xform self.rad")]);
            let e = expand(Path::new("main.rad"), &mut src).unwrap_err().to_string();
            assert!(e.contains(want), "{text}: {e}");
        }
    }
}
