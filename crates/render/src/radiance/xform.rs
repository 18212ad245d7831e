//! RADIANCE's `xform` command, evaluated natively: its options as a list
//! of placed copies (one per array element), and the rigid-body-plus-scale
//! transforms that place them.
//!
//! The semantics are those of RADIANCE's `xform.c` and `xf.c`:
//! transformations apply in command-line order; `-i N` ends the current
//! block and repeats the following one N times; `-a N` makes N copies,
//! copy k applying the following block k times (k = 0 … N − 1; `xform`
//! implements it by re-running itself with `-i k`), so
//! `xform [initial] -a Na [outer] -a Nb [inner] -i 1 [final]` gives copy
//! (ka, kb) = final ∘ innerᵏᵇ ∘ outerᵏᵃ ∘ initial. Copies are named as
//! `xform` names them: with `-n name`, surfaces get the prefix `name.`
//! (`name.ka.kb.` in arrays); without it, arrays prefix `a{ka}.{kb}.`.
//! As in `xform`, materials keep their identifiers; `-m mat` gives every
//! surface the modifier `mat`. `-e` (echo the command as a comment) is
//! accepted and has no effect. A negative determinant (a mirror: `-mx`,
//! `-my`, `-mz` or a negative `-s`) reverses polygon vertex order so each
//! surface keeps its front side, as `xform` does.

use glam::{DAffine3, DMat3, DVec3};

/// A similarity transform: rotation, uniform scale, mirror, translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub affine: DAffine3,
    /// |scale| of lengths (radii).
    pub scale: f64,
    /// True when the determinant is negative (an odd number of mirrors).
    pub mirrored: bool,
}

impl Default for Transform {
    fn default() -> Self {
        Transform::IDENTITY
    }
}

impl Transform {
    pub const IDENTITY: Transform = Transform {
        affine: DAffine3::IDENTITY,
        scale: 1.0,
        mirrored: false,
    };

    pub fn translation(t: DVec3) -> Transform {
        Transform {
            affine: DAffine3::from_translation(t),
            ..Transform::IDENTITY
        }
    }

    /// Rotation by `deg` degrees about `axis` (0 = x, 1 = y, 2 = z),
    /// counter-clockwise looking down the axis towards the origin.
    pub fn rotation(axis: usize, deg: f64) -> Transform {
        let a = deg.to_radians();
        let m = match axis {
            0 => DMat3::from_rotation_x(a),
            1 => DMat3::from_rotation_y(a),
            _ => DMat3::from_rotation_z(a),
        };
        Transform {
            affine: DAffine3::from_mat3(m),
            ..Transform::IDENTITY
        }
    }

    /// Uniform scale by `s` ≠ 0 (negative: a point reflection).
    pub fn scaling(s: f64) -> Transform {
        Transform {
            affine: DAffine3::from_scale(DVec3::splat(s)),
            scale: s.abs(),
            mirrored: s < 0.0,
        }
    }

    /// Mirror in the plane normal to `axis`.
    pub fn mirror(axis: usize) -> Transform {
        let mut s = DVec3::ONE;
        s[axis] = -1.0;
        Transform {
            affine: DAffine3::from_scale(s),
            scale: 1.0,
            mirrored: true,
        }
    }

    /// `self` first, then `next`.
    pub fn then(&self, next: &Transform) -> Transform {
        #[cfg(test)]
        tests::PRODUCTS.with(|n| n.set(n.get() + 1));
        Transform {
            affine: next.affine * self.affine,
            scale: self.scale * next.scale,
            mirrored: self.mirrored != next.mirrored,
        }
    }

    /// `self` applied `n` times (by repeated squaring: 2·log₂ n products).
    pub fn power(&self, n: u64) -> Transform {
        let (mut result, mut base, mut n) = (Transform::IDENTITY, *self, n);
        while n > 0 {
            if n & 1 == 1 {
                result = result.then(&base);
            }
            n >>= 1;
            if n > 0 {
                base = base.then(&base);
            }
        }
        result
    }

    pub fn point(&self, p: DVec3) -> DVec3 {
        self.affine.transform_point3(p)
    }

    /// A direction (not normalised; translation ignored).
    pub fn vector(&self, v: DVec3) -> DVec3 {
        self.affine.transform_vector3(v)
    }
}

/// An `xform` command: where its copies go and which files it reads.
#[derive(Clone, Debug, PartialEq)]
pub struct Xform {
    /// One entry per copy: its transform and the prefix of its surfaces'
    /// identifiers (`name.` or `a0.1.`; empty without `-n` or arrays).
    pub copies: Vec<(Transform, String)>,
    /// `-m`: the modifier every surface takes instead of its own.
    pub material: Option<String>,
    /// The files, as written (relative to the file holding the command).
    pub files: Vec<String>,
}

/// The most copies one `xform` may make (the product of its `-a` counts)
/// and the largest `-i` count: beyond that is refused, not computed.
pub const MAX_COPIES: u64 = 100_000;

/// The most `-a` arrays one `xform` may nest.
pub const MAX_ARRAYS: usize = 8;

/// The longest `-n` name, bytes (every copy's identifiers carry it).
pub const MAX_NAME_BYTES: usize = 64;

/// A block of transformations and how it repeats.
enum Repeat {
    /// Once (the initial block) or N times (`-i N`).
    Times(u64),
    /// Copy k applies it k times (`-a N`).
    Array(u64),
}

/// Interprets the words after `xform`.
pub fn parse_xform(args: &[String]) -> Result<Xform, String> {
    let mut blocks: Vec<(Repeat, Transform)> = vec![(Repeat::Times(1), Transform::IDENTITY)];
    let mut name: Option<String> = None;
    let mut material = None;
    let mut i = 0;
    let num = |i: usize, opt: &str| -> Result<f64, String> {
        let w = args.get(i).ok_or_else(|| format!("`{opt}` needs a number after it"))?;
        match w.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!("`{opt} {w}`: `{w}` is not a finite number")),
        }
    };
    let count = |i: usize, opt: &str| -> Result<u64, String> {
        let w = args.get(i).ok_or_else(|| format!("`{opt}` needs a count after it"))?;
        let n: u64 = w
            .parse()
            .map_err(|_| format!("`{opt} {w}`: `{w}` is not a whole number ≥ 0"))?;
        if n > MAX_COPIES {
            return Err(format!("`{opt} {n}`: more than the {MAX_COPIES} accepted"));
        }
        Ok(n)
    };
    while i < args.len() && args[i].starts_with('-') && args[i].len() > 1 {
        let opt = args[i].as_str();
        let step = match opt {
            "-t" => {
                let t = DVec3::new(num(i + 1, opt)?, num(i + 2, opt)?, num(i + 3, opt)?);
                i += 3;
                Some(Transform::translation(t))
            }
            "-rx" | "-ry" | "-rz" => {
                let axis = (opt.as_bytes()[2] - b'x') as usize;
                i += 1;
                Some(Transform::rotation(axis, num(i, opt)?))
            }
            "-s" => {
                i += 1;
                let s = num(i, opt)?;
                if s == 0.0 {
                    return Err("`-s 0` collapses everything to a point".into());
                }
                Some(Transform::scaling(s))
            }
            "-mx" | "-my" | "-mz" => Some(Transform::mirror((opt.as_bytes()[2] - b'x') as usize)),
            "-i" => {
                i += 1;
                blocks.push((Repeat::Times(count(i, opt)?), Transform::IDENTITY));
                None
            }
            "-a" => {
                i += 1;
                blocks.push((Repeat::Array(count(i, opt)?), Transform::IDENTITY));
                None
            }
            "-n" => {
                i += 1;
                let n = args.get(i).ok_or("`-n` needs a name after it")?;
                if n.len() > MAX_NAME_BYTES {
                    return Err(format!(
                        "`-n`: a name of {} bytes, more than the {MAX_NAME_BYTES} accepted",
                        n.len()
                    ));
                }
                name = Some(n.clone());
                None
            }
            "-m" => {
                i += 1;
                material = Some(args.get(i).ok_or("`-m` needs a material after it")?.clone());
                None
            }
            "-e" => None,
            "-c" => return Err("`-c` (commands per copy) runs programs, which lightbooth never does".into()),
            _ => {
                return Err(format!(
                    "option `{opt}` is not supported (lightbooth evaluates -t, -rx, -ry, -rz, -s, -mx, -my, -mz, \
                     -a, -i, -n, -m and -e)"
                ))
            }
        };
        if let Some(s) = step {
            let last = blocks.last_mut().expect("the initial block");
            last.1 = last.1.then(&s);
        }
        i += 1;
    }
    let files: Vec<String> = args[i..].to_vec();
    if files.is_empty() {
        return Err("no file to transform (xform would read standard input, which a scene file cannot give)".into());
    }
    if let Some(f) = files.iter().find(|f| f.starts_with('-')) {
        return Err(format!("`{f}` after the file names: options go before the files"));
    }
    let arrays: Vec<u64> = blocks
        .iter()
        .filter_map(|(r, _)| match r {
            Repeat::Array(n) => Some(*n),
            Repeat::Times(_) => None,
        })
        .collect();
    if arrays.len() > MAX_ARRAYS {
        return Err(format!(
            "{} arrays (-a): more than the {MAX_ARRAYS} one xform may nest",
            arrays.len()
        ));
    }
    let total = arrays.iter().try_fold(1u64, |acc, &n| acc.checked_mul(n));
    let total = match total {
        Some(t) if t <= MAX_COPIES => t,
        _ => return Err(format!("the arrays make more than {MAX_COPIES} copies (MAX_COPIES)")),
    };
    // Copy (k₁ … k_m) = after_m ∘ b_mᵏᵐ ∘ … ∘ after_1 ∘ b₁ᵏ¹ ∘ before: the
    // repeated (-i) blocks are composed once, and each array's powers
    // b⁰ … bⁿ⁻¹ are built one product at a time (linear in n).
    let mut before = Transform::IDENTITY;
    let mut levels: Vec<(Vec<Transform>, Transform)> = Vec::new();
    if total > 0 {
        for (r, b) in &blocks {
            match r {
                Repeat::Times(n) => {
                    let t = b.power(*n);
                    match levels.last_mut() {
                        Some((_, after)) => *after = after.then(&t),
                        None => before = before.then(&t),
                    }
                }
                Repeat::Array(n) => {
                    let mut powers = Vec::with_capacity(*n as usize);
                    let mut p = Transform::IDENTITY;
                    for _ in 0..*n {
                        powers.push(p);
                        p = p.then(b);
                    }
                    levels.push((powers, Transform::IDENTITY));
                }
            }
        }
    }
    // Every combination of array indices, the first array outermost.
    let mut copies = Vec::with_capacity(total as usize);
    let mut ks = vec![0usize; levels.len()];
    for _ in 0..total {
        let t = levels
            .iter()
            .zip(&ks)
            .fold(before, |acc, ((powers, after), &k)| acc.then(&powers[k]).then(after));
        let suffix: String = ks.iter().map(|k| format!(".{k}")).collect();
        let prefix = match (&name, ks.is_empty()) {
            (Some(n), _) => format!("{n}{suffix}."),
            (None, true) => String::new(),
            (None, false) => format!("a{}.", &suffix[1..]),
        };
        copies.push((t, prefix));
        // The next combination: the last array fastest.
        for level in (0..ks.len()).rev() {
            ks[level] += 1;
            if ks[level] < levels[level].0.len() {
                break;
            }
            ks[level] = 0;
        }
    }
    Ok(Xform {
        copies,
        material,
        files,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    thread_local! {
        /// Transform products computed on this thread (the work of `parse_xform`).
        pub static PRODUCTS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    }

    fn products_of(a: &str) -> (usize, u64) {
        PRODUCTS.with(|n| n.set(0));
        let copies = parse_xform(&args(a)).unwrap().copies.len();
        (copies, PRODUCTS.with(|n| n.get()))
    }

    /// `-a N` used to compute copy k as k products from scratch: N²/2
    /// products (5·10⁹ for N = 100 000, 96 s). Now each copy costs a few.
    #[test]
    fn xform_arrays_are_linear_in_their_count() {
        for n in [10u64, 1000, 100_000] {
            let (copies, products) = products_of(&format!("-t 1 0 0 -a {n} -t 2 0 0 -rz 1 f"));
            assert_eq!(copies as u64, n);
            assert!(products <= 4 * n + 16, "-a {n}: {products} products");
        }
        // Nested arrays: work proportional to the copies, not to their squares.
        let (copies, products) = products_of("-a 300 -t 1 0 0 -a 300 -rz 1 -i 2 -s 2 f");
        assert_eq!(copies, 90_000);
        assert!(products <= 4 * 90_000 + 4 * 600 + 64, "{products} products");
        // -i N is repeated squaring.
        let (_, products) = products_of("-i 100000 -t 1 0 0 f");
        assert!(products <= 64, "{products} products");
        let t = parse_xform(&args("-i 100000 -t 1 0 0 f")).unwrap().copies[0].0;
        assert!(close(t.point(DVec3::ZERO), DVec3::new(100_000.0, 0.0, 0.0)));
    }

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-12
    }

    #[test]
    fn transforms_apply_in_command_order() {
        // Translate then rotate: (1, 0, 0) → (2, 0, 0) → (0, 2, 0) after rz 90.
        let x = parse_xform(&args("-t 1 0 0 -rz 90 -s 2 f.rad")).unwrap();
        assert_eq!(x.files, ["f.rad"]);
        assert_eq!(x.copies.len(), 1);
        let (t, prefix) = &x.copies[0];
        assert!(prefix.is_empty());
        assert!(close(t.point(DVec3::new(1.0, 0.0, 0.0)), DVec3::new(0.0, 4.0, 0.0)));
        assert_eq!(t.scale, 2.0);
        assert!(!t.mirrored);
        let rx = parse_xform(&args("-rx 90 f")).unwrap().copies[0].0;
        assert!(close(rx.point(DVec3::Y), DVec3::Z));
        let ry = parse_xform(&args("-ry 90 f")).unwrap().copies[0].0;
        assert!(close(ry.point(DVec3::Z), DVec3::X));
        let m = parse_xform(&args("-mx -s -3 f")).unwrap().copies[0].0;
        assert!(!m.mirrored && m.scale == 3.0);
        assert!(close(m.point(DVec3::new(1.0, 1.0, 1.0)), DVec3::new(3.0, -3.0, -3.0)));
    }

    /// The points and names RADIANCE's own `xform -n foo -a 2 -t 1 0 0 -a 2
    /// -rz 90 -i 1 -t 0 0 5` gives the point (1, 0, 0) (run once with
    /// pyradiance's xform to check the reading of `-a` and `-i`).
    #[test]
    fn arrays_nest_and_name_as_xform_does() {
        let x = parse_xform(&args("-n foo -a 2 -t 1 0 0 -a 2 -rz 90 -i 1 -t 0 0 5 f.rad")).unwrap();
        let got: Vec<(DVec3, &str)> = x.copies.iter().map(|(t, n)| (t.point(DVec3::X), n.as_str())).collect();
        let want = [
            (DVec3::new(1.0, 0.0, 5.0), "foo.0.0."),
            (DVec3::new(0.0, 1.0, 5.0), "foo.0.1."),
            (DVec3::new(2.0, 0.0, 5.0), "foo.1.0."),
            (DVec3::new(0.0, 2.0, 5.0), "foo.1.1."),
        ];
        assert_eq!(got.len(), 4);
        for ((p, n), (wp, wn)) in got.iter().zip(want) {
            assert!(close(*p, wp), "{p} vs {wp}");
            assert_eq!(*n, wn);
        }
        let unnamed = parse_xform(&args("-a 3 -rz 120 f")).unwrap();
        assert_eq!(unnamed.copies[2].1, "a2.");
        assert!(close(
            unnamed.copies[1].0.point(DVec3::X),
            DMat3::from_rotation_z(120f64.to_radians()) * DVec3::X
        ));
        let it = parse_xform(&args("-i 3 -t 1 0 0 f")).unwrap();
        assert!(close(it.copies[0].0.point(DVec3::ZERO), DVec3::new(3.0, 0.0, 0.0)));
    }

    #[test]
    fn refusals_say_why() {
        for (a, want) in [
            ("-t 1 0 0", "standard input"),
            ("-t 1 0 f", "not a finite number"),
            ("-c 'echo' f", "runs programs"),
            ("-q f", "not supported"),
            ("-a 1000 -a 1000 f", "more than"),
            ("-s 0 f", "collapses"),
            ("-a -2 f", "whole number"),
            (
                "-a 2 -a 2 -a 2 -a 2 -a 2 -a 2 -a 2 -a 2 -a 1 f",
                "more than the 8 one xform may nest",
            ),
        ] {
            let e = parse_xform(&args(a)).unwrap_err();
            assert!(e.contains(want), "{a}: {e}");
        }
    }
}
