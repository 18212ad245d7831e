//! The expanded stream of a RADIANCE scene ([`super::load`]) as the
//! renderer's materials, primitives and emitters.
//!
//! Modifiers are looked up as `oconv` does: by identifier, among those
//! defined earlier in the stream (a later definition of the same name
//! replaces it for what follows).
//!
//! - `plastic`, `metal` (5 reals: r g b specularity roughness) and `mirror`
//!   (3 reals: r g b) become [`Material`]s with [`Surface::Plastic`],
//!   [`Surface::Metal`] and [`Surface::Mirror`]; colour components,
//!   specularity must lie in [0, 1] (reflectances are physical), roughness ≥ 0.
//! - `light` (r g b) and `glow` (r g b maxrad, maxrad ≥ 0) become
//!   one-sided Lambertian [`Emitter`]s on the surface's front side, as
//!   RADIANCE's light sources are. RGB radiance (r, g, b) in RADIANCE's
//!   W/(sr·m²) gives `rgb` = 179·(r, g, b) (RADIANCE's 179 lm/W) and a
//!   synthesised spectrum ([`super::colour`]). A glow with negative maxrad
//!   (never illuminates anything in RADIANCE) is refused; maxrad ≥ 0 only
//!   changes how RADIANCE samples it, not the light it gives.
//!   Emitting surfaces are triangles ([`super::tessellate`]) of a black
//!   material: a RADIANCE light reflects nothing.
//! - `spotlight` (r g b angle xdir ydir zdir) is a `light` whose emission is
//!   cut to the cone of full angle `angle` about (xdir, ydir, zdir), and
//!   whose light reaching a surface at distance d falls off as
//!   d²/(d + flen)², flen = |(xdir, ydir, zdir)| (the focus behind the
//!   source), as RADIANCE evaluates it ([`Spot`]). The vector is transformed
//!   with the material (rotated and scaled, as `xform` does) and flen is in
//!   the file's units like every length.
//! - `spectrum` (nmA nmB s₁ … s_N, N ≥ 3: multipliers at N evenly spaced
//!   wavelengths from nmA to nmB, zero outside, linearly interpolated) and
//!   `specfile` (one string: a file of `wavelength value` pairs, or a
//!   RADIANCE 1-D data file `1` / `nmA nmB N` / N values) colour a material
//!   that names them as its modifier. Its RGB must then be a grey k: the
//!   material's spectrum is k·s(λ) (RADIANCE multiplies the two; lightbooth
//!   does not invent a spectrum for a coloured RGB to multiply), and the
//!   `rgb` coding derives its RGB from that spectrum like any spectral
//!   material's. For `light`/`glow`, L(λ) = k·s(λ)·179/(683·Σȳ·1 nm).
//! - Surfaces: `polygon` (fan triangles), `sphere`/`bubble` (analytic
//!   sphere), `cylinder`/`tube` (analytic open cylinder), `ring` (analytic
//!   disc when its inner radius is 0), `cone`/`cup` and rings with a hole
//!   (triangles); surfaces are two-sided in the renderer, so `bubble` and
//!   `tube` differ from `sphere` and `cylinder` only when they emit.

use std::collections::HashMap;

use glam::DVec3;

use super::colour::{emission_from_rgb, emission_from_spectrum, fit_reflectance, RADIANCE_EFFICACY};
use super::load::{is_surface, placed_vertices, Placed, Source, Stream, MAX_PRIMITIVES};
use super::tessellate::{self, Triangle};
use super::{RadError, RadianceScene};
use crate::geometry::Shape;
use crate::input_file::unquoted;
use crate::scene::{Emitter, Material, Primitive, Spot, Surface};
use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};

/// A defined modifier.
#[derive(Clone, Debug)]
enum Modifier {
    /// A `spectrum` or `specfile`: multipliers on the 1 nm grid.
    Colour(Spectrum),
    /// A reflecting material: index into the materials.
    Reflecting(usize),
    /// A `light` or `glow`: index into the emitters.
    Emitting(usize),
}

struct Converter<'a> {
    out: RadianceScene,
    modifiers: HashMap<String, Modifier>,
    black: Option<usize>,
    metres_per_unit: f64,
    source: &'a mut dyn Source,
}

pub fn convert(stream: Stream, metres_per_unit: f64, source: &mut dyn Source) -> Result<RadianceScene, RadError> {
    let mut c = Converter {
        out: RadianceScene {
            files: stream.files,
            ..Default::default()
        },
        modifiers: HashMap::new(),
        black: None,
        metres_per_unit,
        source,
    };
    for p in &stream.items {
        if !p.prim.integers.is_empty() {
            return Err(p.err(format!(
                "has {} integer arguments; no primitive lightbooth reads takes any",
                p.prim.integers.len()
            )));
        }
        if is_surface(&p.prim.kind) {
            c.surface(p)?;
        } else {
            let m = c.define(p)?;
            c.modifiers.insert(p.prim.id.clone(), m);
        }
    }
    Ok(c.out)
}

fn count(p: &Placed, strings: usize, reals: &[usize]) -> Result<(), RadError> {
    if p.prim.strings.len() != strings || !reals.contains(&p.prim.reals.len()) {
        let want = reals.iter().map(|r| r.to_string()).collect::<Vec<_>>().join(" or ");
        return Err(p.err(format!(
            "takes {strings} string and {want} real arguments, has {} and {}",
            p.prim.strings.len(),
            p.prim.reals.len()
        )));
    }
    Ok(())
}

const PATTERN_HINT: &str = "patterns, textures and mixtures (functions in .cal files, data files, pictures) are \
     not supported: give the colour as the material's RGB or a `spectrum`/`specfile`; for a luminaire's \
     intensity distribution, give the luminaire as an IES file in a TOML scene (`[[light]] ies = \"….ies\"`) \
     next to `[[radiance]] file = …`";

impl Converter<'_> {
    fn define(&mut self, p: &Placed) -> Result<Modifier, RadError> {
        let kind = p.prim.kind.as_str();
        match kind {
            "plastic" | "metal" | "mirror" => {
                if kind == "mirror" && p.prim.strings.len() == 1 {
                    return Err(p.err("a mirror with an alternate material (a string argument) is not supported"));
                }
                count(p, 0, if kind == "mirror" { &[3] } else { &[5] })?;
                let r = &p.prim.reals;
                let rgb = [r[0], r[1], r[2]];
                for (v, what) in rgb.iter().zip(["red", "green", "blue"]) {
                    if !(0.0..=1.0).contains(v) {
                        return Err(p.err(format!(
                            "the {what} reflectance {v} is outside [0, 1] (lightbooth's reflectances are physical)"
                        )));
                    }
                }
                let surface = match kind {
                    "mirror" => Surface::Mirror,
                    _ => {
                        let (specularity, roughness) = (r[3], r[4]);
                        if !(0.0..=1.0).contains(&specularity) {
                            return Err(p.err(format!("specularity {specularity} is outside [0, 1]")));
                        }
                        if roughness < 0.0 {
                            return Err(p.err(format!("roughness {roughness} is negative")));
                        }
                        if kind == "plastic" {
                            Surface::Plastic { specularity, roughness }
                        } else {
                            Surface::Metal { specularity, roughness }
                        }
                    }
                };
                let (reflectance, rgb_exact) = match self.colour_of(p)? {
                    None => {
                        let (shape, residual) = fit_reflectance(rgb);
                        if residual > 1e-4 {
                            tracing::warn!(
                                "{}:{}: {kind} {}: no smooth reflectance has RGB {rgb:?}; the synthesised spectrum \
                                 misses it by {residual:.4} (the rgb coding uses the RGB exactly)",
                                p.file,
                                p.prim.line,
                                p.prim.id
                            );
                        }
                        let spectrum = shape.on_1nm(SpectralUnit::Reflectance, 1.0).map_err(|m| p.err(m))?;
                        (spectrum, Some(rgb))
                    }
                    Some(s) => {
                        let k = grey(p, rgb)?;
                        let values: Vec<f64> = s.values().iter().map(|v| v * k).collect();
                        if let Some(v) = values.iter().find(|v| **v > 1.0) {
                            return Err(p.err(format!(
                                "grey {k} × its spectrum reaches {v}, above 1: a reflectance must stay in [0, 1]"
                            )));
                        }
                        let spectrum = Spectrum::new(Grid::one_nm(), SpectralUnit::Reflectance, values)
                            .map_err(|e| p.err(e.to_string()))?;
                        (spectrum, None)
                    }
                };
                self.out.materials.push(Material {
                    name: p.prim.id.clone(),
                    reflectance,
                    surface,
                    rgb: rgb_exact,
                });
                Ok(Modifier::Reflecting(self.out.materials.len() - 1))
            }
            "light" | "glow" | "spotlight" => {
                count(
                    p,
                    0,
                    match kind {
                        "light" => &[3],
                        "glow" => &[4],
                        _ => &[7],
                    },
                )?;
                let r = &p.prim.reals;
                let rgb = [r[0], r[1], r[2]];
                if rgb.iter().any(|v| *v < 0.0) {
                    return Err(p.err(format!("a negative radiance {rgb:?}")));
                }
                if kind == "glow" && r[3] < 0.0 {
                    return Err(p.err(format!(
                        "maxrad {} < 0: RADIANCE lets such a glow illuminate nothing, which a physical \
                         emitter cannot do; use maxrad = 0 (it then lights the scene)",
                        r[3]
                    )));
                }
                let (radiance, rgb_exact) = match self.colour_of(p)? {
                    None => {
                        let (spectrum, _) = emission_from_rgb(rgb).map_err(|m| p.err(m))?;
                        (spectrum, Some(rgb.map(|v| v * RADIANCE_EFFICACY)))
                    }
                    Some(s) => (emission_from_spectrum(grey(p, rgb)?, &s).map_err(|m| p.err(m))?, None),
                };
                let spot = if kind == "spotlight" { Some(self.spot(p)?) } else { None };
                self.out.emitters.push(Emitter {
                    name: format!("{kind} {} ({}:{})", p.prim.id, p.file, p.prim.line),
                    radiance,
                    two_sided: false,
                    rgb: rgb_exact,
                    spot,
                });
                Ok(Modifier::Emitting(self.out.emitters.len() - 1))
            }
            "spectrum" => {
                self.void_modifier(p)?;
                let r = &p.prim.reals;
                if !p.prim.strings.is_empty() || r.len() < 5 {
                    return Err(p.err("takes 0 strings and 5 or more reals: nmA nmB s1 s2 s3 …"));
                }
                let (a, b) = (r[0], r[1]);
                if a == b || a <= 0.0 || b <= 0.0 {
                    return Err(p.err(format!("the wavelength range {a}–{b} nm is empty or not positive")));
                }
                let n = r.len() - 2;
                let samples: Vec<(f64, f64)> = (0..n)
                    .map(|i| (a + (b - a) * i as f64 / (n - 1) as f64, r[2 + i]))
                    .collect();
                Ok(Modifier::Colour(multipliers(p, samples)?))
            }
            "specfile" => {
                self.void_modifier(p)?;
                count(p, 1, &[0])?;
                let path = p.dir.join(&p.prim.strings[0]);
                let text = self.source.read(&path).map_err(|m| p.err(m))?;
                let quote = self.source.may_quote(&path);
                let samples = read_specfile(&text).map_err(|m| {
                    if quote {
                        p.err(format!("{}: {m}", path.display()))
                    } else {
                        p.err(format!(
                            "{}: {}",
                            path.display(),
                            unquoted("not a usable spectrum file")
                        ))
                    }
                })?;
                if !self.out.files.contains(&path) {
                    self.out.files.push(path);
                }
                Ok(Modifier::Colour(multipliers(p, samples)?))
            }
            "brightfunc" | "colorfunc" | "brightdata" | "colordata" | "colorpict" | "brighttext" | "colortext"
            | "texfunc" | "texdata" | "mixfunc" | "mixdata" | "mixpict" | "mixtext" | "specfunc" | "specdata"
            | "specpict" => Err(p.err(format!("`{kind}`: {PATTERN_HINT}"))),
            "glass" | "dielectric" | "interface" | "trans" | "trans2" | "transfunc" | "transdata" | "transpict"
            | "plastic2" | "metal2" | "plasfunc" | "metfunc" | "plasdata" | "metdata" | "plaspict" | "metpict"
            | "BRTDfunc" | "BSDF" | "aBSDF" | "ashik2" | "prism1" | "prism2" | "mist" | "illum" | "antimatter"
            | "alias" | "mirage" => Err(p.err(format!(
                "the material type `{kind}` is not supported: lightbooth imports plastic, metal, mirror, light, \
                 glow and spotlight (approximate it by one of those)"
            ))),
            other => Err(p.err(format!("unknown primitive type `{other}`"))),
        }
    }

    /// A `spotlight`'s cone (reals 3–6: angle xdir ydir zdir) in scene
    /// coordinates: the orientation vector goes through the material's
    /// transform as `xform` moves it (rotated and scaled with the scene), and
    /// its length, the focal length, into metres.
    fn spot(&self, p: &Placed) -> Result<Spot, RadError> {
        let r = &p.prim.reals;
        let angle = r[3];
        if !(angle > 0.0 && angle <= 360.0) {
            return Err(p.err(format!("the cone angle {angle}° is outside (0°, 360°]")));
        }
        let aim = p.transform.vector(DVec3::new(r[4], r[5], r[6])) * self.metres_per_unit;
        let focal_length_m = aim.length();
        if !(focal_length_m > 0.0 && focal_length_m.is_finite()) {
            return Err(p.err(
                "zero focus vector (RADIANCE's error too): give the beam's direction, its length the focal distance",
            ));
        }
        Ok(Spot {
            axis: aim / focal_length_m,
            cos_half_angle: (angle.to_radians() / 2.0).cos(),
            focal_length_m,
        })
    }

    fn void_modifier(&self, p: &Placed) -> Result<(), RadError> {
        if p.prim.modifier != "void" {
            return Err(p.err(format!(
                "is modified by `{}`; a spectrum's modifier must be void (chained patterns are not supported)",
                p.prim.modifier
            )));
        }
        Ok(())
    }

    /// The colour modifier of a material: `None` for `void`.
    fn colour_of(&self, p: &Placed) -> Result<Option<Spectrum>, RadError> {
        match p.prim.modifier.as_str() {
            "void" => Ok(None),
            name => match self.modifiers.get(name) {
                Some(Modifier::Colour(s)) => Ok(Some(s.clone())),
                Some(_) => Err(p.err(format!(
                    "is modified by the material `{name}`: a material's modifier must be void, a `spectrum` or a \
                     `specfile`"
                ))),
                None => Err(p.err(format!("its modifier `{name}` is not defined before it"))),
            },
        }
    }

    fn black(&mut self) -> usize {
        if let Some(b) = self.black {
            return b;
        }
        let zero = Spectrum::constant(Grid::analysis(), SpectralUnit::Reflectance, 0.0).expect("0");
        self.out
            .materials
            .push(Material::lambertian("(black: a RADIANCE light reflects nothing)", zero));
        self.black = Some(self.out.materials.len() - 1);
        self.out.materials.len() - 1
    }

    fn surface(&mut self, p: &Placed) -> Result<(), RadError> {
        let kind = p.prim.kind.as_str();
        let modifier = p.modifier().to_string();
        let m = match modifier.as_str() {
            "void" => return Err(p.err("has no material (modifier void): give it one")),
            name => self
                .modifiers
                .get(name)
                .cloned()
                .ok_or_else(|| p.err(format!("its material `{name}` is not defined before it")))?,
        };
        let (material, emitter) = match m {
            Modifier::Reflecting(i) => (i, None),
            Modifier::Emitting(e) => (self.black(), Some(e)),
            Modifier::Colour(_) => {
                return Err(p.err(format!(
                    "is modified by the spectrum `{modifier}`: a spectrum colours a material \
                     (`void spectrum s …`, `s plastic m …`, `m {kind} …`)"
                )))
            }
        };
        let k = self.metres_per_unit;
        let t = p.transform;
        let r = &p.prim.reals;
        let point = |i: usize| t.point(DVec3::new(r[i], r[i + 1], r[i + 2])) * k;
        let length = |v: f64| v * t.scale * k;
        let mut shapes: Vec<Shape> = Vec::new();
        let mut triangles: Vec<Triangle> = Vec::new();
        match kind {
            "polygon" => {
                if !p.prim.strings.is_empty() || r.len() < 9 || !r.len().is_multiple_of(3) {
                    return Err(p.err(format!("takes 3·n ≥ 9 reals (n vertices), has {}", r.len())));
                }
                let v: Vec<DVec3> = placed_vertices(p, r).into_iter().map(|v| v * k).collect();
                if let Some(i) = v.iter().position(|v| !v.is_finite()) {
                    return Err(p.err(overflow_message(&format!("vertex {}", i + 1), k)));
                }
                triangles = tessellate::polygon(&v).map_err(|m| p.err(m))?;
            }
            "sphere" | "bubble" => {
                count(p, 0, &[4])?;
                let (c, radius) = (point(0), length(r[3]));
                if r[3] <= 0.0 {
                    return Err(p.err(format!(
                        "radius {} is not positive (for an inward-facing sphere write `bubble`)",
                        r[3]
                    )));
                }
                if emitter.is_some() {
                    triangles = tessellate::sphere(c, radius, kind == "bubble");
                } else {
                    shapes.push(Shape::Sphere { centre: c, radius });
                }
            }
            "cylinder" | "tube" | "cone" | "cup" => {
                let cylinder = matches!(kind, "cylinder" | "tube");
                count(p, 0, if cylinder { &[7] } else { &[8] })?;
                let (p0, p1) = (point(0), point(3));
                let (r0, r1) = if cylinder { (r[6], r[6]) } else { (r[6], r[7]) };
                if (p1 - p0).length() <= 0.0 {
                    return Err(p.err("its two end points coincide"));
                }
                if r0 < 0.0 || r1 < 0.0 || (r0 == 0.0 && r1 == 0.0) {
                    return Err(p.err(format!("radii {r0} and {r1}: they must be ≥ 0 and not both 0")));
                }
                let inward = matches!(kind, "tube" | "cup");
                if cylinder && emitter.is_none() {
                    let axis = p1 - p0;
                    shapes.push(Shape::Cylinder {
                        base: p0,
                        axis: axis.normalize(),
                        length: axis.length(),
                        radius: length(r0),
                    });
                } else {
                    triangles = tessellate::cone(p0, p1, length(r0), length(r1), inward);
                }
            }
            "ring" => {
                count(p, 0, &[8])?;
                let c = point(0);
                let dir = t.vector(DVec3::new(r[3], r[4], r[5]));
                if dir.length() <= 0.0 || !dir.is_finite() {
                    return Err(p.err("its normal direction is zero"));
                }
                let n = dir.normalize();
                let (r0, r1) = (r[6], r[7]);
                if !(r0 >= 0.0 && r1 > r0) {
                    return Err(p.err(format!("radii {r0} and {r1}: need 0 ≤ inner < outer")));
                }
                if r0 == 0.0 && emitter.is_none() {
                    shapes.push(Shape::Disc {
                        centre: c,
                        normal: n,
                        radius: length(r1),
                    });
                } else {
                    triangles = tessellate::ring(c, n, length(r0), length(r1));
                }
            }
            "source" => {
                return Err(p.err(
                    "a distant `source` (sun, sky) is not imported: lightbooth renders closed booths; \
                     model the light as a `light` sphere or polygon",
                ))
            }
            "instance" | "mesh" => {
                return Err(p.err(format!(
                    "`{kind}` (an octree or RADIANCE mesh) is not imported: give the geometry as an OBJ or \
                     PLY `[[mesh]]` in a TOML scene, or as polygons"
                )))
            }
            other => return Err(p.err(format!("unknown surface type `{other}`"))),
        }
        let finite_shapes = shapes.iter().all(|s| {
            let b = s.bounds();
            b.min.is_finite() && b.max.is_finite()
        });
        if !finite_shapes || !triangles.iter().flatten().all(|v| v.is_finite()) {
            return Err(p.err(overflow_message("its geometry", k)));
        }
        if self.out.primitives.len() + shapes.len() + triangles.len() > MAX_PRIMITIVES {
            return Err(p.err(format!(
                "the scene converts to more than {MAX_PRIMITIVES} renderer primitives (MAX_PRIMITIVES; \
                 emitting spheres, cones and rings are hundreds of triangles each): use fewer or simpler surfaces"
            )));
        }
        for shape in shapes {
            self.out.primitives.push(Primitive {
                shape,
                material,
                emitter,
            });
        }
        for [a, b, c] in triangles {
            if let Some(shape) = Shape::triangle(a, b, c) {
                self.out.primitives.push(Primitive {
                    shape,
                    material,
                    emitter,
                });
            }
        }
        Ok(())
    }
}

/// The error for geometry that is not finite once placed.
fn overflow_message(what: &str, metres_per_unit: f64) -> String {
    format!(
        "{what} is not a finite number once placed (the file's numbers × the enclosing `!xform`s × \
         {metres_per_unit} m per unit overflow): check the primitive's numbers and the transforms around it"
    )
}

/// The grey level k of an RGB that a spectrum multiplies (r = g = b).
fn grey(p: &Placed, rgb: [f64; 3]) -> Result<f64, RadError> {
    if rgb[0] == rgb[1] && rgb[1] == rgb[2] {
        Ok(rgb[0])
    } else {
        Err(p.err(format!(
            "RGB {rgb:?} with a spectrum modifier: give a grey (r = g = b, e.g. 1 1 1) and put the colour in \
             the spectrum"
        )))
    }
}

/// Multiplier samples (nm, value) as a spectrum on the 1 nm grid, linearly
/// interpolated, zero outside their range.
fn multipliers(p: &Placed, mut samples: Vec<(f64, f64)>) -> Result<Spectrum, RadError> {
    if let Some((nm, v)) = samples.iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
        return Err(p.err(format!("the value {v} at {nm} nm is negative or not finite")));
    }
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    if samples.len() < 2 || samples.windows(2).any(|w| w[0].0 == w[1].0) {
        return Err(p.err("needs at least two distinct wavelengths"));
    }
    let values = Grid::one_nm()
        .wavelengths()
        .iter()
        .map(|&nm| {
            let i = samples.partition_point(|s| s.0 <= nm);
            if i == 0 || (i == samples.len() && nm > samples[i - 1].0) {
                return 0.0;
            }
            if i == samples.len() {
                return samples[i - 1].1;
            }
            let (a, b) = (samples[i - 1], samples[i]);
            a.1 + (b.1 - a.1) * (nm - a.0) / (b.0 - a.0)
        })
        .collect();
    // Multipliers, not reflectances: a light's may exceed 1 (a material's
    // product with its grey is checked against [0, 1] where it is used).
    Spectrum::new(Grid::one_nm(), SpectralUnit::RelativePower, values).map_err(|e| p.err(e.to_string()))
}

/// A `specfile`: `wavelength value` pairs, or a RADIANCE 1-D data file
/// (`1`, then `nmA nmB N`, then N values). `#` starts a comment line.
fn read_specfile(text: &str) -> Result<Vec<(f64, f64)>, String> {
    let mut numbers = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.starts_with('#') {
            continue;
        }
        for w in line.split_whitespace() {
            match w.parse::<f64>() {
                Ok(v) if v.is_finite() => numbers.push(v),
                _ => return Err(format!("line {}: `{w}` is not a number", i + 1)),
            }
        }
    }
    if numbers.first() == Some(&1.0) && numbers.len() >= 4 {
        let (a, b, n) = (numbers[1], numbers[2], numbers[3]);
        if n.fract() == 0.0 && n >= 2.0 && numbers.len() == 4 + n as usize {
            let n = n as usize;
            return Ok((0..n)
                .map(|i| (a + (b - a) * i as f64 / (n - 1) as f64, numbers[4 + i]))
                .collect());
        }
        return Err("starts like a RADIANCE data file (`1`) but is not `1`, `nmA nmB N`, then N values".into());
    }
    if numbers.len() % 2 != 0 || numbers.is_empty() {
        return Err("expected `wavelength value` pairs".into());
    }
    Ok(numbers.chunks(2).map(|c| (c[0], c[1])).collect())
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;
    use std::path::{Path, PathBuf};

    use super::*;
    use crate::radiance::load::expand;

    struct Memory(HashMap<PathBuf, String>);

    impl Source for Memory {
        fn read(&mut self, path: &Path) -> Result<String, String> {
            self.0
                .get(path)
                .cloned()
                .ok_or_else(|| format!("cannot read {}", path.display()))
        }
    }

    fn load(text: &str, extra: &[(&str, &str)], k: f64) -> Result<RadianceScene, RadError> {
        let mut files: HashMap<PathBuf, String> =
            extra.iter().map(|(p, t)| (PathBuf::from(p), t.to_string())).collect();
        files.insert(PathBuf::from("s.rad"), text.to_string());
        let mut src = Memory(files);
        let stream = expand(Path::new("s.rad"), &mut src)?;
        convert(stream, k, &mut src)
    }

    const MATS: &str = "void plastic p 0 0 5 .6 .2 .1 .05 .1\nvoid metal m 0 0 5 .5 .5 .5 .9 .2\n\
                        void mirror mi 0 0 3 .9 .9 .9\nvoid light l 0 0 3 1 1 1\nvoid glow g 0 0 4 2 2 2 0\n";

    #[test]
    fn materials_become_surfaces_with_exact_rgb_and_emitters_with_179_per_unit() {
        let s = load(MATS, &[], 1.0).unwrap();
        assert_eq!(s.materials.len(), 3);
        assert_eq!(s.materials[0].name, "p");
        assert_eq!(
            s.materials[0].surface,
            Surface::Plastic {
                specularity: 0.05,
                roughness: 0.1
            }
        );
        assert_eq!(s.materials[0].rgb, Some([0.6, 0.2, 0.1]));
        assert_eq!(
            s.materials[1].surface,
            Surface::Metal {
                specularity: 0.9,
                roughness: 0.2
            }
        );
        assert_eq!(s.materials[2].surface, Surface::Mirror);
        // A grey is a flat spectrum.
        assert!(s.materials[1]
            .reflectance
            .values()
            .iter()
            .all(|v| (*v - 0.5).abs() < 1e-15));
        assert_eq!(s.emitters.len(), 2);
        assert_eq!(s.emitters[0].rgb, Some([179.0; 3]));
        assert_eq!(s.emitters[1].rgb, Some([358.0; 3]));
        assert!(!s.emitters[0].two_sided);
    }

    #[test]
    fn every_surface_type_becomes_shapes_in_metres() {
        let text = format!(
            "{MATS}p sphere s 0 0 4 1 2 3 0.5\np bubble b 0 0 4 0 0 0 1\np cylinder c 0 0 7 0 0 0 0 0 2 0.5\n\
             p tube t 0 0 7 0 0 0 2 0 0 0.5\np ring r 0 0 8 0 0 1 0 0 1 0 2\np ring a 0 0 8 0 0 1 0 0 1 1 2\n\
             p cone k 0 0 8 0 0 0 0 0 1 1 0\np cup u 0 0 8 0 0 0 0 0 1 1 0.5\n\
             p polygon q 0 0 12 0 0 0 1 0 0 1 1 0 0 1 0\n"
        );
        let s = load(&text, &[], 0.01).unwrap();
        let shapes: Vec<&Shape> = s.primitives.iter().map(|p| &p.shape).collect();
        match shapes[0] {
            Shape::Sphere { centre, radius } => {
                assert!((*centre - DVec3::new(0.01, 0.02, 0.03)).length() < 1e-15 && (*radius - 0.005).abs() < 1e-15)
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(shapes[1], Shape::Sphere { radius, .. } if (*radius - 0.01).abs() < 1e-15));
        match shapes[2] {
            Shape::Cylinder {
                base,
                axis,
                length,
                radius,
            } => {
                assert_eq!(*base, DVec3::ZERO);
                assert!((*axis - DVec3::Z).length() < 1e-15);
                assert!((*length - 0.02).abs() < 1e-15 && (*radius - 0.005).abs() < 1e-15);
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(shapes[3], Shape::Cylinder { .. }));
        match shapes[4] {
            Shape::Disc { centre, normal, radius } => {
                assert!((*centre - DVec3::new(0.0, 0.0, 0.01)).length() < 1e-15);
                assert_eq!(*normal, DVec3::Z);
                assert!((*radius - 0.02).abs() < 1e-15);
            }
            other => panic!("{other:?}"),
        }
        // The annulus, cone and cup are triangles: 2·256, 256, 2·256; the square 2.
        let triangles = shapes[5..]
            .iter()
            .filter(|s| matches!(s, Shape::Triangle { .. }))
            .count();
        assert_eq!(shapes.len() - 5, triangles);
        assert_eq!(triangles, 512 + 256 + 512 + 2);
        assert!(s.primitives.iter().all(|p| p.material == 0 && p.emitter.is_none()));
    }

    /// Emitting surfaces are triangles of a black material facing their
    /// front: out of a sphere, into a bubble.
    #[test]
    fn emitting_surfaces_are_oriented_triangles() {
        let s = load(
            &format!("{MATS}l sphere s 0 0 4 0 0 0 1\ng bubble b 0 0 4 0 0 0 3\n"),
            &[],
            1.0,
        )
        .unwrap();
        let black = s.materials.iter().position(|m| m.name.starts_with("(black")).unwrap();
        assert!(s.materials[black].reflectance.values().iter().all(|v| *v == 0.0));
        let (mut out, mut inward) = (0, 0);
        for p in &s.primitives {
            assert_eq!(p.material, black);
            let Shape::Triangle { p0, normal, .. } = p.shape else {
                panic!("{:?}", p.shape)
            };
            match p.emitter {
                Some(0) if normal.dot(p0) > 0.0 => out += 1,
                Some(1) if normal.dot(p0) < 0.0 => inward += 1,
                other => panic!("{other:?} {normal} {p0}"),
            }
        }
        assert_eq!((out, inward), (5120, 5120));
    }

    /// `spectrum` and `specfile` colour a grey material: reflectance k·s(λ),
    /// interpolated between samples and zero outside their range.
    #[test]
    fn spectrum_and_specfile_colour_a_grey_material() {
        let text = "void spectrum sp 0 0 5 400 700 0.2 0.8 0.4\nsp plastic a 0 0 5 .5 .5 .5 0 0\n\
                    void specfile sf 1 refl.dat 0 0\nsf metal b 0 0 5 1 1 1 .5 .1\n";
        let s = load(text, &[("refl.dat", "# nm value\n400 0.1\n500 0.3\n800 0.5\n")], 1.0).unwrap();
        let a = &s.materials[0];
        assert_eq!(a.rgb, None);
        let at = |m: &Material, nm: f64| m.reflectance.values()[(nm - 380.0) as usize];
        assert_eq!(at(a, 390.0), 0.0);
        assert!((at(a, 400.0) - 0.1).abs() < 1e-12);
        assert!((at(a, 475.0) - 0.5 * 0.5).abs() < 1e-12);
        assert!((at(a, 700.0) - 0.2).abs() < 1e-12);
        assert_eq!(at(a, 701.0), 0.0);
        let b = &s.materials[1];
        assert!((at(b, 450.0) - 0.2).abs() < 1e-12);
        assert!((at(b, 780.0) - (0.3 + 0.2 * 280.0 / 300.0)).abs() < 1e-12);
        assert_eq!(s.files.len(), 2);
        // A RADIANCE data file gives the same.
        let d = load(
            "void specfile sf 1 d.dat 0 0\nsf plastic c 0 0 5 1 1 1 0 0\n",
            &[("d.dat", "1\n400 700 3\n0.2 0.8 0.4\n")],
            1.0,
        )
        .unwrap();
        assert!((at(&d.materials[0], 475.0) - 0.5).abs() < 1e-12);
        // A light's multipliers may exceed 1: a flat 2 doubles RADIANCE's 179 cd/m² per unit.
        let l = load(
            "void spectrum w 0 0 5 380 780 2 2 2\nw light lw 0 0 3 1 1 1\n",
            &[],
            1.0,
        )
        .unwrap();
        assert_eq!(l.emitters[0].rgb, None);
        let y = lightbooth_science::colorimetry::xyz_from_radiance(&l.emitters[0].radiance, crate::coding::OBSERVER)
            .unwrap()
            .y;
        assert!((y / 358.0 - 1.0).abs() < 1e-9, "{y}");
    }

    #[test]
    fn a_spotlight_is_a_light_with_its_cone_moved_by_xform_and_its_focal_length_in_metres() {
        // xform -rx 90 turns (0, 0, −1.5) into (0, 1.5, 0), -s 2 doubles it:
        // (0, 3, 0) file units, 0.03 m at 1 cm per unit.
        let d = load(
            "!xform -rx 90 -s 2 lamp.rad\n",
            &[(
                "lamp.rad",
                "void spotlight s 0 0 7 2 2 2 60 0 0 -1.5\ns polygon p 0 0 9 0 0 0 1 0 0 0 1 0\n",
            )],
            0.01,
        )
        .unwrap();
        let e = &d.emitters[0];
        assert_eq!(e.rgb, Some([2.0 * RADIANCE_EFFICACY; 3]));
        assert!(!e.two_sided && e.name.starts_with("spotlight s"), "{}", e.name);
        let spot = e.spot.expect("a spotlight has a cone");
        assert!(spot.axis.distance(DVec3::Y) < 1e-12, "{:?}", spot.axis);
        assert!((spot.focal_length_m - 0.03).abs() < 1e-12, "{}", spot.focal_length_m);
        assert!((spot.cos_half_angle - 30f64.to_radians().cos()).abs() < 1e-15);
        assert!(load("void light l 0 0 3 1 1 1\n", &[], 1.0).unwrap().emitters[0]
            .spot
            .is_none());
    }

    #[test]
    fn refusals_name_the_file_line_primitive_and_what_to_do() {
        for (text, want) in [
            (
                "\nvoid brightfunc f 2 x x.cal 0 0\n",
                "s.rad:2: brightfunc f: `brightfunc`: patterns",
            ),
            (
                "void spotlight s 0 0 7 1 1 1 30 0 0 0\n",
                "s.rad:1: spotlight s: zero focus vector",
            ),
            (
                "void spotlight s 0 0 7 1 1 1 0 0 0 -1\n",
                "s.rad:1: spotlight s: the cone angle 0° is outside (0°, 360°]",
            ),
            (
                "void spotlight s 0 0 6 1 1 1 30 0 0\n",
                "takes 0 string and 7 real arguments",
            ),
            (
                "void glass g 0 0 3 .9 .9 .9\n",
                "material type `glass` is not supported",
            ),
            ("void glow g 0 0 4 1 1 1 -1\n", "maxrad -1 < 0"),
            (
                "void plastic p 0 0 5 1.2 .5 .5 0 0\n",
                "red reflectance 1.2 is outside [0, 1]",
            ),
            (
                "void plastic p 0 0 4 1 .5 .5 0\n",
                "takes 0 string and 5 real arguments",
            ),
            (
                "nope polygon q 0 0 9 0 0 0 1 0 0 0 1 0\n",
                "s.rad:1: polygon q: its material `nope` is not defined",
            ),
            ("void polygon q 0 0 9 0 0 0 1 0 0 0 1 0\n", "has no material"),
            (
                "void spectrum sp 0 0 5 400 700 1 1 1\nsp polygon q 0 0 9 0 0 0 1 0 0 0 1 0\n",
                "a spectrum colours a material",
            ),
            (
                "void spectrum sp 0 0 5 400 700 1 1 1\nsp plastic c 0 0 5 1 .5 .5 0 0\n",
                "give a grey",
            ),
            (
                "void spectrum sp 0 0 5 400 700 1 1 2\nsp plastic c 0 0 5 .8 .8 .8 0 0\n",
                "above 1",
            ),
            (
                "void plastic p 0 0 5 .5 .5 .5 0 0\np sphere s 0 0 4 0 0 0 -1\n",
                "write `bubble`",
            ),
            (
                "void plastic p 0 0 5 .5 .5 .5 0 0\np instance i 1 x.oct 0 0\n",
                "OBJ or PLY",
            ),
            (
                "void plastic p 0 0 5 .5 .5 .5 0 0\np source sun 0 0 4 0 0 1 0.5\n",
                "distant `source`",
            ),
            (
                "void plastic p 0 0 5 .5 .5 .5 0 0\np ring r 0 0 8 0 0 0 0 0 1 2 1\n",
                "0 ≤ inner < outer",
            ),
        ] {
            let e = load(text, &[], 1.0).unwrap_err().to_string();
            assert!(e.contains(want), "{text}: {e}");
        }
    }
}
