//! RADIANCE's `genbox`, evaluated natively: `genbox mat name xsize ysize
//! zsize [-i]` is the box [0, xsize] × [0, ysize] × [0, zsize] as six
//! `polygon`s named `name.1540`, `name.4620`, `name.2310`, `name.3267`,
//! `name.5137`, `name.6457` (the digits are the corners, bit 0 = x, bit 1 =
//! y, bit 2 = z), each wound so its normal points out of the box, or into
//! it with `-i` — the vertices `genbox.c` writes, in its order. The rounded
//! (`-r`) and bevelled (`-b`) boxes are refused.

use glam::DVec3;

/// One face: its name suffix and vertices in order.
pub type Face = (&'static str, [DVec3; 4]);

/// The corner names and vertex orders `genbox` writes (outward normals).
const FACES: [(&str, [usize; 4]); 6] = [
    ("1540", [1, 5, 4, 0]),
    ("4620", [4, 6, 2, 0]),
    ("2310", [2, 3, 1, 0]),
    ("3267", [3, 2, 6, 7]),
    ("5137", [5, 1, 3, 7]),
    ("6457", [6, 4, 5, 7]),
];

/// The parsed arguments after `genbox`: material, name, size, inward.
#[derive(Clone, Debug, PartialEq)]
pub struct Genbox {
    pub material: String,
    pub name: String,
    pub size: DVec3,
    pub inward: bool,
}

pub fn parse_genbox(args: &[String]) -> Result<Genbox, String> {
    const USAGE: &str = "genbox MATERIAL NAME XSIZE YSIZE ZSIZE [-i]";
    if args.len() < 5 {
        return Err(format!("needs {USAGE}"));
    }
    let mut size = [0.0; 3];
    for (k, w) in args[2..5].iter().enumerate() {
        size[k] = match w.parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => v,
            _ => return Err(format!("size `{w}` must be a positive number ({USAGE})")),
        };
    }
    let mut inward = false;
    for w in &args[5..] {
        match w.as_str() {
            "-i" => inward = true,
            "-r" | "-b" => {
                return Err(format!(
                    "`{w}` (rounded or bevelled edges) is not supported: model the edges as polygons, or drop `{w}`"
                ))
            }
            other => return Err(format!("unexpected `{other}` ({USAGE})")),
        }
    }
    Ok(Genbox {
        material: args[0].clone(),
        name: args[1].clone(),
        size: DVec3::from(size),
        inward,
    })
}

impl Genbox {
    /// The six faces, in `genbox`'s order.
    pub fn faces(&self) -> Vec<Face> {
        let corner = |i: usize| {
            DVec3::new(
                if i & 1 != 0 { self.size.x } else { 0.0 },
                if i & 2 != 0 { self.size.y } else { 0.0 },
                if i & 4 != 0 { self.size.z } else { 0.0 },
            )
        };
        FACES
            .iter()
            .map(|&(name, order)| {
                let mut v = order.map(corner);
                if self.inward {
                    v.reverse();
                }
                (name, v)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    /// The vertices RADIANCE's `genbox mat box 1 2 3` writes for its first
    /// and last faces, and every face's normal points out of the box.
    #[test]
    fn faces_match_genbox_and_point_outwards() {
        let b = parse_genbox(&args("mat box 1 2 3")).unwrap();
        let faces = b.faces();
        assert_eq!(faces.len(), 6);
        assert_eq!(
            faces[0],
            (
                "1540",
                [
                    DVec3::new(1.0, 0.0, 0.0),
                    DVec3::new(1.0, 0.0, 3.0),
                    DVec3::new(0.0, 0.0, 3.0),
                    DVec3::ZERO
                ]
            )
        );
        assert_eq!(
            faces[5].1,
            [
                DVec3::new(0.0, 2.0, 3.0),
                DVec3::new(0.0, 0.0, 3.0),
                DVec3::new(1.0, 0.0, 3.0),
                DVec3::new(1.0, 2.0, 3.0)
            ]
        );
        let centre = DVec3::new(0.5, 1.0, 1.5);
        for inward in [false, true] {
            let b = Genbox { inward, ..b.clone() };
            for (name, v) in b.faces() {
                let n = (v[1] - v[0]).cross(v[2] - v[0]);
                let out = (v[0] - centre).dot(n) > 0.0;
                assert_eq!(out, !inward, "face {name}");
            }
        }
    }

    #[test]
    fn rounded_boxes_and_bad_sizes_are_refused() {
        assert!(parse_genbox(&args("mat box 1 2 3 -r 0.1"))
            .unwrap_err()
            .contains("rounded"));
        assert!(parse_genbox(&args("mat box 1 -2 3")).unwrap_err().contains("positive"));
        assert!(parse_genbox(&args("mat box 1 2")).unwrap_err().contains("needs"));
        assert!(parse_genbox(&args("mat box 1 2 3 -i")).unwrap().inward);
    }
}
