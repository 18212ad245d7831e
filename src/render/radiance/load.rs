//! Reading a RADIANCE file and everything its inline commands bring in,
//! as one flat stream of placed primitives in file order — what `oconv`
//! would read from the expanded scene.
//!
//! `!xform` and `!genbox` are evaluated here, natively ([`super::xform`],
//! [`super::genbox`]); so is a pipeline of them (`!genbox … | xform -t …`,
//! where each later `xform` transforms the output of the one before).
//! Every other command is refused: lightbooth never runs a program. Files
//! named by `xform` are read relative to the directory of the file that
//! names them. File access goes through [`Source`], so the parsing can be
//! tested without files.

use std::path::{Path, PathBuf};

use glam::DVec3;

use super::genbox::parse_genbox;
use super::lex::command_words;
use super::parse::{parse, Item, RawPrimitive};
use super::xform::{parse_xform, Transform};
use super::RadError;

/// How deep `xform` may nest files (a file that includes itself stops here).
pub const MAX_DEPTH: usize = 16;

/// Most primitives a scene may expand to (arrays multiply them).
pub const MAX_PRIMITIVES: usize = 2_000_000;

/// Where file text comes from.
pub trait Source {
    fn read(&mut self, path: &Path) -> Result<String, String>;
}

/// The file system.
pub struct Files;

impl Source for Files {
    fn read(&mut self, path: &Path) -> Result<String, String> {
        std::fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))
    }
}

/// A primitive where the expanded scene puts it.
#[derive(Clone, Debug)]
pub struct Placed {
    pub prim: RawPrimitive,
    /// The file it was read from, as messages name it.
    pub file: String,
    /// That file's directory (for `specfile` paths).
    pub dir: PathBuf,
    /// Local → scene coordinates.
    pub transform: Transform,
    /// `xform -n` and array prefixes of a surface's identifier.
    pub prefix: String,
    /// `xform -m`: the modifier a surface takes instead of its own.
    pub material: Option<String>,
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
    let mut out = Stream::default();
    let display = path.display().to_string();
    let text = source.read(path).map_err(|m| RadError::new(&display, 0, None, m))?;
    out.files.push(path.to_path_buf());
    expand_text(&text, path, &Context::default(), 0, source, &mut out)?;
    Ok(out)
}

/// What an enclosing `xform` does to a file's primitives.
#[derive(Clone, Debug, Default)]
struct Context {
    transform: Transform,
    prefix: String,
    material: Option<String>,
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

fn expand_text(
    text: &str,
    path: &Path,
    ctx: &Context,
    depth: usize,
    source: &mut dyn Source,
    out: &mut Stream,
) -> Result<(), RadError> {
    let file = path.display().to_string();
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    for item in parse(text, &file)? {
        match item {
            Item::Primitive(prim) => push(out, place(prim, &file, &dir, ctx), &file)?,
            Item::Command { text, line } => {
                let err = |m: String| RadError::new(&file, line, Some(format!("!{}", text.trim())), m);
                let words = command_words(&text).map_err(err)?;
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
                            made.items.push(place(prim, &file, &dir, &Context::default()));
                        }
                    }
                    Some("xform") => {
                        let x = parse_xform(&first[1..]).map_err(|m| err(format!("xform: {m}")))?;
                        if depth + 1 >= MAX_DEPTH {
                            return Err(err(format!(
                                "xform nests deeper than {MAX_DEPTH} files (does a file include itself?)"
                            )));
                        }
                        for f in &x.files {
                            let p = dir.join(f);
                            let sub_text = source.read(&p).map_err(|m| err(format!("xform: {m}")))?;
                            if !made.files.contains(&p) {
                                made.files.push(p.clone());
                            }
                            for (t, prefix) in &x.copies {
                                let c = Context {
                                    transform: *t,
                                    prefix: prefix.clone(),
                                    material: x.material.clone(),
                                };
                                expand_text(&sub_text, &p, &c, depth + 1, source, &mut made)?;
                                if made.items.len() > MAX_PRIMITIVES {
                                    return Err(err(format!("expands to more than {MAX_PRIMITIVES} primitives")));
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
                    let mut next = Vec::new();
                    for (t, prefix) in &x.copies {
                        let c = Context {
                            transform: *t,
                            prefix: prefix.clone(),
                            material: x.material.clone(),
                        };
                        for p in &made.items {
                            next.push(placed_in(p, &c));
                            if next.len() > MAX_PRIMITIVES {
                                return Err(err(format!("expands to more than {MAX_PRIMITIVES} primitives")));
                            }
                        }
                    }
                    made.items = next;
                }
                for p in made.items {
                    push(out, placed_in(&p, ctx), &file)?;
                }
                for f in made.files {
                    if !out.files.contains(&f) {
                        out.files.push(f);
                    }
                }
            }
        }
    }
    Ok(())
}

fn push(out: &mut Stream, p: Placed, file: &str) -> Result<(), RadError> {
    if out.items.len() >= MAX_PRIMITIVES {
        return Err(RadError::new(
            file,
            p.prim.line,
            None,
            format!("the scene expands to more than {MAX_PRIMITIVES} primitives"),
        ));
    }
    out.items.push(p);
    Ok(())
}

fn place(prim: RawPrimitive, file: &str, dir: &Path, ctx: &Context) -> Placed {
    let surface = is_surface(&prim.kind);
    Placed {
        prim,
        file: file.to_string(),
        dir: dir.to_path_buf(),
        transform: ctx.transform,
        prefix: if surface { ctx.prefix.clone() } else { String::new() },
        material: if surface { ctx.material.clone() } else { None },
    }
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
